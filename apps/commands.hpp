#pragma once
// hedgefit's subcommands: each adds itself to the CLI11 app and returns the exit
// code through `*exit_code` when run. Exit codes: 0 ok, 1 bad input or usage,
// 2 processing failure.

#include <CLI/CLI.hpp>

#include "pipeline/error.hpp"

#include <functional>
#include <string>

namespace hedgefit::apps {

inline constexpr int kExitOk = 0;
inline constexpr int kExitBadInput = 1;
inline constexpr int kExitProcessing = 2;
/// Results were printed, but at least one cannot be acted on: its inputs failed a check (the rig
/// no longer fits the cameras); its JSON line's "unusable" says why.
inline constexpr int kExitUnusable = 3;

/// A subcommand's body; throws hedgefit::Error for bad input.
using CommandFn = std::function<int()>;

void AddInfoCommand(CLI::App& app, CommandFn* run);
void AddPipelineCommand(CLI::App& app, CommandFn* run);
void AddPluginsCommand(CLI::App& app, CommandFn* run);
void AddCompareCommand(CLI::App& app, CommandFn* run);
void AddCalibrateCommand(CLI::App& app, CommandFn* run);
void AddRigCommand(CLI::App& app, CommandFn* run);
void AddCheckRigCommand(CLI::App& app, CommandFn* run);
void AddSimulateCommand(CLI::App& app, CommandFn* run);
void AddRenderCommand(CLI::App& app, CommandFn* run);
void AddConvertCommand(CLI::App& app, CommandFn* run);
void AddMeasureCommand(CLI::App& app, CommandFn* run);
void AddTrimCommand(CLI::App& app, CommandFn* run);
void AddStreamCommand(CLI::App& app, CommandFn* run);
void AddBenchCommand(CLI::App& app, CommandFn* run);

/// The global registry with every built-in stage and the plugins on the search path.
void PrepareRegistry(bool load_plugins);

}  // namespace hedgefit::apps
