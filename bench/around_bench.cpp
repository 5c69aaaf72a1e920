#include "bench/around_bench.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <sstream>

#include "around/fusion.hpp"
#include "around/poses.hpp"
#include "around/views.hpp"
#include "bench/render_stamp.hpp"
#include "cloud/cloud_io.hpp"
#include "fitting/trim.hpp"
#include "pipeline/error.hpp"
#include "pipeline/print.hpp"
#include "sim/camera_model.hpp"
#include "sim/povray.hpp"
#include "sim/simulator.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::bench {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

const pipeline::OptionTable<AroundBenchOptions>& AroundBenchOptions::Table() {
  using O = AroundBenchOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("renderer", &O::renderer, "hedgefit or povray").Choices({"hedgefit", "povray"})
          .Add("scenes", &O::scenes, "comma-separated: single (a ball), bulge (a ball with a bulge on its far side), row (two balls)")
          .Add("layouts", &O::layouts, "comma-separated: ring (all round), arc (half round), pass (driving by on one side)")
          .Add("captures", &O::captures, "captures per set, comma-separated (3-8)")
          .Add("poses", &O::poses, "comma-separated: exact, odometry (1-3 % of the distance travelled, 1-2 degrees of heading)")
          .Add("registration", &O::registration, "none, centres or centres+gicp").Choices({"none", "centres", "centres+gicp"})
          .Add("scale", &O::scale, "image scale (0.5: a quarter of the pixels)", "").Range(0.2, 1)
          .Add("seed", &O::seed,
               "the odometry errors', the camera noise's and the leaves' seed (1: the sets the fusion was developed on)", "")
          .Add("dir", &O::dir, "captures, manifests and truths are written here, and reused while their stamp matches today's build")
          .Add("trim_depth", &O::trim_depth_mm, "the trim target: the true envelope less this", "mm").Range(1, 500);
  return table;
}

namespace {

std::vector<std::string> Split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

// The scenes: balls of boxwood on a lawn, nothing else (a ring of cameras would stand in a
// garden's background).
sim::GardenScene AroundScene(const std::string& name) {
  sim::GardenScene sc;
  sc.background = false;
  sc.pot = false;
  sc.camera_height_mm = 1100;
  sc.pitch_deg = 12;
  sim::GardenHedge ball;
  ball.radius_mm = 500;
  ball.leaf_depth_mm = 30;
  ball.x_mm = 0, ball.z_mm = 0;
  if (name == "single" || name == "bulge") {
    if (name == "bulge") {
      // A shoot the shears missed, on the side the first capture cannot see (+z, away from it).
      ball.bulge_mm = 120, ball.bulge_radius_mm = 260, ball.bulge_heading_deg = 0;
    }
    sc.hedges = {ball};
  } else if (name == "row") {
    sim::GardenHedge a = ball, b = ball;
    a.radius_mm = 450, a.x_mm = -650;
    b.radius_mm = 550, b.x_mm = 700;
    sc.hedges = {a, b};
  } else {
    throw Error("bench around: no scene '" + name + "' (single, bulge, row)");
  }
  return sc;
}

struct Station {
  double x, z, heading_deg;
};

// Where the captures stand: about (0, 0), looking at it.
std::vector<Station> Layout(const std::string& layout, int n, const std::string& scene) {
  if (n < 2 || n > 12) throw Error("bench around: captures per set must be 2-12, not " + std::to_string(n));
  const double distance = scene == "row" ? 2700 : 2300;
  std::vector<Station> out;
  for (int k = 0; k < n; ++k) {
    if (layout == "pass") {  // driving by, the camera turned towards the row
      const double x = -2400 + 4800.0 * k / (n - 1), z = -distance;
      out.push_back({x, z, std::atan2(-x, -z) * 180 / M_PI});
      continue;
    }
    double h = 0;
    if (layout == "ring") h = 360.0 * k / n;
    else if (layout == "arc") h = -90 + 180.0 * k / (n - 1);
    else throw Error("bench around: no layout '" + layout + "' (ring, arc, pass)");
    const double r = h * M_PI / 180;
    out.push_back({-distance * std::sin(r), -distance * std::cos(r), h});
  }
  return out;
}

Eigen::Isometry3d ToIsometry(const cv::Matx44d& m) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) t.linear()(r, c) = m(r, c);
    t.translation()[r] = m(r, 3);
  }
  return t;
}

Eigen::Matrix3d TurnAboutVertical(double deg) {
  return Eigen::AngleAxisd(deg * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

// Odometry: each step's motion measured with a scale error of 1-3 % and a heading drift reaching
// 1-2 degrees by the last capture, integrated from the first capture (exact).
std::vector<around::PosedCapture> WithOdometryErrors(const std::vector<around::PosedCapture>& truth, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const double scale = (u(rng) < 0.5 ? -1 : 1) * (0.01 + 0.02 * u(rng));
  const double drift = (u(rng) < 0.5 ? -1 : 1) * (1 + u(rng));  // degrees by the end
  std::normal_distribution<double> lateral(0, 0.005), jitter(0, 0.1);
  std::vector<around::PosedCapture> out = truth;
  double heading = 0;
  for (std::size_t k = 1; k < truth.size(); ++k) {
    heading += drift / double(truth.size() - 1) + jitter(rng);
    const Eigen::Vector3d step = truth[k].world_from_camera.translation() - truth[k - 1].world_from_camera.translation();
    const Eigen::Vector3d side = Eigen::Vector3d::UnitY().cross(step).normalized();
    const Eigen::Vector3d measured = (1 + scale) * step + lateral(rng) * step.norm() * side;
    out[k].world_from_camera.translation() =
        out[k - 1].world_from_camera.translation() + TurnAboutVertical(heading) * measured;
    out[k].world_from_camera.linear() = TurnAboutVertical(heading) * truth[k].world_from_camera.linear();
  }
  return out;
}

struct SetTruth {
  std::vector<fitting::Sphere> hedges;
  std::vector<std::optional<fitting::Sphere>> bulges;
  std::vector<around::PosedCapture> poses;
};

// Renders a set (unless today's build rendered it there already: its stamp) and returns its truth.
SetTruth EnsureSet(const AroundBenchOptions& o, const std::string& scene, const std::string& layout, int n,
                   const std::string& set_dir) {
  const sim::SimRig rig = o.renderer == "povray" ? sim::PovrayRig(o.scale) : sim::PaperRig(o.scale);
  sim::GardenScene sc = AroundScene(scene);
  // The leaves and the lawn drawn from the seed too, so that another seed is another garden, not
  // the same leaves under other noise. Seed 1 keeps the garden's own (texture 11) and its renders.
  sc.texture_seed = 10 + o.seed;
  SetTruth t;
  for (std::size_t i = 0; i < sc.hedges.size(); ++i) {
    const cv::Vec3d c = sim::GardenLevelCenter(sc, sc.hedges[i]);
    t.hedges.push_back(fitting::Sphere{Eigen::Vector3d(c[0], c[1], c[2]), sc.hedges[i].radius_mm});
    const auto b = sim::GardenBulge(sc.hedges[i], c);
    t.bulges.push_back(b ? std::optional<fitting::Sphere>(fitting::Sphere{
                               Eigen::Vector3d(b->first[0], b->first[1], b->first[2]), b->second})
                         : std::nullopt);
  }
  const std::vector<Station> stations = Layout(layout, n, scene);
  const std::string set = scene + "_" + layout + "_" + std::to_string(n);
  // The leaves' seed named where it is not seed 1's, whose sets were rendered before it was drawn.
  const std::string leaves =
      o.seed == 1 ? "" : pipeline::Format(", leaves %llu", static_cast<unsigned long long>(sc.texture_seed));
  const std::string stamp = RenderStamp(o.renderer, pipeline::Format("scale %g, seed %llu, %s%s", o.scale,
                                                                      static_cast<unsigned long long>(o.seed),
                                                                      set.c_str(), leaves.c_str()));
  const bool have = StampMatches(set_dir, set, stamp, fs::exists(fs::path(set_dir) / "manifest.json"), "bench around");
  if (!have) {
    RemoveStamp(set_dir, set);
    std::error_code ec;
    fs::remove(fs::path(set_dir) / "manifest.json", ec);  // the set is done when it is written again
    sim::StartSimulationDir(set_dir, rig);
  }
  for (int k = 0; k < n; ++k) {
    sc.view_x_mm = stations[std::size_t(k)].x, sc.view_z_mm = stations[std::size_t(k)].z;
    sc.view_heading_deg = stations[std::size_t(k)].heading_deg;
    around::PosedCapture p;
    p.time_s = k + 1.0;
    p.name = pipeline::Format("%.3f", *p.time_s);
    p.left = p.name + "_left.png", p.right = p.name + "_right.png";
    p.world_from_camera = ToIsometry(sim::GardenLevelFromCameraPose(sc));
    t.poses.push_back(p);
    if (have) continue;
    for (bool right : {false, true}) {
      cv::Mat img;
      if (o.renderer == "povray") {
        img = sim::ApplyCameraModel(sim::RenderPovrayGarden(rig, right, sc, set_dir), sim::CameraModel(), right,
                                    o.seed * 1000 + std::uint64_t(k));
      } else {
        sim::RenderOptions ro;  // as bench garden renders its gardens
        ro.supersample = 3;
        ro.blur_sigma_px = 0.5;
        ro.noise_sigma = 1.0;
        ro.seed = o.seed * 1000 + std::uint64_t(2 * k + (right ? 1 : 0));
        img = sim::RenderGarden(rig, right, sc, ro);
      }
      stereo::WriteImageAtomic((fs::path(set_dir) / (right ? p.right : p.left)).string(), img);
    }
  }
  if (!have) {
    around::WriteManifest((fs::path(set_dir) / "manifest_odometry.json").string(), WithOdometryErrors(t.poses, o.seed),
                          "rig.yaml");
    around::WriteTum((fs::path(set_dir) / "trajectory.tum").string(), t.poses);
    around::WriteTum((fs::path(set_dir) / "trajectory_odometry.tum").string(), WithOdometryErrors(t.poses, o.seed));
    json truth = {{"hedges", json::array()}};
    for (std::size_t i = 0; i < t.hedges.size(); ++i) {
      json h = {{"center_mm", {t.hedges[i].center_mm.x(), t.hedges[i].center_mm.y(), t.hedges[i].center_mm.z()}},
                {"radius_mm", t.hedges[i].radius_mm}};
      if (t.bulges[i]) {
        h["bulge"] = {{"center_mm", {t.bulges[i]->center_mm.x(), t.bulges[i]->center_mm.y(), t.bulges[i]->center_mm.z()}},
                      {"radius_mm", t.bulges[i]->radius_mm}};
      }
      truth["hedges"].push_back(h);
    }
    cloud::WriteTextFileAtomic((fs::path(set_dir) / "around.truth.json").string(), truth.dump(2) + "\n");
    around::WriteManifest((fs::path(set_dir) / "manifest.json").string(), t.poses, "rig.yaml");
    WriteStamp(set_dir, set, stamp);  // last: marks the set done
  }
  return t;
}

// How far out the envelope reaches from `from` along unit `u`: the farthest exit from the ball
// and its bulge.
double EnvelopeAlong(const fitting::Sphere& ball, const std::optional<fitting::Sphere>& bulge, const Eigen::Vector3d& from,
                     const Eigen::Vector3d& u) {
  auto exit = [&](const fitting::Sphere& s) {
    const Eigen::Vector3d oc = from - s.center_mm;
    const double b = oc.dot(u), c = oc.squaredNorm() - s.radius_mm * s.radius_mm, disc = b * b - c;
    return disc < 0 ? 0.0 : -b + std::sqrt(disc);
  };
  double r = exit(ball);
  if (bulge) r = std::max(r, exit(*bulge));
  return r;
}

double PoseTurnDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return around::RotationDeg(a * b.inverse()); }

void Score(const SetTruth& truth, const std::vector<around::View>& views, const around::FuseResult& fused,
           const std::vector<around::PosedCapture>& given, const AroundBenchOptions& o, AroundBenchRow* row) {
  row->hedges_true = int(truth.hedges.size());
  int inside = 0, checked = 0;
  row->coverage = 1;
  for (std::size_t i = 0; i < truth.hedges.size(); ++i) {
    const fitting::Sphere& t = truth.hedges[i];
    const around::FusedHedge* best = nullptr;
    for (const auto& h : fused.hedges) {
      if ((h.fit.fit.sphere.center_mm - t.center_mm).norm() < 0.5 * t.radius_mm) best = &h;
    }
    if (!best) {
      row->coverage = 0;
      continue;
    }
    ++row->hedges_found;
    const fitting::Sphere& s = best->fit.fit.sphere;
    const double dr = std::abs(s.radius_mm - t.radius_mm), dc = (s.center_mm - t.center_mm).norm();
    if (dr > row->radius_error_mm) row->radius_error_mm = dr, row->radius_se_mm = best->std_error_mm[3];
    row->center_error_mm = std::max(row->center_error_mm, dc);
    for (int k = 0; k < 4; ++k) {
      const double err = k < 3 ? s.center_mm[k] - t.center_mm[k] : s.radius_mm - t.radius_mm;
      if (std::isfinite(best->std_error_mm[k])) ++checked, inside += std::abs(err) <= 1.96 * best->std_error_mm[k];
    }
    row->coverage = std::min(row->coverage, best->coverage);
    double vc = 0;
    for (double c : best->view_coverage) vc += c / double(best->view_coverage.size());
    row->view_coverage += vc / double(truth.hedges.size());
    // The trim plan against the geometry, over what was seen.
    if (truth.bulges[i]) {
      std::vector<Eigen::Vector3d> pts;
      for (std::size_t k = 0; k < fused.cloud.size(); ++k) {
        if (int(fused.cloud.fields.at(cloud::kHedgeIdField)[k]) == best->id) pts.push_back(fused.cloud.points_mm[k].cast<double>());
      }
      fitting::TrimOptions to;
      to.clipped_share = std::clamp(best->fit.clipped_share, 0.05, 1.0);
      const fitting::Sphere target{s.center_mm, t.radius_mm - o.trim_depth_mm};
      const fitting::TrimPlan plan = fitting::PlanTrim(pts, target, to, fused.up);
      double truth_mm3 = 0;
      const double R = target.radius_mm;
      for (const fitting::TrimBin& b : plan.bins) {
        if (b.weight <= 0) continue;
        const double r = EnvelopeAlong(t, truth.bulges[i], target.center_mm, b.direction);
        if (r - R > to.tolerance_mm) truth_mm3 += b.weight * b.solid_angle_sr * (r * r * r - R * R * R) / 3;
      }
      row->trim_volume_l = plan.volume_seen_l;
      row->trim_truth_l = truth_mm3 * 1e-6;
      row->trim_unseen_max_l = plan.volume_unseen_max_l;
      row->seen_share = plan.seen_share;
    }
  }
  for (const auto& h : fused.hedges) {
    if (!h.unconfirmed.empty()) {
      ++row->unconfirmed;
      continue;
    }
    const bool real = std::any_of(truth.hedges.begin(), truth.hedges.end(), [&](const fitting::Sphere& t) {
      return (h.fit.fit.sphere.center_mm - t.center_mm).norm() < 0.5 * t.radius_mm;
    });
    row->phantoms += real ? 0 : 1;
  }
  row->inside_share = checked ? double(inside) / checked : 0;
  // Each capture alone, against the truth nearest its centre (in the true pose).
  int singles = 0;
  for (std::size_t v = 0; v < views.size(); ++v) {
    for (const auto& h : views[v].hedges) {
      if (!h.fit.converged) continue;
      const Eigen::Vector3d c = truth.poses[v].world_from_camera * h.fit.sphere.center_mm;
      for (const auto& t : truth.hedges) {
        if ((c - t.center_mm).norm() > 0.5 * t.radius_mm) continue;
        row->single_radius_error_mm += std::abs(h.fit.sphere.radius_mm - t.radius_mm);
        row->single_center_error_mm += (c - t.center_mm).norm();
        ++singles;
      }
    }
  }
  if (singles) row->single_radius_error_mm /= singles, row->single_center_error_mm /= singles;
  for (std::size_t v = 0; v < fused.poses.size(); ++v) {
    const auto& p = fused.poses[v];
    const Eigen::Isometry3d& tp = truth.poses[v].world_from_camera;
    row->given_pose_mm = std::max(row->given_pose_mm, (given[v].world_from_camera.translation() - tp.translation()).norm());
    row->given_pose_deg = std::max(row->given_pose_deg, PoseTurnDeg(given[v].world_from_camera, tp));
    if (!p.used) continue;
    ++row->used;
    row->pose_mm = std::max(row->pose_mm, (p.refined.translation() - tp.translation()).norm());
    row->pose_deg = std::max(row->pose_deg, PoseTurnDeg(p.refined, tp));
  }
}

}  // namespace

// The prior exact poses are given with (RunAroundBench).
constexpr double kExactPoseSigmaMm = 0.5, kExactPoseSigmaDeg = 0.05;

AroundBenchResult RunAroundBench(const AroundBenchOptions& o) {
  AroundBenchOptions::Table().Validate(o);
  AroundBenchResult result;
  for (const std::string& scene : Split(o.scenes)) {
    for (const std::string& layout : Split(o.layouts)) {
      for (const std::string& count : Split(o.captures)) {
        const int n = std::stoi(count);
        const std::string set_dir =
            (fs::path(o.dir) / o.renderer / pipeline::Format("%s_%s_%d", scene.c_str(), layout.c_str(), n)).string();
        const SetTruth truth = EnsureSet(o, scene, layout, n, set_dir);
        auto t0 = std::chrono::steady_clock::now();
        const std::vector<around::PosedCapture> exact = around::ReadManifest((fs::path(set_dir) / "manifest.json").string());
        stereo::ConvertOptions co;
        const std::vector<around::View> measured = around::MeasureViews(exact, "", co);
        const double measure_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        for (const std::string& poses : Split(o.poses)) {
          const std::vector<around::PosedCapture> given = around::ReadManifest(
              (fs::path(set_dir) / (poses == "exact" ? "manifest.json" : "manifest_odometry.json")).string());
          std::vector<around::View> views = measured;
          for (std::size_t v = 0; v < views.size(); ++v) views[v].world_from_camera = given[v].world_from_camera;
          around::FuseOptions fo;
          fo.registration = o.registration;
          if (poses == "exact") {
            // Exact poses are given as a user with them would (measure --prior-translation,
            // --prior-rotation): good to half a millimetre and 0.05 degrees, a motion-capture
            // system's or a robot arm's. The default prior is odometry's (150 mm, 3 degrees).
            fo.prior_translation_mm = kExactPoseSigmaMm;
            fo.prior_rotation_deg = kExactPoseSigmaDeg;
          }
          AroundBenchRow row;
          row.renderer = o.renderer, row.scene = scene, row.layout = layout, row.poses = poses, row.captures = n;
          row.measure_seconds = measure_s;
          auto t1 = std::chrono::steady_clock::now();
          const around::FuseResult fused = around::Fuse(views, fo);
          row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
          Score(truth, measured, fused, given, o, &row);
          result.rows.push_back(row);
          std::fprintf(stderr, "bench around: %s %s %s %d %s done\n", o.renderer.c_str(), scene.c_str(), layout.c_str(), n,
                       poses.c_str());
        }
      }
    }
  }
  return result;
}

void PrintAroundBench(const AroundBenchResult& r) {
  std::printf("%-8s %-6s %-5s %3s %-8s %5s %6s %7s %8s %8s %7s %6s %7s %7s %9s %9s %8s %8s %8s\n", "renderer", "scene",
              "set", "n", "poses", "used", "found", "ph/unc", "dR mm", "dC mm", "se R", "in95", "cover", "1 view", "alone dR",
              "given", "after", "trim L", "truth L");
  for (const AroundBenchRow& w : r.rows) {
    std::printf("%-8s %-6s %-5s %3d %-8s %5d %3d/%-2d %4d/%-2d %8.2f %8.2f %7.2f %6.2f %6.1f%% %6.1f%% %9.2f %4.0f/%4.1f %4.1f/%4.2f %8s %8s\n",
                w.renderer.c_str(), w.scene.c_str(), w.layout.c_str(), w.captures, w.poses.c_str(), w.used,
                w.hedges_found, w.hedges_true, w.phantoms, w.unconfirmed, w.radius_error_mm, w.center_error_mm,
                w.radius_se_mm, w.inside_share, 100 * w.coverage, 100 * w.view_coverage, w.single_radius_error_mm, w.given_pose_mm, w.given_pose_deg,
                w.pose_mm, w.pose_deg, w.trim_truth_l > 0 ? pipeline::Format("%.2f", w.trim_volume_l).c_str() : "",
                w.trim_truth_l > 0 ? pipeline::Format("%.2f", w.trim_truth_l).c_str() : "");
  }
}

std::string AroundBenchJson(const AroundBenchResult& r) {
  json out = json::array();
  for (const AroundBenchRow& w : r.rows) {
    out.push_back({{"renderer", w.renderer}, {"scene", w.scene}, {"layout", w.layout}, {"captures", w.captures},
                   {"poses", w.poses}, {"used", w.used}, {"hedges_true", w.hedges_true}, {"hedges_found", w.hedges_found},
                   {"phantoms", w.phantoms}, {"unconfirmed", w.unconfirmed},
                   {"radius_error_mm", w.radius_error_mm}, {"center_error_mm", w.center_error_mm},
                   {"radius_se_mm", w.radius_se_mm}, {"inside_share", w.inside_share}, {"coverage", w.coverage},
                   {"view_coverage", w.view_coverage}, {"single_radius_error_mm", w.single_radius_error_mm},
                   {"single_center_error_mm", w.single_center_error_mm}, {"given_pose_mm", w.given_pose_mm},
                   {"given_pose_deg", w.given_pose_deg}, {"pose_mm", w.pose_mm}, {"pose_deg", w.pose_deg},
                   {"trim_volume_l", w.trim_volume_l}, {"trim_truth_l", w.trim_truth_l},
                   {"trim_unseen_max_l", w.trim_unseen_max_l}, {"seen_share", w.seen_share}, {"seconds", w.seconds},
                   {"measure_seconds", w.measure_seconds}});
  }
  return out.dump(2);
}

}  // namespace hedgefit::bench
