// hedgefit find CLOUD...: the ground, the objects on it and the hedge balls among them, in any
// cloud (a LiDAR scan, a photogrammetry model, a robot's map, a stereo capture). The work is
// scene::FindHedges; the reports are scene/find_report.hpp's.

#include <iostream>
#include <sstream>

#include "apps/commands.hpp"
#include "cli/parse.hpp"
#include "cli/stage_flags.hpp"
#include "cloud/cloud_io.hpp"
#include "fitting/methods.hpp"
#include "pipeline/output_check.hpp"
#include "render/top_view.hpp"
#include "scene/find_report.hpp"

namespace hedgefit::apps {

namespace {


// Marks in the file's frame, as the picture's points are (less the cloud's global shift).
std::vector<Eigen::Vector2d> ShiftedMarks(std::vector<Eigen::Vector2d> marks, const Eigen::Vector3d& offset) {
  for (auto& m : marks) m -= offset.head<2>();
  return marks;
}

struct FindArgs {
  std::vector<std::string> clouds;
  double scale = 0;  // 0: guess
  std::string format = "table";
  std::string labelled;
  std::string plot, plot_marks;
  std::vector<std::string> viewpoint;  // "x,y,z", the cloud's units
  std::string viewpoints;              // a cloud file of them (a trajectory)
  std::uint64_t seed = 42;
  StageFlags flags;
};

// --viewpoint's "x,y,z" and --viewpoints' points, in the cloud's units and frame.
std::vector<Eigen::Vector3d> Viewpoints(const FindArgs& a) {
  std::vector<Eigen::Vector3d> at;
  for (const std::string& text : a.viewpoint) {
    Eigen::Vector3d v;
    char c1 = 0, c2 = 0, rest = 0;
    std::istringstream in(text);
    if (!(in >> v.x() >> c1 >> v.y() >> c2 >> v.z()) || c1 != ',' || c2 != ',' || (in >> rest) || !v.allFinite()) {
      throw Error("--viewpoint '" + text + "': give the sensor's position as X,Y,Z in the cloud's units (e.g. 2.5,-1.5,1.6)");
    }
    at.push_back(v);
  }
  if (!a.viewpoints.empty()) {
    const cloud::PointCloud c = cloud::ReadCloud(a.viewpoints);
    for (const auto& p : c.points_mm) {
      if (p.allFinite()) at.push_back(p.cast<double>() + c.offset);
    }
    if (at.empty()) throw Error("--viewpoints " + a.viewpoints + ": holds no position; give one 'x y z' line per station");
  }
  return at;
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
  if (!a.plot_marks.empty()) render::ReadTopViewMarks(a.plot_marks, 1.0);  // a bad file fails before any work
  const std::vector<Eigen::Vector3d> viewpoints = Viewpoints(a);
  std::vector<scene::FindReport> reports;
  int failed = 0;
  for (const std::string& file : a.clouds) {
    try {
      cloud::PointCloud cloud;
      scene::FindReport rep = scene::FindInCloudFile(file, a.scale, o, &cloud, viewpoints);
      if (!a.labelled.empty()) cloud::WriteCloud(a.labelled, scene::LabelCloud(cloud, rep.result));
      if (!a.plot.empty()) {
        render::WriteTopView(cloud, rep.result, a.plot, 1200, a.plot_marks.empty() ? std::vector<Eigen::Vector2d>{} : ShiftedMarks(render::ReadTopViewMarks(a.plot_marks, rep.scale), rep.offset_mm));
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
      "no ball takes is searched for clipped topiary by height (a dome, a spheroid, an ellipsoid, a drum, a box or a cone with\n"
      "a vertical axis: squat box seen from above), with its semi-axes and heading; --no-topiary turns that off. One too\n"
      "sparse to show a solid top is undecided, with the spacing that would decide. A scanner's cloud seen from the\n"
      "side is judged over the part of each top that faces where it stood: give --viewpoint (repeatable) or --viewpoints.\n"
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
  cmd->add_option("--viewpoint", a->viewpoint,
                  "where the sensor stood, X,Y,Z in the cloud's units (repeatable: a scanner's stations)");
  cmd->add_option("--viewpoints", a->viewpoints, "a cloud file of where the sensor stood (e.g. a trajectory as 'x y z' lines, .xyz)")
      ->check(CLI::ExistingFile);
  GroupFlags(cmd, {{"Inputs", {"CLOUD", "--scale", "--viewpoint", "--viewpoints"}}, {"Finding", {"--seed"}}, {"Output", {"--format", "--labelled", "--plot", "--plot-marks"}}});
  cmd->callback([=]() { *run = [=]() { return RunFind(*a); }; });
}

}  // namespace hedgefit::apps
