#include "bench/garden_bench.hpp"
#include "cloud/cleaning.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "bench/lab_bench.hpp"
#include "bench/render_stamp.hpp"
#include "bench/sgbm_mode_option.hpp"
#include "cloud/filters.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/print.hpp"
#include "eval/truth_file.hpp"
#include "fitting/methods.hpp"
#include "fitting/uncertainty.hpp"
#include "sim/povray.hpp"
#include "stereo/rig_uncertainty.hpp"
#include "sim/simulator.hpp"
#include "stereo/image_io.hpp"
#include "stereo/outline.hpp"
#include "measure/outline_start.hpp"

namespace hedgefit::bench {

GardenOptions::GardenOptions() : cleaning(cloud::DefaultCleaningJson()) { convert.mode = stereo::SegmentMode::kGarden; }

const pipeline::OptionTable<GardenOptions>& GardenOptions::Table() {
  using O = GardenOptions;
  static const auto table = WithSgbmMode(
      pipeline::OptionTable<O>()
          .Add("dir", &O::dir, "where the simulated captures go")
          .Add("scale", &O::scale, "image scale of the simulated rig (1 = 1920 x 1200)")
          .Range(0.25, 2.0)
          .Add("reuse", &O::reuse,
               "reuse captures already in --dir that today's build rendered with these options (their stamp)")
          .Add("renderer", &O::renderer,
               "hedgefit (its own ray caster, a noise-shaded leaf shell) or povray (POV-Ray, hedges of leaf discs)")
          .Choices({"hedgefit", "povray"})
          .Add("camera", &O::camera, "povray: ideal, or real (per-camera noise, gains, white balance, vignetting, Bayer)")
          .Choices({"ideal", "real"})
          .Add("hard", &O::hard,
               "the harder gardens instead: two balls with the hedge row between them, a low and a high camera, the "
               "smallest ball farthest, the largest nearest, one near each edge of the image, one cut by it, three "
               "touching in a row, one among other shrubs")
          .Add("random", &O::random,
               "N gardens drawn from seeds 1..N instead (random1 ...): one to three balls of the issue's range side by "
               "side, a camera 0.9-1.4 m up, sometimes a shrub (not with --hard)")
          .Range(0, 200)
          .Add("paper", &O::paper,
               "N gardens of the paper's outdoor size instead (paper1 ...): one or two balls of r 880-960 mm, the "
               "nearest 2.0-2.4 m away, in one of the four leaf presets, sun or overcast")
          .Range(0, 200)
          .Add("first_seed", &O::first_seed,
               "the first seed of --random and --paper (1: the tuning seeds; 101: the held-back ones)")
          .Range(1, 100000)
          .Add("gardens", &O::gardens, "these garden presets instead, comma-separated (sim::GardenPreset's names)")
          .Add("outline", &O::outline, "fit the envelope to each hedge's outline in both views too")
          .Add("leaves", &O::leaves,
               "the gardens across leaves instead (sim::GardenLeafPresetNames): boxwood, yew, privet and holly, each "
               "with two balls in sun and a dome and a ball under an overcast sky")
          .Bind<int>("garden_refine_curvature", [](O& o) -> int& { return o.convert.match.garden_refine_curvature; },
                     "curvature correction grid half-size for hedges found by depth, steps of 2 px (0 = off)")
          .Range(0, 10)
          .Add("envelope_points_per_ray", &O::envelope_points_per_ray,
               "the envelope fit's points_per_ray: with an outline, the front weighted to the say of this many points per "
               "outline ray (0 = off; -1, the default, leaves the fit's own default, 1)")
          .Min(-1)
          .Bind<int>("max_points", [](O& o) -> int& { return o.convert.match.max_points; },
                     "at most this many pixels matched and refined per hedge: a larger hedge keeps every s-th pixel "
                     "and row (0 = every pixel)")
          .Range(0, 100000000),
      [](O& o) -> stereo::SgbmOptions& { return o.convert.match.sgbm; });
  return table;
}

namespace {

double Ms(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

void LeafLayerErrors::Add(const LeafLayerErrors& o) {
  if (bins.empty()) {
    *this = o;
    return;
  }
  const double n = double(points), m = double(o.points);
  if (n + m > 0) {
    true_outer_share = (true_outer_share * n + o.true_outer_share * m) / (n + m);
    measured_outer_share = (measured_outer_share * n + o.measured_outer_share * m) / (n + m);
  }
  points += o.points;
  for (std::size_t b = 0; b < bins.size() && b < o.bins.size(); ++b) {
    const double k = double(bins[b].points), l = double(o.bins[b].points);
    if (k + l > 0) bins[b].mean_error_mm = (bins[b].mean_error_mm * k + o.bins[b].mean_error_mm * l) / (k + l);
    bins[b].points += o.bins[b].points;
  }
}

LeafLayerErrors MeasureLeafLayer(const std::vector<Eigen::Vector3d>& points_mm, const cv::Mat& surface,
                                 const sim::SimCamera& camera, const fitting::Sphere& truth) {
  LeafLayerErrors out;
  const double edges[] = {0, 2, 5, 10, 15, 20, 30, 60};
  for (std::size_t b = 0; b + 1 < std::size(edges); ++b) out.bins.push_back({edges[b], edges[b + 1], 0, 0.0});
  if (points_mm.empty()) return out;
  std::vector<cv::Point3d> obj;
  obj.reserve(points_mm.size());
  for (const auto& p : points_mm) obj.emplace_back(p.x(), p.y(), p.z());
  std::vector<cv::Point2d> px;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(camera.K), cv::Mat(camera.dist), px);
  std::vector<double> sum(out.bins.size(), 0.0);
  std::size_t outer_true = 0, outer_measured = 0;
  const double R = truth.radius_mm;
  for (std::size_t i = 0; i < obj.size(); ++i) {
    const int u = static_cast<int>(std::lround(px[i].x)), v = static_cast<int>(std::lround(px[i].y));
    if (u < 0 || v < 0 || u >= surface.cols || v >= surface.rows) continue;
    const cv::Vec3f t = surface.at<cv::Vec3f>(v, u);
    if (!std::isfinite(t[2])) continue;
    const double s_true = (Eigen::Vector3d(t[0], t[1], t[2]) - truth.center_mm).norm();
    const double depth = R - s_true;
    if (depth < -5 || depth >= edges[std::size(edges) - 1]) continue;  // not this hedge's leaf
    std::size_t b = 0;
    while (b + 1 < out.bins.size() && depth >= out.bins[b].to_mm) ++b;
    sum[b] += (points_mm[i] - truth.center_mm).norm() - s_true;
    ++out.bins[b].points;
    ++out.points;
    outer_true += depth < 2 ? 1 : 0;
    outer_measured += R - (points_mm[i] - truth.center_mm).norm() < 2 ? 1 : 0;
  }
  for (std::size_t b = 0; b < out.bins.size(); ++b) {
    out.bins[b].mean_error_mm = out.bins[b].points > 0 ? sum[b] / double(out.bins[b].points) : 0.0;
  }
  if (out.points > 0) {
    out.true_outer_share = double(outer_true) / double(out.points);
    out.measured_outer_share = double(outer_measured) / double(out.points);
  }
  return out;
}

namespace {

// The presets' captures in a.dir, rendered unless --reuse finds them there, stamped by today's build.
void EnsureGardenRenders(const GardenOptions& a, const std::vector<std::string>& presets, bool pov) {
  namespace fs = std::filesystem;
  std::string set = "gardens";
  for (const std::string& p : presets) set += " " + p;
  const std::string stamp =
      RenderStamp(pov ? "povray" : "hedgefit", pipeline::Format("scale %g, camera %s, %s", a.scale,
                                                                pov ? a.camera.c_str() : "as rendered", set.c_str()));
  const bool have = fs::exists(fs::path(a.dir) / ("garden_" + presets.back() + "_right.png"));
  if (!(a.reuse && StampMatches(a.dir, set, stamp, have, "bench garden"))) {
    RemoveStamp(a.dir, set);
    if (pov) {
      sim::WritePovrayGarden(a.dir, a.scale,
                                a.camera == "real" ? sim::CameraModel() : sim::CameraModel::Ideal(), presets);
    } else {
      sim::RenderOptions ro;
      ro.supersample = 3;
      ro.blur_sigma_px = 0.5;
      ro.noise_sigma = 1.0;  // independent in each camera
      sim::WriteGarden(a.dir, a.scale, ro, presets);
    }
    WriteStamp(a.dir, set, stamp);
  }
}

// The outline's rays against the true envelope (px at each ray's tangent point), per view.
void ScoreOutline(const std::vector<cloud::TangentRay>& rays, const fitting::Sphere& truth, GardenHedgeRow* row) {
  std::vector<double> err[2];
  for (const auto& ray : rays) {
    const Eigen::Vector3d w = truth.center_mm - ray.origin_mm;
    const double along = w.dot(ray.direction), dist = (w - along * ray.direction).norm();
    err[ray.view ? 1 : 0].push_back((dist - truth.radius_mm) * ray.focal_px / along);
  }
  std::vector<double> all = err[0];
  all.insert(all.end(), err[1].begin(), err[1].end());
  std::sort(all.begin(), all.end());
  row->outline_quantiles_px.clear();
  for (double q : {0.02, 0.1, 0.25, 0.5, 0.75, 0.9}) {
    if (!all.empty()) row->outline_quantiles_px.push_back(all[std::size_t(q * double(all.size() - 1))]);
  }
  for (int v = 0; v < 2; ++v) {
    std::vector<double>& e = err[v];
    row->outline_rays[v] = e.size();
    if (e.empty()) continue;
    double sum = 0;
    for (double x : e) sum += x;
    row->outline_mean_px[v] = sum / double(e.size());
    std::nth_element(e.begin(), e.begin() + std::ptrdiff_t(e.size() / 2), e.end());
    const double med = row->outline_median_px[v] = e[e.size() / 2];
    for (double& x : e) x = std::abs(x - med);
    std::nth_element(e.begin(), e.begin() + std::ptrdiff_t(e.size() / 2), e.end());
    row->outline_mad_px[v] = 1.4826 * e[e.size() / 2];
  }
}

// The left view's grey levels across the true envelope's silhouette, in the rectified frame: each
// profile along the silhouette's normal (one per px of it; the bottom, against the lawn, left out)
// normalised between its own inside (-10 to -6 px) and outside (+6 to +10 px) levels, so that 1 is
// the hedge and 0 the background, and averaged. The measured outline's cut is a two-level fit, so
// it lands near this profile's 50 % point; a sharp edge crosses 50 % at the envelope within the
// camera's blur, a tapering one (sparse, pointed outer leaves) inside it by about half its width.
// Profiles whose two sides differ by under 15 grey levels (6 % of the range) are left out: their
// normalisation would divide by the noise.
constexpr double kProfileFirstPx = -6, kProfileLastPx = 3;

// The rectified left view as float grey levels, once per capture, for ScoreEdgeProfile.
cv::Mat GreyForProfiles(const cv::Mat& left_rect) {
  cv::Mat grey;
  if (left_rect.channels() == 3) cv::cvtColor(left_rect, grey, cv::COLOR_BGR2GRAY);
  else grey = left_rect;
  cv::Mat f;
  grey.convertTo(f, CV_32F);
  return f;
}

void ScoreEdgeProfile(const cv::Mat& grey, const stereo::StereoRig& rig, const fitting::Sphere& truth,
                      GardenHedgeRow* row) {
  if (grey.empty() || rig.P1.empty()) return;
  auto at = [&](double x, double y) {  // bilinear; NaN off the image
    if (!(x >= 0 && y >= 0 && x + 1 < grey.cols && y + 1 < grey.rows)) return std::nan("");
    cv::Mat one;
    cv::getRectSubPix(grey, cv::Size(1, 1), cv::Point2f(float(x), float(y)), one);
    return double(one.at<float>(0, 0));
  };
  const double f = rig.P1.at<double>(0, 0), cx = rig.P1.at<double>(0, 2), cy = rig.P1.at<double>(1, 2);
  const cv::Matx33d R1(rig.R1);
  const cv::Vec3d c = R1 * cv::Vec3d(truth.center_mm.x(), truth.center_mm.y(), truth.center_mm.z());
  const int n_out = int(kProfileLastPx - kProfileFirstPx) + 1;
  std::vector<double> sum(std::size_t(n_out), 0.0);
  std::size_t used = 0;
  for (const stereo::SilhouettePoint& point : stereo::SphereSilhouette(c, truth.radius_mm, cv::Vec3d(0, 0, 0), f, cx, cy)) {
    if (point.u[1] > 0.5) continue;  // the bottom: the lawn
    const cv::Point2d& p = point.p;
    const cv::Point2d& n = point.n;
    auto mean = [&](double from, double to) {
      double s = 0;
      int m = 0;
      for (double t = from; t <= to + 1e-9; t += 0.25, ++m) s += at(p.x + t * n.x, p.y + t * n.y);
      return s / m;
    };
    const double inside = mean(-10, -6), outside = mean(6, 10);
    if (!std::isfinite(inside) || !std::isfinite(outside) || std::abs(inside - outside) < 15) continue;
    std::vector<double> v(static_cast<std::size_t>(n_out));
    bool ok = true;
    for (int j = 0; j < n_out && ok; ++j) {
      const double t = kProfileFirstPx + j;
      v[std::size_t(j)] = (at(p.x + t * n.x, p.y + t * n.y) - outside) / (inside - outside);
      ok = std::isfinite(v[std::size_t(j)]);
    }
    if (!ok) continue;
    for (int j = 0; j < n_out; ++j) sum[std::size_t(j)] += v[std::size_t(j)];
    ++used;
  }
  row->edge_profile_rays = used;
  row->edge_profile.clear();
  if (used == 0) return;
  for (double x : sum) row->edge_profile.push_back(x / double(used));
}

// What else was taken for a hedge (a shrub): do the envelope fit and the default fit (ransac_ray,
// what measure prints) tell it is not a ball?
void ScoreOthers(const cloud::PointCloud& cleaned, const std::vector<cloud::HedgeGroup>& groups, GardenScene* scene) {
  for (const auto& g : groups) {
    if (std::any_of(scene->rows.begin(), scene->rows.end(), [&](const GardenHedgeRow& row) { return row.id == g.id; })) continue;
    const std::vector<Eigen::Vector3d> pts = cloud::PointsAt(cleaned, g.indices);
    const std::vector<double> pixel_mm = cloud::FieldAt(cleaned, cloud::kPixelSizeField, g.indices);
    const fitting::SphereFitResult f = fitting::RunFitMethod("envelope", pts, {}, 42, true, &pixel_mm);
    if (!f.converged) continue;
    scene->others_not_ball += f.not_a_ball ? 1 : 0;
    scene->others_not_ball_default += fitting::RunFitMethod("ransac_ray", pts, {}, 42, true).not_a_ball ? 1 : 0;
    scene->others_span_ratio.push_back(2 * f.sphere.radius_mm / std::max(1e-9, fitting::PrincipalSpan(pts)));
    scene->others_outside_share.push_back(fitting::OutsideShare(pts, f.sphere));
  }
}

// The paper's path on the same capture: the colour mask and the algebraic fit.
void ScoreColourPath(const cv::Mat& left, const cv::Mat& right, const stereo::StereoRig& rig,
                     const stereo::ConvertOptions& convert, const std::vector<fitting::Sphere>& spheres,
                     GardenScene* scene) {
  try {
    stereo::ConvertOptions colour = convert;
    colour.mode = stereo::SegmentMode::kColour;
    const stereo::ConvertResult c = stereo::ConvertCapture(left, right, rig, colour);
    scene->colour_mask_share = double(cv::countNonZero(c.mask)) / double(c.mask.total());
    std::vector<Eigen::Vector3d> pts;
    for (const auto& p : c.cloud.points_mm) {
      if (cloud::IsFinite(p)) pts.push_back(p.cast<double>());
    }
    const fitting::SphereFitResult k = fitting::RunFitMethod("kasa", pts, {});
    if (!k.converged) {
      scene->colour_message = k.message;
    } else {
      const fitting::Sphere* best = nullptr;
      for (const auto& s : spheres) {
        if (!best || (s.center_mm - k.sphere.center_mm).norm() < (best->center_mm - k.sphere.center_mm).norm()) best = &s;
      }
      const eval::FitError e = eval::Evaluate(k.sphere, *best);
      scene->colour_aer_mm = e.aer_mm;
      scene->colour_ld_mm = e.ld_mm;
    }
  } catch (const Error& e) {
    scene->colour_message = e.what();
  }
}

}  // namespace

std::vector<std::pair<std::string, fitting::SphereFitResult>> OracleFits(
    const std::vector<Eigen::Vector3d>& points_mm, const std::vector<double>& pixel_mm,
    const std::vector<cloud::TangentRay>& outline, const cv::Mat& surface, const sim::SimCamera& camera,
    const fitting::Sphere& truth, const std::map<std::string, pipeline::OptionValue>& envelope_options) {
  std::vector<std::pair<std::string, fitting::SphereFitResult>> out;
  if (surface.empty() || outline.empty() || points_mm.empty()) return out;
  // The points at the leaves their pixels truly see.
  std::vector<cv::Point3d> obj;
  for (const auto& p : points_mm) obj.emplace_back(p.x(), p.y(), p.z());
  std::vector<cv::Point2d> px;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(camera.K), cv::Mat(camera.dist), px);
  std::vector<Eigen::Vector3d> true_points;
  std::vector<double> true_pixel_mm;
  for (std::size_t i = 0; i < px.size(); ++i) {
    const int u = int(std::lround(px[i].x)), v = int(std::lround(px[i].y));
    if (u < 0 || v < 0 || u >= surface.cols || v >= surface.rows) continue;
    const cv::Vec3f t = surface.at<cv::Vec3f>(v, u);
    if (!std::isfinite(t[2])) continue;
    const Eigen::Vector3d q(t[0], t[1], t[2]);
    const double depth = truth.radius_mm - (q - truth.center_mm).norm();
    if (depth < -5 || depth > 60) continue;  // not this hedge's leaf
    true_points.push_back(q);
    if (!pixel_mm.empty()) true_pixel_mm.push_back(pixel_mm[i]);
  }
  // The outline's rays turned to graze the true envelope.
  std::vector<cloud::TangentRay> true_outline;
  for (cloud::TangentRay r : outline) {
    const Eigen::Vector3d to_c = truth.center_mm - r.origin_mm;
    const double dist = to_c.norm();
    if (dist <= truth.radius_mm) continue;
    const Eigen::Vector3d u = to_c / dist;
    Eigen::Vector3d w = r.direction - r.direction.dot(u) * u;
    if (w.norm() < 1e-9) continue;
    w.normalize();
    const double a = std::asin(truth.radius_mm / dist);
    r.direction = std::cos(a) * u + std::sin(a) * w;
    true_outline.push_back(r);
  }
  auto fit = [&](const std::vector<Eigen::Vector3d>& pts, const std::vector<double>& pix,
                 const std::vector<cloud::TangentRay>& rays) {
    return fitting::RunFitMethod("envelope", pts, envelope_options, 42, true, pix.empty() ? nullptr : &pix, &rays);
  };
  out.emplace_back("true_points", fit(true_points, true_pixel_mm, outline));
  out.emplace_back("true_outline", fit(points_mm, pixel_mm, true_outline));
  out.emplace_back("both", fit(true_points, true_pixel_mm, true_outline));
  for (int view = 0; view < 2; ++view) {  // one view's measured outline alone: its disparity's share
    std::vector<cloud::TangentRay> one;
    for (const auto& r : outline) {
      if (r.view == view) one.push_back(r);
    }
    out.emplace_back(view ? "right_outline" : "left_outline", fit(points_mm, pixel_mm, one));
  }
  return out;
}

GardenResult RunGarden(const GardenOptions& a) {
  namespace fs = std::filesystem;
  const auto t0 = std::chrono::steady_clock::now();
  cloud::CheckFilterStages(a.cleaning, "bench garden's cleaning");
  std::vector<std::string> presets = a.hard ? sim::GardenHardPresetNames() : sim::GardenPresetNames();
  if (a.leaves) presets = sim::GardenLeafPresetNames();
  if (a.random > 0 || a.paper > 0) {
    presets.clear();
    const std::string family = a.random > 0 ? "random" : "paper";
    for (int i = 0; i < std::max(a.random, a.paper); ++i) presets.push_back(family + std::to_string(a.first_seed + i));
  }
  if (!a.gardens.empty()) {
    presets.clear();
    std::stringstream list(a.gardens);
    for (std::string name; std::getline(list, name, ',');) {
      sim::GardenPreset(name);  // an unknown name fails here, before any rendering
      presets.push_back(name);
    }
  }
  if (a.renderer != "hedgefit" && a.renderer != "povray") throw Error("--renderer: use hedgefit or povray");
  if (a.camera != "ideal" && a.camera != "real") throw Error("--camera: use ideal or real");
  const bool pov = a.renderer == "povray";
  EnsureGardenRenders(a, presets, pov);
  // No boards in a garden: the renderer's exact rig, so the figures are segmentation, matching
  // and fitting (the lab bench measures calibration).
  const sim::SimRig sim = pov ? sim::PovrayRig(a.scale) : sim::PaperRig(a.scale);
  const stereo::StereoRig rig = sim::RigFromSimulation(sim);
  // Each fit's stated uncertainty as `measure` states it with this rig: the points' scatter and
  // the matcher's common offset (the exact rig has no calibration error to carry).
  const cloud::PointPerturbation matching = stereo::DisparityOffsetPerturbation(rig);
  GardenResult out;
  eval::SummaryBuilder summary;
  stereo::ConvertOptions garden = a.convert;
  garden.mode = stereo::SegmentMode::kGarden;
  std::map<std::string, pipeline::OptionValue> envelope_options;
  if (a.envelope_points_per_ray >= 0) envelope_options["points_per_ray"] = a.envelope_points_per_ray;
  const std::map<std::string, pipeline::OptionValue> defaults;
  for (const std::string& name : presets) {
    const fs::path base = fs::path(a.dir) / ("garden_" + name);
    const cv::Mat left = stereo::ReadImageFile(base.string() + "_left.png"),
                  right = stereo::ReadImageFile(base.string() + "_right.png");
    const std::vector<eval::SphereTruth> truths = eval::ReadSphereTruths(base.string() + ".truth.json");
    GardenScene scene;
    scene.name = name;
    // Every pixel's true leaf, to hold the matcher to (MeasureLeafLayer).
    const cv::Mat surface = pov ? sim::RenderPovrayGardenSurface(sim, sim::GardenPreset(name), a.dir)
                                : sim::RenderGardenSurface(sim, sim::GardenPreset(name));
    scene.hedges_true = truths.size();
    auto tc = std::chrono::steady_clock::now();
    const stereo::ConvertResult res = stereo::ConvertCapture(left, right, rig, garden);
    scene.convert_ms = Ms(tc);
    const cloud::PointCloud cleaned = cloud::RunFilterStages(res.cloud, a.cleaning, "bench garden's cleaning");
    const auto groups = cloud::HedgeGroups(cleaned);
    const auto raw_groups = cloud::HedgeGroups(res.cloud);  // the written clouds, for the 50 mm share
    // Each hedge's outline, as stereo.outline measures it in a pipeline.
    const cloud::HedgeOutlines outlines =
        a.outline ? measure::MeasureCloudOutlines(res.left_rect, res.right_rect, res.hedge_labels, rig, cleaned, 42, res.ground)
                  : cloud::HedgeOutlines();
    std::vector<fitting::Sphere> spheres;
    for (const auto& t : truths) spheres.push_back(fitting::Sphere{t.center_mm, t.radius_mm});
    const cv::Mat profile_grey = GreyForProfiles(res.left_rect);
    for (std::size_t ti = 0; ti < truths.size(); ++ti) {
      GardenHedgeRow row;
      row.truth = spheres[ti];
      row.truth_surface_mm = truths[ti].surface_radius_mm.value_or(0);
      // The hedge hedgefit found for this truth: the group whose points' centroid is nearest.
      for (const auto& g : groups) {
        const std::vector<Eigen::Vector3d> pts = cloud::PointsAt(cleaned, g.indices);
        const auto t = eval::TruthForPoints(spheres, pts);
        if (!t || (t->center_mm - row.truth.center_mm).norm() > 1e-9) continue;
        row.id = g.id;
        row.points = pts.size();
        row.span_mm = fitting::PrincipalSpan(pts);
        if (!surface.empty()) {
          const LeafLayerErrors layer = MeasureLeafLayer(pts, surface, sim.left, row.truth);
          if (!out.leaf_layer) out.leaf_layer = layer;
          else out.leaf_layer->Add(layer);
        }
        for (const auto& rg : raw_groups) {
          if (rg.id != g.id) continue;
          std::size_t outside = 0;
          for (std::size_t i : rg.indices) {
            const Eigen::Vector3d p = res.cloud.points_mm[i].cast<double>();
            outside += (p - row.truth.center_mm).norm() - row.truth.radius_mm > 50 ? 1 : 0;
          }
          row.outside_50mm = double(outside) / double(std::max<std::size_t>(1, rg.indices.size()));
        }
        const std::vector<double> pixel_mm = cloud::FieldAt(cleaned, cloud::kPixelSizeField, g.indices);
        const auto outline = outlines.find(g.id);
        ScoreEdgeProfile(profile_grey, rig, row.truth, &row);
        if (outline != outlines.end()) {
          ScoreOutline(outline->second, row.truth, &row);
          row.oracle = OracleFits(pts, pixel_mm, outline->second, surface, sim.left, row.truth, envelope_options);
        }
        for (const auto& m : fitting::SphereMethodNames()) {
          row.fits.push_back(fitting::RunFitMethod(m, pts, m == "envelope" ? envelope_options : defaults, 42, true,
                                                   &pixel_mm, outline != outlines.end() ? &outline->second : nullptr));
          row.fits.back().hedge_id = g.id;
          fitting::AddUncertainty(pts, nullptr, &row.fits.back(), &matching);
          row.outside_share.push_back(fitting::OutsideShare(pts, row.fits.back().sphere));
          if (m == "envelope") scene.envelope_ms += row.fits.back().wall_ms;
          summary.Add(m, row.fits.back(), row.truth);
        }
      }
      scene.rows.push_back(std::move(row));
    }
    for (const GardenHedgeRow& row : scene.rows) scene.hedges_found += row.id != 0 ? 1 : 0;
    scene.others_found = res.hedges.size() - std::min(res.hedges.size(), scene.hedges_found);
    ScoreOthers(cleaned, groups, &scene);
    ScoreColourPath(left, right, rig, a.convert, spheres, &scene);
    out.scenes.push_back(std::move(scene));
  }
  out.summary = summary.Finish();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

namespace {

// IntervalCoverage per method over every found hedge, in table order.
std::vector<std::pair<std::string, IntervalCoverage>> Coverage(const GardenResult& r) {
  std::vector<std::pair<std::string, IntervalCoverage>> out;
  for (const auto& m : fitting::SphereMethodNames()) {
    IntervalCoverage c;
    for (const GardenScene& s : r.scenes) {
      for (const GardenHedgeRow& h : s.rows) {
        for (const auto& f : h.fits) {
          if (f.method == m) c.Add(f, h.truth);
        }
      }
    }
    if (c.cases > 0) out.emplace_back(m, c);
  }
  return out;
}

}  // namespace

namespace {

// The envelope's centre error along the view ray (+: too far) and its AER, as measured and with
// the points, the outline or both swapped for the truth (GardenHedgeRow::oracle).
void PrintOracle(const GardenResult& r) {
  bool any = false;
  for (const GardenScene& s : r.scenes) {
    for (const GardenHedgeRow& h : s.rows) any = any || !h.oracle.empty();
  }
  if (!any) return;
  std::printf("the envelope with the truth swapped in: centre along the view ray (+ too far) / AER, mm\n"
              "  %-16s %4s %16s %16s %16s %16s %16s %16s\n", "garden", "id", "as measured", "true points", "true outline",
              "both", "left outline", "right outline");
  auto cell = [](const fitting::SphereFitResult& f, const fitting::Sphere& t) {
    if (!f.converged) return std::string("-");
    const Eigen::Vector3d ray = t.center_mm.normalized();
    return pipeline::Format("%+6.2f / %+5.2f", (f.sphere.center_mm - t.center_mm).dot(ray), f.sphere.radius_mm - t.radius_mm);
  };
  for (const GardenScene& s : r.scenes) {
    for (const GardenHedgeRow& h : s.rows) {
      if (h.oracle.empty()) continue;
      std::string measured = "-";
      for (const auto& f : h.fits) {
        if (f.method == "envelope") measured = cell(f, h.truth);
      }
      std::printf("  %-16s %4d %16s", s.name.c_str(), h.id, measured.c_str());
      for (const auto& [name, f] : h.oracle) std::printf(" %16s", cell(f, h.truth).c_str());
      std::printf("\n");
    }
  }
}

}  // namespace

void PrintGarden(const GardenResult& r) {
  const auto methods = fitting::SphereMethodNames();
  for (const GardenScene& s : r.scenes) {
    char others[160] = "";
    if (s.others_found > 0) {
      std::snprintf(others, sizeof(others),
                    " (and %zu not a hedge of the truth, told not a ball: %zu by envelope, %zu by ransac_ray)",
                    s.others_found, s.others_not_ball, s.others_not_ball_default);
    }
    std::printf("garden_%s: %zu of %zu hedges found%s; capture to clouds %.0f ms, envelope fits %.0f ms\n", s.name.c_str(),
                s.hedges_found, s.hedges_true, others, s.convert_ms, s.envelope_ms);
    std::printf("  %4s %8s %8s %9s %8s", "id", "true r", "points", ">50mm out", "");
    for (const auto& m : {"geometric", "ransac", "envelope"}) std::printf(" %17s", (std::string(m) + " AER/LD").c_str());
    std::printf("   envelope surface r (true)\n");
    for (const GardenHedgeRow& h : s.rows) {
      if (h.id == 0) {
        std::printf("  %4s %8.0f  not found\n", "-", h.truth.radius_mm);
        continue;
      }
      std::printf("  %4d %8.0f %8zu %8.2f%% %8s", h.id, h.truth.radius_mm, h.points, 100 * h.outside_50mm, "");
      const fitting::SphereFitResult* envelope = nullptr;
      for (const auto& m : {"geometric", "ransac", "envelope"}) {
        for (const auto& f : h.fits) {
          if (f.method != m) continue;
          if (f.method == "envelope") envelope = &f;
          if (!f.converged) {
            std::printf(" %17s", "failed");
          } else {
            const auto e = eval::Evaluate(f.sphere, h.truth);
            std::printf("     %6.2f / %5.2f", e.aer_mm, e.ld_mm);
          }
        }
      }
      if (envelope && envelope->converged && envelope->Extra("surface_radius_mm")) {
        std::printf("   %.1f (%.1f)", *envelope->Extra("surface_radius_mm"), h.truth_surface_mm);
      }
      for (const auto& f : h.fits) {
        if (f.converged && f.not_a_ball) std::printf("   %s: NOT A BALL", f.method.c_str());
      }
      if (h.outline_rays[0] > 0) {
        std::printf("   outline L %zu: %+.2f px (MAD %.2f), R %zu: %+.2f px (MAD %.2f)", h.outline_rays[0],
                    h.outline_median_px[0], h.outline_mad_px[0], h.outline_rays[1], h.outline_median_px[1],
                    h.outline_mad_px[1]);
        if (envelope && envelope->Extra("top_bias_px")) {
          std::printf("; beta %.2f px, noise %.2f px, ragged %.2f px", *envelope->Extra("top_bias_px"),
                      *envelope->Extra("outline_noise_px"), *envelope->Extra("outline_ragged_px"));
        }
      }
      std::printf("\n");
    }
    if (s.colour_message.empty()) {
      std::printf("  the paper's path (excess-green mask, %.0f%% of the frame; Kasa): AER %.0f mm, LD %.0f mm\n",
                  100 * s.colour_mask_share, s.colour_aer_mm, s.colour_ld_mm);
    } else {
      std::printf("  the paper's path (excess-green mask; Kasa): %s\n", s.colour_message.c_str());
    }
    std::printf("\n");
  }
  std::printf("summary over every hedge found (AER and LD against the outer envelope)\n  %-17s %11s %11s %10s %9s %9s\n",
              "method", "mean|AER|", "max|AER|", "mean RER%", "mean LD", "max LD");
  for (const auto& m : methods) {
    auto it = r.summary.find(m);
    if (it == r.summary.end()) continue;
    const auto& s = it->second;
    std::printf("  %-17s %11.2f %11.2f %10.3f %9.2f %9.2f\n", m.c_str(), s.mean_abs_aer_mm, s.max_abs_aer_mm,
                s.mean_rer_percent, s.mean_ld_mm, s.max_ld_mm);
  }
  std::printf("  %-17s %11.2f %11s %10s %9.2f %9s   (published, outdoor, 4 hedges r 880-960 mm)\n", "paper outdoor", 4.02,
              "-", "-", 18.29, "-");
  // Do the stated 95 % intervals hold the truth (found hedges x cx, cy, cz, r)?
  std::printf("95 %% intervals (points' scatter, matcher's common offset; the exact rig) against the truth\n"
              "  %-17s %9s %14s %14s %11s\n",
              "method", "inside", "stated se mm", "actual rms mm", "matching %");
  for (const auto& [m, c] : Coverage(r)) {
    std::printf("  %-17s %4d/%-4d %14.2f %14.2f %11.0f\n", m.c_str(), c.inside, c.cases, c.StatedRms(), c.ErrorRms(),
                c.MatchingPercent());
  }
  if (r.leaf_layer && r.leaf_layer->points > 0) {
    const LeafLayerErrors& l = *r.leaf_layer;
    std::printf("the matcher against the renderer's own leaves (%zu points of the found hedges, cleaned)\n"
                "  true depth below the envelope    share   radial error (measured - true)\n",
                l.points);
    for (const LeafDepthBin& b : l.bins) {
      std::printf("  %5.0f - %-5.0f mm             %6.1f%%   %+7.2f mm\n", b.from_mm, b.to_mm,
                  100.0 * double(b.points) / double(l.points), b.mean_error_mm);
    }
    std::printf("  within 2 mm of the envelope: %.1f%% of the true leaves, %.1f%% of the measured points\n",
                100 * l.true_outer_share, 100 * l.measured_outer_share);
  }
  PrintOracle(r);
  std::printf("whole run %.1f s\n", r.seconds);
}

std::string GardenJson(const GardenResult& r) {
  using nlohmann::json;
  json j;
  j["scenes"] = json::array();
  for (const GardenScene& s : r.scenes) {
    json js = {{"name", s.name},           {"hedges_true", s.hedges_true}, {"hedges_found", s.hedges_found},
               {"others_found", s.others_found}, {"others_not_ball", s.others_not_ball},
               {"others_not_ball_default", s.others_not_ball_default},
               {"others_sphere_to_span", s.others_span_ratio}, {"others_outside_share", s.others_outside_share},
               {"convert_ms", s.convert_ms}, {"envelope_ms", s.envelope_ms}};
    js["hedges"] = json::array();
    for (const GardenHedgeRow& h : s.rows) {
      json jh = {{"id", h.id},
                 {"true_center_mm", {h.truth.center_mm.x(), h.truth.center_mm.y(), h.truth.center_mm.z()}},
                 {"true_radius_mm", h.truth.radius_mm},
                 {"true_surface_radius_mm", h.truth_surface_mm},
                 {"points", h.points},
                 {"outside_50mm_share", h.outside_50mm}};
      if (h.outline_rays[0] + h.outline_rays[1] > 0) {
        jh["outline"] = json::array();
        jh["outline_quantiles_px"] = h.outline_quantiles_px;  // 2, 10, 25, 50, 75, 90 %, both views
        for (int v = 0; v < 2; ++v) {
          jh["outline"].push_back({{"view", v ? "right" : "left"}, {"rays", h.outline_rays[v]},
                                   {"median_px", h.outline_median_px[v]}, {"mad_px", h.outline_mad_px[v]},
                                   {"mean_px", h.outline_mean_px[v]}});
        }
      }
      if (!h.edge_profile.empty()) {
        // The mean grey-level profile across the true envelope (ScoreEdgeProfile): 1 the hedge,
        // 0 the background, at every whole px from kProfileFirstPx (+ outside).
        jh["edge_profile"] = {{"first_px", kProfileFirstPx}, {"rays", h.edge_profile_rays}, {"coverage", h.edge_profile}};
      }
      if (!h.oracle.empty()) {
        jh["oracle"] = json::object();
        for (const auto& [name, f] : h.oracle) {
          if (!f.converged) continue;
          const auto e = eval::Evaluate(f.sphere, h.truth);
          jh["oracle"][name] = {{"center_mm", {f.sphere.center_mm.x(), f.sphere.center_mm.y(), f.sphere.center_mm.z()}},
                                {"radius_mm", f.sphere.radius_mm}, {"aer_mm", e.aer_mm}, {"ld_mm", e.ld_mm},
                                {"top_bias_px", f.Extra("top_bias_px").value_or(0)}};
        }
      }
      jh["fits"] = json::array();
      for (std::size_t fi = 0; fi < h.fits.size(); ++fi) {
        const auto& f = h.fits[fi];
        json jf = {{"method", f.method}, {"converged", f.converged}};
        if (f.converged) {
          const auto e = eval::Evaluate(f.sphere, h.truth);
          jf["radius_mm"] = f.sphere.radius_mm;
          jf["aer_mm"] = e.aer_mm;
          jf["ld_mm"] = e.ld_mm;
          if (const auto surface = f.Extra("surface_radius_mm")) jf["surface_radius_mm"] = *surface;
          jf["sphere_to_span"] = 2 * f.sphere.radius_mm / std::max(1e-9, h.span_mm);
          jf["outside_share"] = h.outside_share[fi];
          jf["center_mm"] = {f.sphere.center_mm.x(), f.sphere.center_mm.y(), f.sphere.center_mm.z()};
          for (const auto& [key, value] : StatedUncertainty(f)) jf[key] = value;
          for (const char* extra : {"top_bias_px", "top_bias_mm", "outline_rays", "outline_noise_px", "outline_ragged_px",
                                    "leaf_depth_mm", "clipped_share"}) {
            if (const auto v = f.Extra(extra)) jf[extra] = *v;
          }
        }
        jh["fits"].push_back(jf);
      }
      js["hedges"].push_back(jh);
    }
    js["paper_path"] = s.colour_message.empty()
                           ? json{{"mask_share", s.colour_mask_share}, {"kasa_aer_mm", s.colour_aer_mm},
                                  {"kasa_ld_mm", s.colour_ld_mm}}
                           : json{{"message", s.colour_message}};
    j["scenes"].push_back(js);
  }
  j["summary"] = json::object();
  for (const auto& [m, s] : r.summary) {
    j["summary"][m] = {{"hedges", s.clouds},          {"failures", s.failures},   {"mean_abs_aer_mm", s.mean_abs_aer_mm},
                       {"max_abs_aer_mm", s.max_abs_aer_mm}, {"mean_ld_mm", s.mean_ld_mm}, {"max_ld_mm", s.max_ld_mm}};
  }
  j["paper_outdoor"] = {{"mean_abs_aer_mm", 4.02}, {"mean_ld_mm", 18.29}};
  j["intervals"] = json::object();
  for (const auto& [m, c] : Coverage(r)) {
    j["intervals"][m] = {{"inside", c.inside}, {"cases", c.cases}, {"stated_se_rms_mm", c.StatedRms()},
                         {"actual_rms_mm", c.ErrorRms()}, {"matching_percent", c.MatchingPercent()}};
  }
  if (r.leaf_layer) {
    json bins = json::array();
    for (const LeafDepthBin& b : r.leaf_layer->bins) {
      bins.push_back({{"from_mm", b.from_mm}, {"to_mm", b.to_mm}, {"points", b.points}, {"mean_error_mm", b.mean_error_mm}});
    }
    j["leaf_layer"] = {{"points", r.leaf_layer->points}, {"bins", bins},
                       {"true_outer_share", r.leaf_layer->true_outer_share},
                       {"measured_outer_share", r.leaf_layer->measured_outer_share}};
  }
  return j.dump(2) + "\n";
}

}  // namespace hedgefit::bench
