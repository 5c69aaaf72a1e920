// hedgefit trim CLOUD --radius R: the trim plan of each hedge in a cloud against a target
// sphere: cut depth per point, share of the surface to cut, depth percentiles, volume.

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "apps/commands.hpp"
#include "pipeline/output_check.hpp"
#include "cli/parse.hpp"
#include "cloud/cloud_io.hpp"
#include "pipeline/registry.hpp"
#include "measure/trim_plan.hpp"
#include "render/render.hpp"

namespace hedgefit::apps {

namespace {

using json = nlohmann::ordered_json;

struct TrimArgs {
  std::string cloud, center, method = "ransac_geometric", output, render, format = "table", up = "-y", axes, shape = "ellipsoid";
  double heading = 0;
  double radius = 0, tolerance = 5, scale = 1, bin_deg = 0;
  bool no_clean = false, print_pipeline = false;
};

}  // namespace

void AddTrimCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand(
      "trim", "Trim plan: how far each hedge sticks out past a target sphere, the share to cut and the volume to remove");
  cmd->footer(
      "Examples:\n"
      "  hedgefit trim build/demo/sphere_2300.pcd --radius 280 --render build/trim.png -o build/trim.pcd\n"
      "  hedgefit trim row_2.pcd --radius 480 --method envelope --format json\n"
      "  hedgefit trim row_2.pcd --radius 480 --center 80,252,2557   # a given target, no fit\n"
      "  hedgefit trim bed.ply --scale 1000 --up z --axes 300,300,180 --center 4815,-2126,-372   # a clipped spheroid\n"
      "  hedgefit trim box.ply --up z --axes 400,250,300 --heading 30 --shape cuboid --center 0,0,300   # a clipped box\n"
      "The target is a sphere of --radius, or a shape of --axes with a vertical axis (--up), about each hedge's\n"
      "fitted centre (--method), or about --center.\n"
      "Cut depth = distance to the target's centre minus its radius: + sticks out (cut), - lies inside.\n"
      "The volume counts what the camera saw (seen_share of the sphere); volume_all_round_l assumes the\n"
      "unseen side sticks out as the seen side does.\n");
  auto a = std::make_shared<TrimArgs>();
  cmd->add_option("cloud", a->cloud, "cloud file (" + cloud::CloudExtensionList() + "); a hedge_id field gives one plan per hedge")->required();
  cmd->add_option("--radius", a->radius, "target radius, mm (up to 100 m); or --axes")->check(CLI::Range(1e-3, 1e5));
  cmd->add_option("--axes", a->axes,
                  "a clipped shape as the target: semi-axes A,B,C in mm along the heading, across it and along --up "
                  "(a spheroid: A,A,C), e.g. from find's shape");
  cmd->add_option("--heading", a->heading, "the shape's first semi-axis, degrees counter-clockwise about --up from x")
      ->capture_default_str();
  cmd->add_option("--shape", a->shape,
                  "what --axes are of: an ellipsoid, a cylinder (a drum: R,R,half-height), a cuboid (a box: "
                  "half-sides) or a cone (base R,R,half-height), as find's shape names them")
      ->check(CLI::IsMember({"ellipsoid", "cylinder", "cuboid", "cone"}))
      ->capture_default_str();
  cmd->add_option("--center", a->center, "target centre X,Y,Z in mm (default: each hedge's fitted centre)");
  cmd->add_option("--scale", a->scale, "multiply coordinates on read (1000 for metre files)")->capture_default_str();
  cmd->add_option("--method", a->method, "fit that centres the target (without --center)")->capture_default_str();
  cmd->add_option("--tolerance", a->tolerance, "cut depths up to this count as on target, mm")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--bin-deg", a->bin_deg,
                  "the volume bins' size at the equator, degrees (0: about 20 points per bin; small on a shape's rim or apex)")
      ->check(CLI::Range(0.0, 90.0))
      ->capture_default_str();
  cmd->add_option("-o,--output", a->output, "also write the cloud with a 'cut_depth' field (PCD)");
  cmd->add_option("--render", a->render, "also render the cloud coloured by cut depth with the target drawn (PNG)");
  cmd->add_option("--up", a->up,
                  "the vertical (the volume bins' rings are taken about it, and 'unseen' directions are given about "
                  "it): -y for a camera's cloud and a fused one in its frame, z for most maps")
      ->check(CLI::IsMember({"x", "y", "z", "-x", "-y", "-z"}))
      ->capture_default_str();
  cmd->add_option("--format", a->format, "table or json")->check(CLI::IsMember({"table", "json"}))->capture_default_str();
  cmd->add_flag("--no-clean", a->no_clean, "no NaN removal and outlier removal (filters.hedge_outlier) before the fit");
  cmd->add_flag("--print-pipeline", a->print_pipeline, "print the pipeline JSON this runs and exit");
  GroupFlags(cmd, {{"Inputs", {"cloud", "--scale", "--no-clean"}}, {"Target", {"--radius", "--axes", "--heading", "--shape", "--center", "--method", "--tolerance", "--up"}}, {"Outputs", {"--output", "--render", "--print-pipeline"}}, {"Output format", {"--format"}}});
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      measure::TrimRequest r;
      r.cloud = a->cloud, r.scale = a->scale, r.clean = !a->no_clean, r.method = a->method;
      if (!a->center.empty()) r.center = ParseNumbers(a->center, 3, "--center");
      r.radius = a->radius, r.tolerance = a->tolerance, r.bin_deg = a->bin_deg, r.up = a->up, r.heading = a->heading, r.output = a->output;
      if (!a->axes.empty()) r.axes = ParseNumbers(a->axes, 3, "--axes");
      r.shape = a->shape;
      if (a->print_pipeline) {
        std::printf("%s\n", json{{"pipeline", json::parse(measure::TrimRecipe(r))}}.dump(2).c_str());
        return kExitOk;
      }
      if (!a->output.empty()) cloud::CheckCloudOutput("-o", a->output, {a->cloud});
      if (!a->render.empty()) pipeline::CheckImageOutput("--render", a->render, {".png"}, {a->cloud});
      const measure::TrimResult t = measure::PlanTrim(r, pipeline::Registry::Global());
      const auto& plans = t.plans;
      for (const auto& p : plans) {
        for (const auto& w : p.warnings) std::fprintf(stderr, "hedgefit: warning: trim: hedge %d: %s\n", p.hedge_id ? p.hedge_id : 1, w.c_str());
      }
      if (!a->render.empty()) render::RenderTrimPlan(t.cloud, plans, a->render);
      if (a->format == "json") {
        std::cout << fitting::TrimPlansJson(a->cloud, plans) << "\n";
        return kExitOk;
      }
      fitting::PrintTrimTable(std::cout, plans);
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
