// hedgefit find CLOUD...: the ground, the objects on it and the hedge balls among them, in any
// cloud (a LiDAR scan, a photogrammetry model, a robot's map, a stereo capture). The work is
// scene::FindHedges; the reports are scene/find_report.hpp's.

#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "apps/commands.hpp"
#include "cli/parse.hpp"
#include "cli/stage_flags.hpp"
#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"
#include "fitting/methods.hpp"
#include "pipeline/output_check.hpp"
#include "pipeline/print.hpp"
#include "render/top_view.hpp"
#include "scene/find_report.hpp"

namespace hedgefit::apps {

namespace {

struct FindArgs {
  std::vector<std::string> clouds;
  double scale = 0;  // 0: guess
  std::string format = "table";
  std::string labelled;
  std::string plot, plot_marks;
  std::uint64_t seed = 42;
  StageFlags flags;
};

// The marks for --plot: one "x y" (or "x,y") per line in the cloud's units; # starts a comment.
std::vector<Eigen::Vector2d> ReadMarks(const std::string& path, double scale) {
  std::ifstream in(path);
  if (!in) throw Error("--plot-marks " + path + ": cannot read it (a text file of 'x y' per line, in the cloud's units)");
  std::vector<Eigen::Vector2d> marks;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    line = line.substr(0, line.find('#'));
    for (char& ch : line) if (ch == ',') ch = ' ';
    std::istringstream fields(line);
    double x = 0, y = 0;
    if (!(fields >> x)) continue;
    if (!(fields >> y) || !std::isfinite(x) || !std::isfinite(y)) {
      throw Error(pipeline::Format("--plot-marks %s line %d: expected two numbers 'x y'", path.c_str(), n));
    }
    marks.emplace_back(x * scale, y * scale);
  }
  return marks;
}

int RunFind(const FindArgs& a) {
  fitting::QuietSolverWarnings();
  scene::FindOptions o;
  try {
    scene::FindOptions::Table().Apply(a.flags.Given(), &o);
    o.seed = a.seed;
    o.Check();
  } catch (const Error& e) {
    throw Error(AsFlagMessage(e.what()));
  }
  if ((!a.labelled.empty() || !a.plot.empty()) && a.clouds.size() != 1) {
    throw Error("--labelled and --plot write one cloud's result: give one CLOUD (or run find once per cloud)");
  }
  if (!a.labelled.empty()) cloud::CheckCloudOutput("--labelled", a.labelled, a.clouds);
  if (!a.plot.empty()) pipeline::CheckImageOutput("--plot", a.plot, {".png"}, a.clouds);
  if (!a.plot_marks.empty() && a.plot.empty()) throw Error("--plot-marks draws on --plot's picture: give --plot PNG too");
  if (!a.plot_marks.empty()) ReadMarks(a.plot_marks, 1.0);  // a bad file fails before any work
  std::vector<scene::FindReport> reports;
  int failed = 0;
  for (const std::string& file : a.clouds) {
    try {
      scene::FindReport rep;
      cloud::PointCloud cloud = cloud::ReadCloud(file);
      if (a.scale > 0) {
        rep.scale = a.scale, rep.scale_source = pipeline::Format("scale %g given", a.scale);
      } else {
        const double extent = cloud::LargestExtent(cloud), spacing = cloud::MedianSpacing(cloud);
        rep.scale = cloud::GuessUnits(extent, spacing) == "m" ? 1000.0 : 1.0;
        rep.scale_source = rep.scale == 1000.0
                               ? pipeline::Format("metres, guessed from its span %.3g and spacing %.3g; --scale overrides", extent, spacing)
                               : "mm, guessed; --scale overrides";
      }
      if (rep.scale != 1.0) {
        for (auto& p : cloud.points_mm) p *= float(rep.scale);
      }
      rep.result = scene::FindHedges(cloud, o);
      rep.result.file = file;
      if (!a.labelled.empty()) cloud::WriteCloud(a.labelled, scene::LabelCloud(cloud, rep.result));
      if (!a.plot.empty()) {
        render::WriteTopView(cloud, rep.result, a.plot, 1200, a.plot_marks.empty() ? std::vector<Eigen::Vector2d>{} : ReadMarks(a.plot_marks, rep.scale));
      }
      reports.push_back(std::move(rep));
    } catch (const Error& e) {
      std::cerr << "hedgefit: " << e.what() << "; skipped\n";
      ++failed;
    }
  }
  if (a.format == "json") {
    scene::WriteFindJson(std::cout, reports);
  } else if (a.format == "csv") {
    scene::WriteFindCsv(std::cout, reports);
  } else {
    scene::WriteFindTable(std::cout, reports);
  }
  std::cout.flush();
  return failed > 0 ? kExitBadInput : kExitOk;
}

}  // namespace

void AddFindCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("find", "Find the ground, the objects on it and every hedge ball in any cloud (LiDAR, photogrammetry, a map)");
  cmd->footer(
      "Examples:\n"
      "  hedgefit find data/sphere_scans/example2/L1_S1.xyz\n"
      "  hedgefit find scan.ply --format json --labelled scan_labelled.ply --plot scan_top.png\n"
      "  hedgefit find map.pcd --scale 1000 --min-radius 250 --max-radius 1200\n"
      "Units are guessed as `info` guesses them (span, then spacing); --scale overrides. Up is +z, or -y for a\n"
      "camera's cloud (organised, or with hedgefit's pixel_mm field), refined to the ground it sees; --up overrides.\n"
      "Each object is a ball, a dome (a ball cut by the ground), an ellipsoid, or not a ball, with the reason; what\n"
      "no ball takes is searched for clipped topiary by height (a dome, a spheroid or an ellipsoid with a vertical\n"
      "axis: squat box seen from above), with its semi-axes and heading; --no-topiary turns that off.\n"
      "--labelled writes the cloud with hedge_id (balls and topiary), object_id and ground fields: compare, trim\n"
      "and render then work on each.\n");
  auto a = std::make_shared<FindArgs>();
  cmd->add_option("CLOUD", a->clouds, "cloud files (" + cloud::CloudExtensionList() + ")")->required();
  cmd->add_option("--scale", a->scale, "multiply coordinates on read (1000 for metre files); default: guessed")
      ->check(CLI::PositiveNumber);
  a->flags.Add(cmd, scene::FindOptions::Table().Specs(), {}, "Finding");
  cmd->add_option("--seed", a->seed, "sample consensus seed")->check(Seed())->capture_default_str();
  cmd->add_option("--format", a->format, "table, json or csv")->check(CLI::IsMember({"table", "json", "csv"}))->capture_default_str();
  cmd->add_option("--labelled", a->labelled, "write the cloud with hedge_id, object_id and ground fields to this file");
  cmd->add_option("--plot", a->plot, "draw the top view with each ball's circle, each topiary's footprint and each other object's outline to this PNG");
  cmd->add_option("--plot-marks", a->plot_marks,
                  "also draw these places on --plot as crosses (a text file of 'x y' per line, the cloud's units: a map's topiary)");
  GroupFlags(cmd, {{"Inputs", {"CLOUD", "--scale"}}, {"Finding", {"--seed"}}, {"Output", {"--format", "--labelled", "--plot", "--plot-marks"}}});
  cmd->callback([=]() { *run = [=]() { return RunFind(*a); }; });
}

}  // namespace hedgefit::apps
