// hedgefit measure: one stereo capture to each hedge's centre and radius, in one step
// (the capture pipeline, cleaning and a fit), printed as one JSON object per hedge and fit.

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "apps/commands.hpp"
#include "around/around_report.hpp"
#include "around/around_view.hpp"
#include "around/fusion.hpp"
#include "around/poses.hpp"
#include "around/views.hpp"
#include "cli/capture_flags.hpp"
#include "cli/parse.hpp"
#include "cli/stage_flags.hpp"
#include "cloud/cloud_io.hpp"
#include "fitting/methods.hpp"
#include "measure/measure_capture.hpp"
#include "pipeline/output_check.hpp"
#include "pipeline/registry.hpp"
#include "stereo/rig.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::apps {

namespace {

using json = nlohmann::ordered_json;  // keys in the order written: hedge first

struct MeasureArgs {
  std::string left, right, rig, overlay, methods = "ransac_ray";
  bool no_clean = false, print_pipeline = false, pretty = false, strict = false;
  CaptureFlags capture;
  // Several captures with poses (around/).
  std::string manifest, trajectory, captures, fused, plot, format = "json";
  StageFlags fuse_flags;
};

// `measure --manifest` / `--trajectory`: every capture measured alone, then fused.
int RunMeasureAround(const MeasureArgs& a) {
  std::vector<std::string> inputs;
  const std::vector<around::PosedCapture> captures = around::ReadPosedCaptures(a.manifest, a.trajectory, a.captures, a.rig, &inputs);
  const std::string& source = inputs.front();
  if (!a.fused.empty()) cloud::CheckCloudOutput("--fused", a.fused, inputs);
  if (!a.plot.empty()) pipeline::CheckImageOutput("--plot", a.plot, {".png"}, inputs);
  around::FuseOptions fo;
  around::FuseOptions::Table().Apply(a.fuse_flags.Given(), &fo);
  fo.Check();
  fitting::QuietSolverWarnings();
  const std::vector<around::View> views = around::MeasureViews(captures, a.rig, a.capture.Resolve(pipeline::Registry::Global()));
  const around::FuseResult r = around::Fuse(views, fo);
  if (a.format == "table") {
    around::PrintFuseTable(std::cout, r);
  } else {
    for (const std::string& line : around::FuseJsonLines(r, a.pretty)) std::printf("%s\n", line.c_str());
  }
  std::fflush(stdout);
  for (const std::string& w : r.warnings) std::fprintf(stderr, "hedgefit: warning: %s\n", w.c_str());
  if (!a.fused.empty()) cloud::WriteCloud(a.fused, r.cloud);
  if (!a.plot.empty()) around::WriteAroundView(r, a.plot);
  if (r.hedges.empty()) throw ProcessingError(source + ": no hedge could be fused from the captures");
  const bool any_confirmed =
      std::any_of(r.hedges.begin(), r.hedges.end(), [](const around::FusedHedge& h) { return h.unconfirmed.empty(); });
  if (!any_confirmed) {
    std::fprintf(stderr, "hedgefit: error: %s: every fused hedge is unconfirmed (its line says why)\n", source.c_str());
    return kExitUnusable;
  }
  return kExitOk;
}

}  // namespace

void AddMeasureCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand(
      "measure", "One stereo capture to each hedge's centre and radius in one step: one JSON object per hedge");
  cmd->footer(
      "Examples:\n"
      "  hedgefit measure --rig build/demo/rig.yaml --left build/demo/lab/sphere_2300_left.png \\\n"
      "      --right build/demo/lab/sphere_2300_right.png --overlay build/sphere_2300_measure.png\n"
      "  hedgefit measure --garden --method envelope --rig build/garden/rig.yaml \\\n"
      "      --left build/garden/garden_row_left.png --right build/garden/garden_row_right.png\n"
      "Prints one JSON line per hedge and method (JSON Lines): hedge id (1, 2, ... left to right), method,\n"
      "centre_mm, radius_mm, std_error_mm (cx, cy, cz, r; from the points' scatter only), inliers, rms_mm,\n"
      "fit and capture times, and with --garden the hedge's image box; not_a_ball (and a warning) when the\n"
      "points are not a ball's (a shrub taken for a hedge: see README, compare). Every capture checks its\n"
      "rig against its own images (rig_check: ok, widened, unusable; docs/commands.md). Exit 2 when no fit\n"
      "converges, 3 when a result is unusable (its line's \"unusable\" says why) or, with --strict, unchecked.\n"
      "Several captures around a hedge (docs/around.md):\n"
      "  hedgefit measure --manifest build/around/hedgefit/single_ring_4/manifest_odometry.json --plot around.png\n"
      "  hedgefit measure --trajectory poses.tum --captures DIR --rig rig.yaml --fused fused.pcd\n");
  auto a = std::make_shared<MeasureArgs>();
  cmd->add_option("--left", a->left, "left image");
  cmd->add_option("--right", a->right, "right image");
  cmd->add_option("--rig", a->rig, "rig file from `hedgefit calibrate` (with --manifest: for captures that name none)");
  auto* manifest = cmd->add_option("--manifest", a->manifest,
                                   "several captures with the poses of their left cameras (JSON: docs/around.md): each "
                                   "measured, then fused into one measurement per hedge");
  auto* trajectory = cmd->add_option("--trajectory", a->trajectory,
                                     "the same from a TUM trajectory ('time tx ty tz qx qy qz qw', metres) and --captures");
  cmd->add_option("--captures", a->captures, "with --trajectory: the folder of TIME_left.png / TIME_right.png");
  cmd->add_option("--fused", a->fused, "with --manifest: also write the fused cloud (world frame; hedge_id, capture fields)");
  cmd->add_option("--plot", a->plot, "with --manifest: also draw the fused hedges from above with each camera (PNG)");
  cmd->add_option("--format", a->format, "with --manifest: json (JSON Lines) or table")
      ->check(CLI::IsMember({"json", "table"}))
      ->capture_default_str();
  manifest->excludes(trajectory);
  a->fuse_flags.Add(cmd, around::FuseOptions::Table().Specs(), {}, "Fusing (--manifest, --trajectory)");
  cmd->add_option("--method", a->methods,
                  "fit method(s), comma-separated (see `hedgefit compare --help`); envelope for leafy hedges")
      ->capture_default_str();
  cmd->add_option("--overlay", a->overlay, "also write the left image with each fitted hedge drawn on it (PNG)");
  cmd->add_flag("--no-clean", a->no_clean, "fit the raw cloud (no outlier removal: filters.hedge_outlier)");
  cmd->add_flag("--pretty", a->pretty, "indented JSON instead of one line per object");
  cmd->add_flag("--strict", a->strict,
                "exit 3 also when the rig could not be checked against the capture (rig_check unchecked: too few "
                "textured places across the frame), as a robot should");
  cmd->add_flag("--print-pipeline", a->print_pipeline, "print the pipeline JSON this runs and exit");
  a->capture.Add(cmd);
  GroupFlags(cmd, {{"Inputs", {"--left", "--right", "--rig"}}, {"Fitting", {"--method", "--no-clean"}}, {"Outputs", {"--overlay", "--print-pipeline"}}, {"Output format", {"--pretty", "--strict"}}});
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      if (!a->manifest.empty() || !a->trajectory.empty()) {
        if (!a->left.empty() || !a->right.empty()) throw InputError("--left/--right and --manifest/--trajectory: give one capture or a manifest");
        return RunMeasureAround(*a);
      }
      if (a->left.empty() || a->right.empty() || a->rig.empty()) {
        throw InputError("measure: give --left, --right and --rig (one capture), or --manifest (several captures with poses)");
      }
      const pipeline::Registry& registry = pipeline::Registry::Global();
      measure::MeasureRequest request;
      request.capture = a->capture.Resolve(registry);
      request.methods = fitting::ParseMethodList(a->methods, "--method");
      request.clean = !a->no_clean;
      request.overlay = a->overlay;
      if (a->print_pipeline) {
        const json stages = json::parse(measure::MeasureRecipe(request, registry, a->left, a->right, a->rig));
        std::printf("%s\n", json{{"pipeline", stages}}.dump(2).c_str());
        return kExitOk;
      }
      const measure::MeasureResult m = measure::MeasureCapture(a->left, a->right, a->rig, request, registry);
      if (!m.hint.empty()) std::fprintf(stderr, "hedgefit: warning: %s: %s\n", a->left.c_str(), m.hint.c_str());
      for (const auto& j : m.lines) std::printf("%s\n", a->pretty ? j.dump(2).c_str() : j.dump().c_str());
      std::fflush(stdout);
      if (!m.output_error.empty()) {
        throw ProcessingError("--overlay " + m.output_error + "; the measurements were printed, no overlay was kept");
      }
      if (m.converged == 0) throw ProcessingError(a->left + ": no fit converged (" + m.first_failure + ")");
      if (!m.first_failure.empty()) std::fprintf(stderr, "hedgefit: warning: %s\n", m.first_failure.c_str());
      for (const std::string& why : m.not_balls) std::fprintf(stderr, "hedgefit: warning: %s: %s\n", a->left.c_str(), why.c_str());
      if (m.unusable) return kExitUnusable;
      // Without --strict the capture's hint above has said it already.
      if (a->strict && !m.unchecked.empty()) {
        std::fprintf(stderr, "hedgefit: error: %s: %s (--strict)\n", a->left.c_str(), m.unchecked.c_str());
        return kExitUnusable;
      }
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
