#include "bench/lab_bench.hpp"

#include <sstream>
#include "cloud/cleaning.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "bench/render_stamp.hpp"
#include "bench/sgbm_mode_option.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/print.hpp"
#include "fitting/fit_fields.hpp"
#include "fitting/methods.hpp"
#include "fitting/uncertainty.hpp"
#include "stereo/calibration.hpp"
#include "sim/camera_model.hpp"
#include "sim/povray.hpp"
#include "stereo/rig_uncertainty.hpp"
#include "sim/simulator.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::bench {

LabOptions::LabOptions() : alpha(stereo::CalibrationOptions{}.alpha) {}

const pipeline::OptionTable<LabOptions>& LabOptions::Table() {
  using O = LabOptions;
  static const auto table = WithSgbmMode(
      pipeline::OptionTable<O>()
          .Add("dir", &O::dir, "where the simulated captures go")
          .Add("scale", &O::scale, "image scale of the simulated rig (1 = 1920 x 1200)")
          .Range(0.25, 2.0)
          .Add("reuse", &O::reuse, "reuse captures already in --dir that today's build rendered with these options (their stamp)")
          .Add("wide_boards", &O::wide_boards,
               "also calibrate from 12 boards near the image's edges (simulate --preset wide-boards; rendered if missing)")
          .Add("renderer", &O::renderer,
               "hedgefit (its own simulator) or povray (an independent ray tracer: its own camera, textures, lights, "
               "anti-aliasing)")
          .Choices({"hedgefit", "povray"})
          .Add("camera", &O::camera,
               "ideal (as rendered) or real (gains, white balance, vignetting, Bayer, shot and read noise per camera)")
          .Choices({"ideal", "real"})
          .Add("noise_draws", &O::noise_draws,
               "with --camera real: record each sphere N times, each with its own draw of the cameras' noise (the "
               "same render and calibration), and summarise over all of them with the spread of one draw's 7 "
               "captures; the as-rendered spheres are kept in --dir/as_rendered")
          .Range(1, 100)
          .AddCustom(
              "camera_without", pipeline::OptionType::kString,
              "with --camera real: leave these camera effects (gains, vignetting, bayer, noise, jpeg; comma-separated) "
              "out of the spheres' pairs to see what each costs; the boards, and so the calibration, keep them all",
              "",
              [](const O& o) -> pipeline::OptionValue {
                std::string text;
                for (const auto& e : o.camera_without) text += (text.empty() ? "" : ",") + e;
                return text;
              },
              [](O& o, const pipeline::OptionValue& v) {
                o.camera_without.clear();
                std::stringstream in(std::get<std::string>(v));
                for (std::string e; std::getline(in, e, ',');) {
                  if (!e.empty()) o.camera_without.push_back(e);
                }
              })
          .Bind<int>("erode", [](O& o) -> int& { return o.convert.segment.erode_px; },
                     "mask erosion (drops the silhouette ring)", "px")
          .Range(0, 200)
          .Bind<int>("refine_radius", [](O& o) -> int& { return o.convert.match.sgbm.refine_radius; },
                     "sub-pixel refinement window half-size (0 = off)", "px")
          .Range(0, 15)
          .Bind<int>("refine_curvature", [](O& o) -> int& { return o.convert.match.sgbm.refine_curvature; },
                     "curvature correction grid half-size, steps of 2 px (0 = off)")
          .Range(0, 10)
          .Bind<int>("max_points", [](O& o) -> int& { return o.convert.match.max_points; },
                     "at most this many pixels matched and refined per hedge: a larger hedge keeps every s-th pixel "
                     "and row (0 = every pixel; the lab sphere covers about 45,000)")
          .Range(0, 100000000)
          .Bind<int>("min_stride", [](O& o) -> int& { return o.convert.match.min_stride; },
                     "every n-th pixel and row at most, however small the hedge (1 = every pixel; from 3 SGBM runs at "
                     "half resolution, half_res_from_stride)")
          .Range(1, 64)
          .Add("alpha", &O::alpha,
               "rectification scaling (0 = only valid pixels, -1 = OpenCV's default): a rectified focal length that "
               "differs from the camera's varies the resampling phase over the hedge")
          .Range(-1.0, 1.0)
          .Add("true_rig", &O::true_rig,
               "use the simulator's exact rig instead of calibrating from the boards (separates calibration error "
               "from matching error)"),
      [](O& o) -> stereo::SgbmOptions& { return o.convert.match.sgbm; });
  return table;
}

namespace {

// RANSAC for the lab: ~3 sigma of depth noise at 2.6 m on this rig, radii of lab spheres.
const std::map<std::string, pipeline::OptionValue> kLabFitOptions = {
    {"distance_threshold", 15.0}, {"min_radius", 100.0}, {"max_radius", 1000.0}};

struct Spread {
  double mean = 0, sd = 0, min = 0, max = 0;
};

Spread SpreadOf(const std::vector<eval::MethodSummary>& draws, double eval::MethodSummary::*field) {
  Spread s;
  if (draws.empty()) return s;
  s.min = s.max = draws.front().*field;
  for (const auto& d : draws) s.mean += d.*field, s.min = std::min(s.min, d.*field), s.max = std::max(s.max, d.*field);
  s.mean /= double(draws.size());
  for (const auto& d : draws) s.sd += (d.*field - s.mean) * (d.*field - s.mean);
  s.sd = draws.size() > 1 ? std::sqrt(s.sd / double(draws.size() - 1)) : 0.0;
  return s;
}

// How hedgefit's renderer draws every image of the lab: 3 x 3 rays per pixel, 0.5 px of blur.
sim::RenderOptions LabRenderOptions() {
  sim::RenderOptions ro;
  ro.supersample = 3;
  ro.blur_sigma_px = 0.5;
  return ro;
}

std::string AsRenderedDir(const LabOptions& a) { return (std::filesystem::path(a.dir) / "as_rendered").string(); }

// The sphere `sc` as the renderer drew it, before any camera: from `dir`/as_rendered, or rendered
// (and kept there) when missing.
cv::Mat AsRenderedSphere(const LabOptions& a, const sim::SphereScene& sc, bool right, const std::string& name) {
  namespace fs = std::filesystem;
  const fs::path path = fs::path(AsRenderedDir(a)) / (name + (right ? "_right.png" : "_left.png"));
  if (fs::exists(path)) return stereo::ReadImageFile(path.string());
  fs::create_directories(path.parent_path());
  cv::Mat img;
  if (a.renderer == "povray") {
    img = sim::RenderPovray(sim::PovrayRig(a.scale), right, "sphere", {}, sc, AsRenderedDir(a));
  } else {
    img = sim::RenderSphere(sim::PaperRig(a.scale), right, sc, LabRenderOptions());
  }
  stereo::WriteImageAtomic(path.string(), img);
  return img;
}

}  // namespace

void IntervalCoverage::Add(const fitting::SphereFitResult& f, const fitting::Sphere& truth) {
  const auto total = fitting::TotalStdError(f);
  if (!f.converged || !total) return;
  const Eigen::Vector4d err(f.sphere.center_mm.x() - truth.center_mm.x(), f.sphere.center_mm.y() - truth.center_mm.y(),
                            f.sphere.center_mm.z() - truth.center_mm.z(), f.sphere.radius_mm - truth.radius_mm);
  for (int k = 0; k < 4; ++k) {
    ++cases;
    inside += std::abs(err[k]) <= 1.96 * (*total)[k];
    stated2 += (*total)[k] * (*total)[k];
    error2 += err[k] * err[k];
    if (f.rig_std_error_mm) rig2 += (*f.rig_std_error_mm)[k] * (*f.rig_std_error_mm)[k];
    if (f.matching_std_error_mm) matching2 += (*f.matching_std_error_mm)[k] * (*f.matching_std_error_mm)[k];
  }
}

std::vector<std::pair<std::string, std::vector<double>>> StatedUncertainty(const fitting::SphereFitResult& fit) {
  std::vector<std::pair<std::string, std::vector<double>>> out;
  for (const auto& [key, value] : fitting::FitFields(fit)) {
    if (key.find("std_error_mm") != std::string::npos || key == "ci95_mm") {
      out.emplace_back(key, std::get<std::vector<double>>(value));
    }
  }
  return out;
}

namespace {

// The lab's captures (and the wide boards, when asked) in a.dir, rendered unless --reuse finds
// them there stamped by today's build with these options.
void EnsureLabRenders(const LabOptions& a, const sim::CameraModel& camera) {
  namespace fs = std::filesystem;
  const std::string set = "lab", stamp = RenderStamp(a.renderer, pipeline::Format("scale %g, camera %s, the lab",
                                                                                 a.scale, a.camera.c_str()));
  const bool have = fs::exists(fs::path(a.dir) / "sphere_2600_right.png");
  if (!(a.reuse && StampMatches(a.dir, set, stamp, have, "bench lab"))) {
    RemoveStamp(a.dir, set);
    RemoveStamp(a.dir, "wide boards");  // drawn beside the lab's own: rendered again with it
    if (a.renderer == "povray") {
      sim::WritePovrayLab(a.dir, a.scale, camera, 1, a.camera == "real" ? AsRenderedDir(a) : std::string());
    } else {
      const auto files = sim::WritePaperLab(a.dir, a.scale, LabRenderOptions());
      if (a.camera == "real") {
        std::uint64_t view = 0;
        for (const auto& f : files) {
          if (f.size() < 4 || f.compare(f.size() - 4, 4, ".png") != 0) continue;
          const bool right = f.find("_right.png") != std::string::npos;
          // The as-rendered spheres are the other noise draws' source.
          if (fs::path(f).filename().string().rfind("sphere_", 0) == 0) {
            fs::create_directories(AsRenderedDir(a));
            fs::copy_file(f, fs::path(AsRenderedDir(a)) / fs::path(f).filename(), fs::copy_options::overwrite_existing);
          }
          stereo::WriteImageAtomic(f, sim::ApplyCameraModel(stereo::ReadImageFile(f), camera, right, 1 + view++ / 2));
        }
      }
    }
    WriteStamp(a.dir, set, stamp);
  }
  if (a.wide_boards && !a.true_rig) {
    const std::string wide = RenderStamp(a.renderer, pipeline::Format("scale %g, camera %s, wide boards", a.scale,
                                                                      a.camera.c_str()));
    if (!StampMatches(a.dir, "wide boards", wide, fs::exists(fs::path(a.dir) / "board_28_right.png"), "bench lab")) {
      sim::WriteWideBoards(a.dir, a.renderer, a.scale, LabRenderOptions(), camera);
      WriteStamp(a.dir, "wide boards", wide);
    }
  }
}

}  // namespace

LabResult RunLab(const LabOptions& a) {
  namespace fs = std::filesystem;
  const auto t0 = std::chrono::steady_clock::now();
  if (a.renderer != "hedgefit" && a.renderer != "povray") throw Error("--renderer: use hedgefit or povray");
  if (a.camera != "ideal" && a.camera != "real") throw Error("--camera: use ideal or real");
  if (a.noise_draws < 1) throw Error("--noise-draws: give at least 1");
  if (!a.cleaning.empty()) cloud::CheckFilterStages(a.cleaning, "bench lab's cleaning");
  if (a.noise_draws > 1 && a.camera != "real") {
    throw Error("--noise-draws: only a real camera draws noise; add --camera real or leave --noise-draws at 1");
  }
  const sim::CameraModel camera = a.camera == "real" ? sim::CameraModel() : sim::CameraModel::Ideal();
  if (!a.camera_without.empty() && a.camera != "real") {
    throw Error("--camera-without: only a real camera has effects to leave out; add --camera real");
  }
  sim::CameraModel sphere_camera = camera;
  for (const auto& e : a.camera_without) sphere_camera = sim::WithoutEffect(sphere_camera, e, "--camera-without");
  EnsureLabRenders(a, camera);
  std::vector<std::pair<std::string, std::string>> boards;
  for (int i = 1; i <= (a.wide_boards ? 28 : 16); ++i) {
    char l[32], r[32];
    std::snprintf(l, sizeof(l), "board_%02d_left.png", i);
    std::snprintf(r, sizeof(r), "board_%02d_right.png", i);
    boards.emplace_back((fs::path(a.dir) / l).string(), (fs::path(a.dir) / r).string());
  }
  stereo::CalibrationOptions co;
  co.board.inner_corners = cv::Size(12, 11);
  co.board.square_mm = 30;
  co.alpha = a.alpha;
  cv::Size size;
  const stereo::StereoRig rig =
      a.true_rig ? sim::RigFromSimulation(a.renderer == "povray" ? sim::PovrayRig(a.scale) : sim::PaperRig(a.scale))
                 : stereo::CalibrateFromCorners(stereo::DetectBoards(boards, co.board, &size), size, co);
  LabResult out;
  out.rms_stereo_px = rig.rms_stereo_px;
  out.baseline_mm = rig.baseline_mm;
  out.exact_rig = a.true_rig;
  eval::SummaryBuilder summary;
  // The rig's calibration uncertainty, carried into every fit (none for the exact rig).
  const cloud::PointPerturbation perturbation = stereo::RigPerturbation(rig);
  const cloud::PointPerturbation matching = stereo::DisparityOffsetPerturbation(rig);
  const std::vector<sim::SphereScene> spheres = sim::PaperLabSpheres();
  for (int draw = 1; draw <= a.noise_draws; ++draw) {
    eval::SummaryBuilder draw_summary;
    for (std::size_t k = 0; k < spheres.size(); ++k) {
      const int z = static_cast<int>(std::lround(spheres[k].center[2]));
      char name[32];
      std::snprintf(name, sizeof(name), "sphere_%04d", z);
      const fs::path base = fs::path(a.dir) / name;
      LabRow row;
      row.z_mm = z;
      row.draw = draw;
      row.truth = eval::ReadTruthFile(base.string() + ".truth.json");
      cv::Mat left, right;
      if (draw == 1 && a.camera_without.empty()) {
        left = stereo::ReadImageFile(base.string() + "_left.png");
        right = stereo::ReadImageFile(base.string() + "_right.png");
      } else {
        // Seeds no other image of the lab draws (the renderers' own stay below 10^6).
        const std::uint64_t seed = 1000000 + 1000 * std::uint64_t(draw) + k;
        left = sim::ApplyCameraModel(AsRenderedSphere(a, spheres[k], false, name), sphere_camera, false, seed);
        right = sim::ApplyCameraModel(AsRenderedSphere(a, spheres[k], true, name), sphere_camera, true, seed);
      }
      const stereo::ConvertResult res = stereo::ConvertCapture(left, right, rig, a.convert);
      row.convert_ms = res.wall_ms;
      cloud::PointCloud cleaned_copy;
      if (!a.cleaning.empty()) cleaned_copy = cloud::RunFilterStages(res.cloud, a.cleaning, "bench lab's cleaning");
      const cloud::PointCloud& cleaned = a.cleaning.empty() ? res.cloud : cleaned_copy;
      std::vector<Eigen::Vector3d> pts;
      std::vector<std::size_t> finite;
      for (std::size_t i = 0; i < cleaned.size(); ++i) {
        if (cloud::IsFinite(cleaned.points_mm[i])) pts.push_back(cleaned.points_mm[i].cast<double>()), finite.push_back(i);
      }
      const std::vector<double> pixel_mm = cloud::FieldAt(cleaned, cloud::kPixelSizeField, finite);
      row.points = pts.size();
      for (const auto& m : fitting::SphereMethodNames()) {
        row.fits.push_back(fitting::RunFitMethod(m, pts, kLabFitOptions, 42, false, &pixel_mm));
        fitting::AddUncertainty(pts, &perturbation, &row.fits.back(), &matching);
        summary.Add(m, row.fits.back(), row.truth);
        draw_summary.Add(m, row.fits.back(), row.truth);
      }
      out.rows.push_back(std::move(row));
    }
    if (a.noise_draws > 1) {
      for (const auto& [m, s] : draw_summary.Finish()) out.per_draw[m].push_back(s);
    }
  }
  out.noise_draws = a.noise_draws;
  out.camera_without = a.camera_without;
  out.summary = summary.Finish();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void PrintLab(const LabResult& r) {
  if (r.exact_rig) {
    std::printf("using the simulator's exact rig (no calibration error), baseline %.3f mm\n", r.baseline_mm);
  } else {
    std::printf("calibrated from the simulated boards: stereo RMS %.3f px, baseline %.3f mm\n", r.rms_stereo_px,
                r.baseline_mm);
  }
  if (!r.camera_without.empty()) {
    std::string effects;
    for (const auto& e : r.camera_without) effects += (effects.empty() ? "" : ", ") + e;
    std::printf("spheres recorded without the camera's %s (the boards keep every effect), every draw afresh\n",
                effects.c_str());
  }
  const std::vector<std::string> methods = fitting::SphereMethodNames();
  for (std::size_t k = 0; k < methods.size(); ++k) {
    std::printf("\n%s\n  %6s %8s %8s %8s %7s %26s %26s %7s\n", methods[k].c_str(), "Z mm", "AR mm", "MR mm", "AER mm",
                "RER %", "AL (x, y, z) mm", "ML (x, y, z) mm", "LD mm");
    for (const auto& row : r.rows) {
      if (row.draw != 1) continue;  // the pairs on disk; the other draws are in the summaries
      const auto& f = row.fits[k];
      if (!f.converged) {
        std::printf("  %6.0f failed: %s\n", row.z_mm, f.message.c_str());
        continue;
      }
      const auto e = eval::Evaluate(f.sphere, row.truth);
      std::printf("  %6.0f %8.2f %8.2f %8.2f %7.2f   (%6.1f, %6.1f, %7.1f)   (%6.1f, %6.1f, %7.1f) %7.2f\n", row.z_mm,
                  row.truth.radius_mm, f.sphere.radius_mm, e.aer_mm, e.rer_percent, row.truth.center_mm.x(),
                  row.truth.center_mm.y(), row.truth.center_mm.z(), f.sphere.center_mm.x(), f.sphere.center_mm.y(),
                  f.sphere.center_mm.z(), e.ld_mm);
    }
  }
  if (r.noise_draws > 1) {
    std::printf("\n(the tables above are draw 1%s; the summary is over all %d draws)\n",
                r.camera_without.empty() ? ", the pairs in the directory" : "", r.noise_draws);
  }
  std::printf("\nsummary over Z = 2000..2600 mm (7 positions x %d noise draw%s)\n  %-17s %10s %10s %9s %9s %9s %9s\n",
              r.noise_draws, r.noise_draws > 1 ? "s" : "", "method",
              "mean|AER|", "max|AER|", "mean RER%", "RMSE", "mean LD", "max LD");
  for (const auto& m : methods) {
    const auto& s = r.summary.at(m);
    std::printf("  %-17s %10.2f %10.2f %9.3f %9.2f %9.2f %9.2f\n", m.c_str(), s.mean_abs_aer_mm, s.max_abs_aer_mm,
                s.mean_rer_percent, s.rmse_radius_mm, s.mean_ld_mm, s.max_ld_mm);
  }
  const eval::MethodSummary p = eval::PaperTable2();
  std::printf("  %-17s %10.2f %10.2f %9.3f %9.2f %9.2f %9.2f   (published, %s)\n", "paper", p.mean_abs_aer_mm,
              p.max_abs_aer_mm, p.mean_rer_percent, p.rmse_radius_mm, p.mean_ld_mm, p.max_ld_mm,
              eval::kPaperTable2Label);
  if (!r.per_draw.empty()) {
    // How far one draw of seven captures - what a single run reports - strays from the mean.
    std::printf("\nper noise draw (7 captures each): mean|AER| and mean LD, their mean, sd and range over %d draws\n"
                "  %-17s %8s %6s %15s %9s %6s %15s\n",
                r.noise_draws, "method", "|AER|", "sd", "min - max", "LD", "sd", "min - max");
    for (const auto& m : methods) {
      const auto it = r.per_draw.find(m);
      if (it == r.per_draw.end()) continue;
      const Spread aer = SpreadOf(it->second, &eval::MethodSummary::mean_abs_aer_mm);
      const Spread ld = SpreadOf(it->second, &eval::MethodSummary::mean_ld_mm);
      std::printf("  %-17s %8.2f %6.2f %7.2f - %5.2f %9.2f %6.2f %7.2f - %5.2f\n", m.c_str(), aer.mean, aer.sd, aer.min,
                  aer.max, ld.mean, ld.sd, ld.min, ld.max);
    }
  }
  // Do the stated 95 % intervals (points + rig) hold the truth? Per method, over the 7
  // captures x (cx, cy, cz, r); and the stated standard error against the actual error.
  std::printf("\n95 %% intervals (points' scatter, rig calibration, matcher's common offset) against the truth\n  %-17s %9s "
              "%14s %14s %9s %11s\n",
              "method", "inside", "stated se mm", "actual rms mm", "rig %", "matching %");
  for (std::size_t k = 0; k < methods.size(); ++k) {
    IntervalCoverage c;
    for (const auto& row : r.rows) c.Add(row.fits[k], row.truth);
    if (c.cases == 0) continue;
    std::printf("  %-17s %4d/%-4d %14.2f %14.2f %9.0f %11.0f\n", methods[k].c_str(), c.inside, c.cases, c.StatedRms(),
                c.ErrorRms(), c.RigPercent(), c.MatchingPercent());
  }
  double ms = 0;
  for (const auto& row : r.rows) ms += row.convert_ms;
  std::printf("capture to cloud: %.0f ms per 1920x1200-scaled pair on average; whole run %.1f s\n",
              ms / double(r.rows.size()), r.seconds);
}

std::string LabJson(const LabResult& r) {
  nlohmann::json out;
  out["rig"] = {{"rms_stereo_px", r.rms_stereo_px}, {"baseline_mm", r.baseline_mm}, {"exact", r.exact_rig}};
  const std::vector<std::string> methods = fitting::SphereMethodNames();
  out["rows"] = nlohmann::json::array();
  for (std::size_t k = 0; k < methods.size(); ++k) {
    for (const auto& row : r.rows) {
      const auto& f = row.fits[k];
      if (!f.converged) continue;
      const auto e = eval::Evaluate(f.sphere, row.truth);
      out["rows"].push_back({{"method", methods[k]}, {"z_mm", row.z_mm}, {"draw", row.draw}, {"ar_mm", row.truth.radius_mm},
                             {"mr_mm", f.sphere.radius_mm}, {"aer_mm", e.aer_mm}, {"rer_percent", e.rer_percent},
                             {"ld_mm", e.ld_mm},
                             {"ml_mm", {f.sphere.center_mm.x(), f.sphere.center_mm.y(), f.sphere.center_mm.z()}},
                             {"al_mm", {row.truth.center_mm.x(), row.truth.center_mm.y(), row.truth.center_mm.z()}}});
      for (const auto& [key, value] : StatedUncertainty(f)) out["rows"].back()[key] = value;
    }
  }
  for (const auto& m : methods) {
    const auto& s = r.summary.at(m);
    out["summary"][m] = {{"mean_abs_aer_mm", s.mean_abs_aer_mm}, {"max_abs_aer_mm", s.max_abs_aer_mm},
                         {"mean_rer_percent", s.mean_rer_percent}, {"rmse_radius_mm", s.rmse_radius_mm},
                         {"mean_ld_mm", s.mean_ld_mm}, {"max_ld_mm", s.max_ld_mm}, {"failures", s.failures}};
  }
  out["noise_draws"] = r.noise_draws;
  out["camera_without"] = r.camera_without;
  for (const auto& [m, draws] : r.per_draw) {
    for (const auto& d : draws) {
      out["per_draw"][m].push_back({{"mean_abs_aer_mm", d.mean_abs_aer_mm}, {"mean_ld_mm", d.mean_ld_mm}});
    }
  }
  const eval::MethodSummary p = eval::PaperTable2();
  out["paper"] = {{"mean_abs_aer_mm", p.mean_abs_aer_mm}, {"mean_rer_percent", p.mean_rer_percent},
                  {"mean_ld_mm", p.mean_ld_mm}, {"source", eval::kPaperTable2Label}};
  return out.dump(2) + "\n";
}

}  // namespace hedgefit::bench
