#pragma once
// hedgefit's subcommands: each adds itself to the CLI11 app and, when parsed, sets `*run` to its
// body, which returns an exit code (cli/run.hpp). The flag helpers they share are in cli/.

#include <CLI/CLI.hpp>

#include "cli/run.hpp"
#include "pipeline/error.hpp"

#include <functional>
#include <string>

namespace hedgefit::apps {

using namespace hedgefit::cli;  // exit codes, CommandFn, PrepareRegistry, the flag helpers

void AddInfoCommand(CLI::App& app, CommandFn* run);
void AddPipelineCommand(CLI::App& app, CommandFn* run);
void AddPluginsCommand(CLI::App& app, CommandFn* run);
void AddCompareCommand(CLI::App& app, CommandFn* run);
void AddCalibrateCommand(CLI::App& app, CommandFn* run);
void AddRigCommand(CLI::App& app, CommandFn* run);
void AddCheckRigCommand(CLI::App& app, CommandFn* run);
void AddRenderCommand(CLI::App& app, CommandFn* run);
void AddConvertCommand(CLI::App& app, CommandFn* run);
void AddMeasureCommand(CLI::App& app, CommandFn* run);
void AddTrimCommand(CLI::App& app, CommandFn* run);
void AddStreamCommand(CLI::App& app, CommandFn* run);
void AddFindCommand(CLI::App& app, CommandFn* run);

/// When argv[1] names a command of hedgefit-bench (`simulate`, `bench`), runs that program, found
/// beside this one, with the same arguments (its usage lines still say `hedgefit`); returns only
/// when it cannot (the exit code for a one-line error already printed), or -1 for any other
/// command.
int ForwardToBenchProgram(int argc, char** argv);

}  // namespace hedgefit::apps
