#pragma once
// What every hedgefit command shares around its own work: the exit codes, the registry of
// built-in stages and plugins, and a command line run with one-line errors ("did you mean").

#include <CLI/CLI.hpp>

#include <functional>

namespace hedgefit::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitBadInput = 1;
inline constexpr int kExitProcessing = 2;
/// Results were printed, but at least one cannot be acted on: its inputs failed a check (the rig
/// no longer fits the cameras); its JSON line's "unusable" says why.
inline constexpr int kExitUnusable = 3;

/// A subcommand's body, set by the subcommand's parse callback; throws hedgefit::Error for bad
/// input, ProcessingError for a failure.
using CommandFn = std::function<int()>;

/// The global registry with every built-in stage and the plugins on the search path.
void PrepareRegistry(bool load_plugins);

/// Parses `argv` into `app` and runs what a subcommand set in `*run`; every error is one line on
/// stderr naming the command (and the closest command or flag to a mistyped one), and an exit
/// code: kExitBadInput for usage and hedgefit::Error, kExitProcessing for failures.
int RunCommandLine(CLI::App& app, int argc, char** argv, const CommandFn* run);

/// The allocator's and the libraries' settings both programs (hedgefit, hedgefit-bench) start with.
void PrepareProcess();

// `simulate` and `bench` live in their own program, hedgefit-bench (bench/cli/), which alone
// links the simulator and the benches; hedgefit lists them and hands them over
// (apps/forward.cpp). Their one-line descriptions, shared by both programs' --help:
inline constexpr char kSimulateAbout[] =
    "Render a simulated stereo rig's view of a chessboard or a textured sphere, with truth";
inline constexpr char kBenchAbout[] = "End-to-end benchmarks";
/// The name of the program that runs `simulate` and `bench`, built beside hedgefit.
inline constexpr char kBenchProgram[] = "hedgefit-bench";

}  // namespace hedgefit::cli
