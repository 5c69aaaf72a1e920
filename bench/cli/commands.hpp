#pragma once
// hedgefit-bench's two commands, `simulate` and `bench` (hedgefit hands them over: apps/forward.cpp):
// each adds itself to the CLI11 app and, when parsed, sets `*run` to its body (cli/run.hpp).

#include <CLI/CLI.hpp>

#include "cli/run.hpp"

namespace hedgefit::bench_cli {

using namespace hedgefit::cli;  // exit codes, CommandFn, PrepareRegistry, the flag helpers

void AddSimulateCommand(CLI::App& app, CommandFn* run);
void AddBenchCommand(CLI::App& app, CommandFn* run);

}  // namespace hedgefit::bench_cli
