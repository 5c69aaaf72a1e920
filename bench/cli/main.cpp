// hedgefit-bench: `hedgefit simulate` and `hedgefit bench`, the commands that need the simulator
// and the benches, in a program of their own beside the benches they run, so that hedgefit links
// neither. hedgefit hands them over (apps/forward.cpp); run directly, it takes the same arguments.

#include <string>

#include "bench/cli/commands.hpp"
#include "pipeline/version.hpp"

int main(int argc, char** argv) {
  using namespace hedgefit::bench_cli;
  PrepareProcess();
  CLI::App app{"hedgefit " + std::string(hedgefit::kVersion) +
               ": the simulator and the benchmarks (hedgefit simulate, hedgefit bench)"};
  app.set_version_flag("--version", std::string("hedgefit ") + hedgefit::kVersion);
  app.require_subcommand(1);
  app.footer("Exit codes: 0 ok, 1 bad input or usage, 2 processing failure, 3 results printed but unusable.\n"
             "Run 'hedgefit COMMAND --help' for a command's options and examples.");
  CommandFn run;
  AddSimulateCommand(app, &run);
  AddBenchCommand(app, &run);
  return hedgefit::cli::RunCommandLine(app, argc, argv, &run);
}
