// hedgefit: measure spherical hedges from a binocular camera.
// A table of subcommands, each in its own file; errors become one line on stderr.

#include <string>

#include "apps/commands.hpp"
#include "pipeline/version.hpp"

int main(int argc, char** argv) {
  using namespace hedgefit::apps;
  const int forwarded = ForwardToBenchProgram(argc, argv);
  if (forwarded >= 0) return forwarded;
  PrepareProcess();
  CLI::App app{"hedgefit " + std::string(hedgefit::kVersion) +
               ": reconstruct and measure spherical hedges from stereo images and point clouds"};
  app.set_version_flag("--version", std::string("hedgefit ") + hedgefit::kVersion);
  app.require_subcommand(1);
  app.footer("Exit codes: 0 ok, 1 bad input or usage, 2 processing failure, 3 results printed but unusable\n"
             "(a check of their inputs failed; each result says why).\n"
             "Run 'hedgefit COMMAND --help' for a command's options and examples.");
  CommandFn run;
  AddInfoCommand(app, &run);
  AddPipelineCommand(app, &run);
  AddPluginsCommand(app, &run);
  AddCompareCommand(app, &run);
  AddFindCommand(app, &run);
  AddCalibrateCommand(app, &run);
  AddRigCommand(app, &run);
  AddCheckRigCommand(app, &run);
  // Listed here, run by hedgefit-bench: ForwardToBenchProgram has handed them over already.
  app.add_subcommand("simulate", kSimulateAbout)->allow_extras();
  AddRenderCommand(app, &run);
  AddConvertCommand(app, &run);
  AddMeasureCommand(app, &run);
  AddTrimCommand(app, &run);
  AddStreamCommand(app, &run);
  app.add_subcommand("bench", kBenchAbout)->allow_extras();
  return hedgefit::cli::RunCommandLine(app, argc, argv, &run);
}
