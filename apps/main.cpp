// hedgefit: measure spherical hedges from a binocular camera.
// A table of subcommands, each in its own file; errors become one line on stderr.

#include <malloc.h>
#include <opencv2/core/utils/logger.hpp>

#include <string>

#include "apps/commands.hpp"
#include "pipeline/version.hpp"
#include "fitting/methods.hpp"

int main(int argc, char** argv) {
  using namespace hedgefit::apps;
  // Each capture allocates and frees images of several megabytes (rectified views, B-spline
  // coefficients, disparity maps). glibc serves blocks that large from fresh mmap'd pages that the
  // kernel must fault in and zero every time: a tenth of a garden capture's CPU time. Served
  // from the heap and reused instead, a row of three hedges measures 5 % faster in `stream`
  // (488-497 -> 460-465 ms per frame) and peaks lower (433 -> 392 MB).
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // hedgefit reports problems itself, one line each: OpenCV's own warnings would come first.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  hedgefit::fitting::QuietSolverWarnings();  // and Ceres' (glog) warnings: each fit reports its own trouble
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
  AddSimulateCommand(app, &run);
  AddRenderCommand(app, &run);
  AddConvertCommand(app, &run);
  AddMeasureCommand(app, &run);
  AddTrimCommand(app, &run);
  AddStreamCommand(app, &run);
  AddBenchCommand(app, &run);
  return hedgefit::cli::RunCommandLine(app, argc, argv, &run);
}
