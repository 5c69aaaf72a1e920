// hedgefit compare CLOUD...: clean each cloud, run every fitter, and print one row per
// method; with ground truth, the paper's AER / RER / LD columns and a summary per method.
// The work is eval::CompareCloud and its writers (eval/compare.hpp).

#include <iostream>

#include "cli/capture_flags.hpp"
#include "apps/commands.hpp"
#include "pipeline/output_check.hpp"
#include "cli/parse.hpp"
#include "cli/stage_flags.hpp"
#include "cloud/cleaning.hpp"
#include "cloud/cloud_io.hpp"
#include "eval/compare.hpp"
#include "fitting/methods.hpp"
#include "render/plot.hpp"
#include "stereo/rig.hpp"
#include "stereo/rig_uncertainty.hpp"

namespace hedgefit::apps {

namespace {

struct CompareArgs {
  std::vector<std::string> clouds;
  std::string truth;
  std::string pipeline;
  std::string methods = "all";
  std::string format = "table";
  double scale = 1.0;
  std::uint64_t seed = 42;
  StageFlags fit_flags;  // the robust methods' options, from the method table
  std::string plot;
  std::string rig;
};

int RunCompare(const CompareArgs& a) {
  PrepareRegistry(true);
  if (!a.plot.empty()) pipeline::CheckImageOutput("--plot", a.plot, {".png"}, a.clouds);
  eval::CompareOptions o;
  o.methods = fitting::ParseMethodList(a.methods, "--method");
  o.fit_options = a.fit_flags.Given();
  o.cleaning_json = a.pipeline.empty() ? cloud::DefaultCleaningJson() : eval::ReadCleaningFile(a.pipeline);
  o.cleaning_source = a.pipeline.empty() ? "default cleaning" : a.pipeline;
  o.scale = a.scale;
  o.seed = a.seed;
  if (!a.truth.empty()) o.truth = eval::ReadTruthFiles(a.truth);
  cloud::PointPerturbation rig_perturbation, matching_perturbation;
  if (!a.rig.empty()) {
    const stereo::StereoRig rig = stereo::ReadRig(a.rig);
    if (rig.covariance.empty()) {
      throw Error("--rig " + a.rig + ": the rig carries no calibration covariance; recalibrate it with `hedgefit calibrate`");
    }
    rig_perturbation = stereo::RigPerturbation(rig);
    matching_perturbation = stereo::DisparityOffsetPerturbation(rig);
    o.rig = &rig_perturbation;
    o.matching = &matching_perturbation;
  }
  eval::CheckCleaning(o, a.clouds.front());
  std::vector<eval::CloudReport> reports;
  int failed = 0;
  for (const std::string& file : a.clouds) {
    try {
      for (auto& r : eval::CompareCloud(file, o)) reports.push_back(std::move(r));
    } catch (const Error& e) {
      std::cerr << "hedgefit: " << e.what() << "; skipped\n";
      ++failed;
    }
  }
  // A cloud (or hedge) that no method could fit fails the run: a script must not read "every fit
  // failed" as success.
  const auto unfitted = eval::Unfitted(reports);
  for (const auto* r : unfitted) {
    std::cerr << "hedgefit: " << r->file << ": no method fitted a sphere (" << r->fits.front().message
              << "); give the points of one hedge's surface\n";
  }
  const eval::CompareSummary summary = eval::Summarise(reports);
  if (!a.plot.empty()) {
    std::string x_title;
    const auto series = eval::ErrorSeriesByMethod(reports, o.methods, &x_title);
    render::PlotErrors(series, x_title, 1200, 500, a.plot);
  }
  if (a.format == "json") {
    eval::WriteCompareJson(std::cout, reports, o.methods, summary);
  } else if (a.format == "csv") {
    eval::WriteCompareCsv(std::cout, reports);
  } else {
    eval::WriteCompareTable(std::cout, reports, o.methods, summary);
  }
  std::cout.flush();
  return failed > 0 ? kExitBadInput : !unfitted.empty() ? kExitProcessing : kExitOk;
}

}  // namespace

void AddCompareCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("compare", "Clean clouds, fit spheres with every method, compare (with truth: AER, RER, LD)");
  cmd->footer(
      "Examples:\n"
      "  hedgefit compare sample_clouds/*.pcd\n"
      "  hedgefit compare scan.pcd --truth scan.truth.json --method hyper,ransac_geometric --format json\n"
      "  hedgefit compare data/sphere_scans/example2/L1_S1.xyz --scale 1000 --min-radius 250 --max-radius 350\n"
      "  hedgefit compare build/garden/row_*.pcd --truth build/garden/garden_row.truth.json --method ransac,envelope\n"
      "Truth: --truth FILE, or CLOUD.truth.json beside each cloud: {\"center_mm\": [x, y, z], \"radius_mm\": r}, or\n"
      "{\"hedges\": [...]} for several; each hedge (a cloud's hedge_id field) is matched to the nearest one.\n"
      "A fit whose sphere is far wider than its points, or with over 5 % of them a tenth of its radius outside it,\n"
      "is marked not a ball (not_a_ball in JSON, a '^ not a ball' line in the table): a shrub, lawn, or two lobes.\n");
  auto a = std::make_shared<CompareArgs>();
  cmd->add_option("CLOUD", a->clouds, "cloud files (" + cloud::CloudExtensionList() + ")")->required();
  cmd->add_option("--truth", a->truth, "ground-truth JSON for every cloud (default: CLOUD.truth.json if present)");
  cmd->add_option("--pipeline", a->pipeline, "JSON array of cleaning stages replacing the default (nonfinite + hedge_outlier)");
  std::string method_list;
  for (const auto& m : fitting::FitMethodNames()) method_list += m + ",";
  cmd->add_option("--method,--methods", a->methods,
                  "comma-separated: " + method_list + " or all (every sphere fit; all,ellipsoid adds the ellipsoid)")
      ->capture_default_str();
  cmd->add_option("--format", a->format, "table, json or csv")->check(CLI::IsMember({"table", "json", "csv"}))->capture_default_str();
  cmd->add_option("--scale", a->scale, "multiply coordinates on read (1000 for metre files)")->capture_default_str();
  // RANSAC's options, as declared in its table; each applies to every method that has it.
  std::vector<pipeline::OptionSpec> robust;
  for (const auto& spec : fitting::FindFitMethod("ransac", "compare").options) {
    if (spec.name != "seed") robust.push_back(spec);
  }
  a->fit_flags.Add(cmd, robust, {}, "Fitting (RANSAC, for every method that uses it)", {{"method", "--estimator"}});
  cmd->add_option("--seed", a->seed, "RANSAC sampler seed")->check(Seed())->capture_default_str();
  cmd->add_option("--rig", a->rig,
                  "the rig the clouds were measured with (hedgefit calibrate's YAML): each fit's uncertainty then "
                  "includes the rig's calibration");
  cmd->add_option("--plot", a->plot, "also draw |AER| and LD per method (against distance when several clouds have truth) to this PNG");
  GroupFlags(cmd, {{"Inputs", {"CLOUD", "--truth", "--scale", "--rig"}}, {"Cleaning", {"--pipeline"}}, {"Fitting", {"--method", "--seed"}}, {"Output", {"--format", "--plot"}}});
  cmd->callback([=]() { *run = [=]() { return RunCompare(*a); }; });
}

}  // namespace hedgefit::apps
