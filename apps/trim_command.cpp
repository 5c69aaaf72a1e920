// hedgefit trim CLOUD --radius R: the trim plan of each hedge in a cloud against a target
// sphere: cut depth per point, share of the surface to cut, depth percentiles, volume.

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "cli/capture_flags.hpp"
#include "apps/commands.hpp"
#include "pipeline/output_check.hpp"
#include "cli/parse.hpp"
#include "cloud/cloud_io.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "fitting/methods.hpp"
#include "fitting/trim.hpp"
#include "render/render.hpp"

namespace hedgefit::apps {

namespace {

using json = nlohmann::ordered_json;

struct TrimArgs {
  std::string cloud, center, method = "ransac_geometric", output, render, format = "table", up = "-y", axes;
  double heading = 0;
  double radius = 0, tolerance = 5, scale = 1;
  bool no_clean = false, print_pipeline = false;
};

json Stages(const TrimArgs& a, const std::vector<double>& center) {
  json reader = {{"filename", a.cloud}};  // the reader chosen by extension
  if (a.scale != 1) reader["scale"] = a.scale;
  json p = json::array({reader});
  if (!a.no_clean) {
    for (const auto& stage : DefaultCleaning()) p.push_back(json(stage));
  }
  if (center.empty()) p.push_back({{"type", fitting::FindFitMethod(a.method, "--method").stage}});
  json trim = {{"type", "filters.trim_depth"}, {"radius", a.radius}, {"tolerance", a.tolerance}, {"up", a.up}};
  if (!a.axes.empty()) trim["axes"] = ParseNumbers(a.axes, 3, "--axes"), trim["heading"] = a.heading;
  if (!center.empty()) trim["center"] = center;
  p.push_back(trim);
  if (!a.output.empty()) p.push_back({{"type", "writers.pcd"}, {"filename", a.output}, {"encoding", "binary_compressed"}});
  return p;
}

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
      "The target is a sphere of --radius, or a shape of --axes with a vertical axis (--up), about each hedge's\n"
      "fitted centre (--method), or about --center.\n"
      "Cut depth = distance to the target's centre minus its radius: + sticks out (cut), - lies inside.\n"
      "The volume counts what the camera saw (seen_share of the sphere); volume_all_round_l assumes the\n"
      "unseen side sticks out as the seen side does.\n");
  auto a = std::make_shared<TrimArgs>();
  cmd->add_option("cloud", a->cloud, "cloud file (.pcd, .ply, .xyz); a hedge_id field gives one plan per hedge")->required();
  cmd->add_option("--radius", a->radius, "target radius, mm (up to 100 m); or --axes")->check(CLI::Range(1e-3, 1e5));
  cmd->add_option("--axes", a->axes,
                  "a clipped shape as the target: semi-axes A,B,C in mm along the heading, across it and along --up "
                  "(a spheroid: A,A,C), e.g. from find's shape");
  cmd->add_option("--heading", a->heading, "the shape's first semi-axis, degrees counter-clockwise about --up from x")
      ->capture_default_str();
  cmd->add_option("--center", a->center, "target centre X,Y,Z in mm (default: each hedge's fitted centre)");
  cmd->add_option("--scale", a->scale, "multiply coordinates on read (1000 for metre files)")->capture_default_str();
  cmd->add_option("--method", a->method, "fit that centres the target (without --center)")->capture_default_str();
  cmd->add_option("--tolerance", a->tolerance, "cut depths up to this count as on target, mm")
      ->check(CLI::NonNegativeNumber)
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
  GroupFlags(cmd, {{"Inputs", {"cloud", "--scale", "--no-clean"}}, {"Target", {"--radius", "--axes", "--heading", "--center", "--method", "--tolerance", "--up"}}, {"Outputs", {"--output", "--render", "--print-pipeline"}}, {"Output format", {"--format"}}});
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      if (!(a->radius > 0) && a->axes.empty()) throw Error("trim: give the target's --radius R (mm), or a clipped shape's --axes A,B,C");
      std::vector<double> center;
      if (!a->center.empty()) center = ParseNumbers(a->center, 3, "--center");
      const json stages = Stages(*a, center);
      if (a->print_pipeline) {
        std::printf("%s\n", json{{"pipeline", stages}}.dump(2).c_str());
        return kExitOk;
      }
      if (!a->output.empty()) cloud::CheckCloudOutput("-o", a->output, {a->cloud});
      if (!a->render.empty()) pipeline::CheckImageOutput("--render", a->render, {".png"}, {a->cloud});
      pipeline::Pipeline p = pipeline::Pipeline::FromJson(stages.dump(), "trim", pipeline::Registry::Global());
      pipeline::Context ctx;
      ctx.quiet = true;
      p.Run(ctx);
      const auto& plans = ctx.Get<std::vector<fitting::TrimPlan>>("trim_plans");
      if (!a->render.empty()) {
        render::RenderOptions ro;
        ro.color = render::ColorMode::kField;
        ro.field = "cut_depth";
        ro.views = {render::View::kFront, render::View::kSide};
        ro.wireframe = true;
        std::vector<render::SphereOverlay> spheres;
        for (const auto& t : plans) {
          render::SphereOverlay target{"target" + (t.hedge_id ? " hedge " + std::to_string(t.hedge_id) : std::string()),
                                       t.target, false, false, t.target_axes_mm, t.target_heading_deg, t.pole};
          spheres.push_back(target);
        }
        render::RenderToPng(ctx.Get<cloud::PointCloud>("cloud"), spheres, ro, a->render);
      }
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
