#include "fitting/methods.hpp"

#include <Eigen/Geometry>
#include <glog/logging.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "cloud/stable_sample.hpp"
#include "fitting/algebraic_fit.hpp"
#include "fitting/ellipsoid_fit.hpp"
#include "fitting/envelope_fit.hpp"
#include "fitting/geometric_fit.hpp"
#include "fitting/ransac_fit.hpp"
#include "fitting/ray_fit.hpp"
#include "fitting/shape_fit.hpp"

namespace hedgefit::fitting {

namespace {

using pipeline::Options;
using pipeline::OptionSpec;

// A shape fit (ellipsoid, spheroid) as a row of the table: the centre and the axes' geometric mean
// as its sphere, the axes beside it.
SphereFitResult ShapeResult(const std::string& method, const EllipsoidFit& e, std::size_t points) {
  SphereFitResult r;
  r.method = method;
  r.points_used = points;
  r.inliers = points;
  r.wall_ms = e.wall_ms;
  r.converged = e.converged;
  r.message = e.message;
  if (e.converged) {
    r.sphere.center_mm = e.center_mm;
    r.sphere.radius_mm = std::cbrt(e.axes_mm.prod());
    r.rms_mm = e.rms_mm;
    r.SetExtra("axes_mm", {e.axes_mm[0], e.axes_mm[1], e.axes_mm[2]});
    r.SetExtra("vertical_axis_mm", {e.vertical_axis_mm});
    r.SetExtra("horizontal_axis_mm", {e.horizontal_axis_mm});
  }
  return r;
}

FitMethod Algebraic(AlgebraicMethod m, std::string stage, std::string description) {
  return {MethodName(m), std::move(stage), std::move(description), {}, false, [m](const Options&) -> BoundFit {
            return [m](const FitInputs& in) {
              AlgebraicFitOptions o;
              o.method = m;
              return FitSphereAlgebraic(*in.points_mm, o);
            };
          }};
}

// RANSAC's options plus its seed (-1: the caller's, i.e. the pipeline's --seed).
std::vector<OptionSpec> RansacOptions() {
  return pipeline::TableOptions<RansacFitOptions>(
      {pipeline::IntOption("seed", -1, "sampler seed; -1 = the pipeline's --seed").Min(-1)});
}

RansacFitOptions BindRansac(const Options& o) {
  RansacFitOptions p = RansacFitOptions::Table().FromOptions(o);
  p.Check();
  return p;
}

// RANSAC with the seed option resolved (-1: the caller's seed).
SphereFitResult RunRansac(const RansacFitOptions& p, const Options& o, const FitInputs& in,
                          std::vector<std::size_t>* inliers) {
  RansacFitOptions run = p;
  const std::int64_t seed = o.GetInt("seed");
  run.seed = seed >= 0 ? static_cast<std::uint64_t>(seed) : in.seed;
  return FitSphereRansac(*in.points_mm, run, inliers);
}

// RANSAC's inliers, refit geometrically from RANSAC's sphere; then, with `refine`, refit again on
// the same inliers from the geometric sphere (when that converged). Times add up; the result is
// named `method` and counts every point as used.
SphereFitResult RansacThenRefine(
    const RansacFitOptions& p, const Options& o, const FitInputs& in, const std::string& method,
    const std::function<SphereFitResult(const std::vector<Eigen::Vector3d>&, const Sphere&)>& refine = {}) {
  std::vector<std::size_t> inliers;
  const SphereFitResult coarse = RunRansac(p, o, in, &inliers);
  SphereFitResult r = coarse;
  if (coarse.converged) {
    std::vector<Eigen::Vector3d> in_pts;
    in_pts.reserve(inliers.size());
    for (std::size_t i : inliers) in_pts.push_back((*in.points_mm)[i]);
    // Refined further, the geometric fit only seeds the refinement: its standard errors (a
    // Ceres covariance, ~10 ms on a lab capture) would be thrown away.
    GeometricFitOptions geometric;
    geometric.compute_covariance = !refine;
    r = FitSphereGeometric(in_pts, geometric, &coarse.sphere);
    if (refine && r.converged) {
      const double geometric_ms = r.wall_ms;
      r = refine(in_pts, r.sphere);
      r.wall_ms += geometric_ms;
    }
    r.wall_ms += coarse.wall_ms;
    r.points_used = in.points_mm->size();
  }
  if (in.inliers) *in.inliers = std::move(inliers);
  r.method = method;
  return r;
}

// fitters.geometric: Ceres, from an algebraic fit or the pipeline's previous one.
FitMethod GeometricRow() {
  std::vector<OptionSpec> options = pipeline::TableOptions<GeometricFitOptions>();
  // 'previous' starts from the last fit of the pipeline instead of an algebraic one.
  for (auto& spec : options) {
    if (spec.name == "initial") {
      spec.choices.push_back("previous");
      spec.help = "start from this algebraic fit, or 'previous' (the last fit before this one)";
    }
  }
  return {"geometric", "fitters.geometric",
               "Ceres orthogonal-distance sphere fit (residual |p - c| - r), robust loss optional, with standard errors",
               options, false, [](const Options& o) -> BoundFit {
                 const GeometricFitOptions p = GeometricFitOptions::Table().FromOptions(o);
                 p.Check();
                 const bool from_previous = o.GetString("initial") == "previous";
                 return [p, from_previous](const FitInputs& in) {
                   if (from_previous && in.previous == nullptr) {
                     throw Error("option 'initial': 'previous' needs a converged fit from an earlier stage");
                   }
                   return FitSphereGeometric(*in.points_mm, p, from_previous ? in.previous : nullptr);
                 };
               }};
}

// fitters.ransac_ray: RANSAC, the geometric fit, then the fit along the rays.
FitMethod RansacRayRow() {
  std::vector<OptionSpec> options = RansacOptions();
  options.push_back(pipeline::ListOption("origin", {0, 0, 0}, 3,
                                      "where the sensor's rays start, in the cloud's frame (a capture's cloud: "
                                      "the left camera, 0 0 0)",
                                      "mm"));
  return {"ransac_ray", "fitters.ransac_ray",
               "RANSAC's inliers, the geometric fit, then a fit along the sensor's rays (range less the range "
               "where the ray meets the sphere), which noise along the rays does not bias",
               options, true, [](const Options& o) -> BoundFit {
                 const RansacFitOptions p = BindRansac(o);
                 const std::vector<double>& origin = o.GetList("origin");
                 RayFitOptions ro;
                 ro.origin_mm = Eigen::Vector3d(origin[0], origin[1], origin[2]);
                 return [p, o, ro](const FitInputs& in) {
                   return RansacThenRefine(p, o, in, "ransac_ray",
                                           [&ro](const std::vector<Eigen::Vector3d>& pts, const Sphere& start) {
                                             return FitSphereAlongRays(pts, start, ro);
                                           });
                 };
               }};
}

// The envelope fit of `in` from the fit `initial` names (or the pipeline's previous one).
SphereFitResult FitEnvelopeFrom(const EnvelopeFitOptions& p, const std::string& initial, const FitInputs& in) {
  SphereFitResult start;
  if (initial == "previous") {
    if (in.previous == nullptr) {
      throw Error("option 'initial': 'previous' needs a converged fit from an earlier stage");
    }
    start.sphere = *in.previous;
    start.converged = true;
  } else {
    FitInputs sub = in;
    sub.inliers = nullptr;
    // The start sees about max_points of the points, chosen as the likelihood chooses them
    // (by where each lies, so a point more or fewer does not redraw them): it only has to land in
    // the likelihood's basin, and RANSAC and the geometric fit cost in proportion to the points.
    std::vector<Eigen::Vector3d> thinned;
    const std::size_t n = in.points_mm->size(), cap = std::size_t(p.max_points);
    if (cap > 0 && n > cap) {
      const std::vector<std::size_t> kept = cloud::StableSample(*in.points_mm, cap);
      if (kept.size() * 2 >= cap) {
        thinned.reserve(kept.size());
        for (const std::size_t i : kept) thinned.push_back((*in.points_mm)[i]);
        sub.points_mm = &thinned;
      }
    }
    start = FindFitMethod(initial, "initial").bind(pipeline::Options(
        [&] {
          std::map<std::string, pipeline::OptionValue> v;
          for (const auto& spec : FindFitMethod(initial, "initial").options) v[spec.name] = spec.default_value;
          return v;
        }()))(sub);
  }
  if (!start.converged) {
    SphereFitResult failed = start;
    failed.method = "envelope";
    failed.message = "no starting sphere: " + start.message;
    return failed;
  }
  const bool from_views = in.viewpoints && in.viewpoints->size() == in.points_mm->size();
  const EnvelopeFit e = FitEnvelope(*in.points_mm, p, &start.sphere, in.pixel_mm, in.outline, from_views ? in.viewpoints : nullptr);
  SphereFitResult r = e.fit;
  r.wall_ms += start.wall_ms;
  if (r.converged) {
    r.SetExtra("surface_radius_mm", {e.surface_radius_mm});
    r.SetExtra("leaf_depth_mm", {e.leaf_depth_mm});
    r.SetExtra("clipped_share", {e.clipped_share});
    if (e.top_bias_mm != 0) r.SetExtra("top_bias_mm", {e.top_bias_mm});
    if (e.outline_rays > 0) {
      if (e.std_error_mm) r.std_error_mm = *e.std_error_mm, r.std_error_own = true;
      r.SetExtra("top_bias_px", {e.top_bias_px});
      r.SetExtra("outline_rays", {double(e.outline_rays)});
      r.SetExtra("outline_noise_px", {e.outline_noise_px});
      r.SetExtra("outline_ragged_px", {e.outline_ragged_px});
    }
  }
  return r;
}

// fitters.envelope: the leafy shell, from a start fit on the points it will see.
FitMethod EnvelopeRow() {
  std::vector<OptionSpec> options = pipeline::TableOptions<EnvelopeFitOptions>(
      {pipeline::StringOption("initial", "ransac_geometric",
                           "start from this fit, or 'previous' (the last fit before this one)")
           .Choices({"geometric", "ransac_geometric", "previous"})});
  return {"envelope", "fitters.envelope",
               "Leafy shell: outer envelope radius (where the leaves end) and mean leaf-surface radius about one "
               "centre, by maximum likelihood of leaf depth seen along the view ray plus noise",
               options, false, [](const Options& o) -> BoundFit {
                 const EnvelopeFitOptions p = EnvelopeFitOptions::Table().FromOptions(o);
                 p.Check();
                 const std::string initial = o.GetString("initial");
                 return [p, initial](const FitInputs& in) { return FitEnvelopeFrom(p, initial, in); };
               }};
}

// fitters.ellipsoid: a shape diagnostic.
FitMethod EllipsoidRow() {
  return {"ellipsoid", "fitters.ellipsoid",
               "General ellipsoid (Li & Griffiths 2004 direct least squares): axes, the vertical against the "
               "horizontal ones, to tell a ball from a dome",
               {}, false, [](const Options&) -> BoundFit {
                 return [](const FitInputs& in) {
                   const EllipsoidFit e = FitEllipsoid(*in.points_mm);
                   return ShapeResult("ellipsoid", e, in.points_mm->size());
                 };
               }};
}

// fitters.spheroid: a shape diagnostic.
FitMethod SpheroidRow() {
  return {"spheroid", "fitters.spheroid",
               "Sphere flattened or stretched along the vertical (5 parameters, Ceres, Huber): horizontal and "
               "vertical semi-axes, to tell a ball from a dome on the cap a camera sees",
               pipeline::TableOptions<SpheroidFitOptions>(), false, [](const Options& o) -> BoundFit {
                 const SpheroidFitOptions so = SpheroidFitOptions::Table().FromOptions(o);
                 so.Check();
                 return [so](const FitInputs& in) {
                   const EllipsoidFit e = FitSpheroid(*in.points_mm, so);
                   return ShapeResult("spheroid", e, in.points_mm->size());
                 };
               }};
}

// fitters.shape: a clipped shape with a vertical axis (shape_fit.hpp), the cloud turned so `up`
// is +z; the ground is the cloud's lowest 1 % along it (a cloud of one topiary on its lawn, or
// cut at it).
FitMethod ShapeRow() {
  return {"shape", "fitters.shape",
          "Clipped topiary shape with a vertical axis: a ball, a dome, a spheroid, an ellipsoid with its heading, a cylinder or a cuboid, "
          "chosen by BIC (as find's topiary); axes_mm along the heading, across it and vertical: the envelope's, where "
          "the outer leaves end, unless envelope is false",
          {pipeline::StringOption("up", "z", "the vertical: z for most maps and scans, -y for a camera's cloud")
               .Choices({"x", "y", "z", "-x", "-y", "-z"}),
           pipeline::BoolOption("envelope", true,
                                "axes to the envelope (a trimmed refit and the leaf layer's offset, as find measures "
                                "topiary); false: the surface fitted through the points"),
           pipeline::DoubleOption("noise", 0, "the sensor's noise the leaf layer's model holds; 0: estimated from the "
                                  "points (find gives it the lawn's)", "mm")},
          false,
          [](const Options& o) -> BoundFit {
            const std::string name = o.GetString("up");
            const bool envelope = o.GetBool("envelope");
            const double noise = o.GetDouble("noise");
            Eigen::Vector3d up = Eigen::Vector3d::Zero();
            up[name.back() - 'x'] = name[0] == '-' ? -1 : 1;
            return [up, envelope, noise](const FitInputs& in) {
              const Eigen::Matrix3d turn = Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitZ()).toRotationMatrix();
              std::vector<Eigen::Vector3d> pts;
              std::vector<double> z;
              for (const auto& p : *in.points_mm) {
                if (!p.allFinite()) continue;
                pts.push_back(turn * p);
                z.push_back(pts.back().z());
              }
              SphereFitResult r;
              r.method = "shape";
              r.points_used = pts.size();
              if (pts.size() < 20) {
                r.message = "a shape needs 20 points or more";
                return r;
              }
              std::nth_element(z.begin(), z.begin() + z.size() / 100, z.end());
              const ClippedShape s = FitClippedShape(pts, z[z.size() / 100], noise, 0, 4000, true, envelope);
              r.converged = s.converged;
              if (!s.converged) {
                r.message = "no shape with a vertical axis fits";
                return r;
              }
              r.sphere.center_mm = turn.transpose() * s.center_mm;
              r.sphere.radius_mm = std::cbrt(s.axes_mm.prod());
              r.rms_mm = s.roughness_mm;
              r.message = (s.form.empty() ? "" : s.form + " ") + s.shape;
              r.SetExtra("axes_mm", {s.axes_mm.x(), s.axes_mm.y(), s.axes_mm.z()});
              r.SetExtra("axes_ci95_mm", {s.axes_ci95_mm.x(), s.axes_ci95_mm.y(), s.axes_ci95_mm.z()});
              r.SetExtra("center_ci95_mm", {s.center_ci95_mm.x(), s.center_ci95_mm.y(), s.center_ci95_mm.z()});
              r.SetExtra("heading_deg", {s.heading_deg});
              r.SetExtra("envelope_offset_mm", {s.envelope_offset_mm});
              r.SetExtra("up", {up.x(), up.y(), up.z()});
              return r;
            };
          }};
}

std::vector<FitMethod> MakeTable() {
  std::vector<FitMethod> t;
  t.push_back(Algebraic(AlgebraicMethod::kKasa, "fitters.algebraic",
                        "The paper's algebraic least-squares sphere (Kasa): fast, biased small on partial caps"));
  t.push_back(Algebraic(AlgebraicMethod::kPratt, "fitters.pratt", "Pratt's (1987) algebraic sphere fit"));
  t.push_back(Algebraic(AlgebraicMethod::kTaubin, "fitters.taubin", "Taubin's (1991) algebraic sphere fit"));
  t.push_back(Algebraic(AlgebraicMethod::kHyper, "fitters.hyper",
                        "Hyper algebraic sphere fit (Al-Sharadqah & Chernov 2009): no second-order bias"));
  t.push_back({"ransac", "fitters.ransac",
               "PCL sample consensus on SACMODEL_SPHERE, seeded, on centred data, radius limits re-checked",
               RansacOptions(), true, [](const Options& o) -> BoundFit {
                 const RansacFitOptions p = BindRansac(o);
                 return [p, o](const FitInputs& in) { return RunRansac(p, o, in, in.inliers); };
               }});
  t.push_back(GeometricRow());
  t.push_back({"ransac_geometric", "fitters.ransac_geometric",
               "RANSAC finds the inliers, then the geometric fit refines on them from RANSAC's sphere",
               RansacOptions(), true, [](const Options& o) -> BoundFit {
                 const RansacFitOptions p = BindRansac(o);
                 return [p, o](const FitInputs& in) { return RansacThenRefine(p, o, in, "ransac_geometric"); };
               }});
  t.push_back(RansacRayRow());
  t.push_back(EnvelopeRow());
  t.push_back(EllipsoidRow());
  t.push_back(SpheroidRow());
  t.push_back(ShapeRow());
  // Robust and geometric before algebraic; among algebraic, the least biased first. The fit along
  // the rays ranks below ransac_geometric: it is the better fit of a capture's cloud, but only when
  // the cloud's origin is the camera, and the one fit that stands for any cloud (render's distance
  // colours) must not depend on where the cloud came from.
  const std::map<std::string, int> trust = {{"ransac_geometric", 8}, {"ransac_ray", 7}, {"envelope", 6},
                                            {"geometric", 5},        {"ransac", 4},     {"hyper", 3},
                                            {"taubin", 2},           {"pratt", 1}};
  for (auto& m : t) {
    m.trust = trust.count(m.name) ? trust.at(m.name) : 0;
    m.sphere = m.name != "ellipsoid" && m.name != "spheroid" && m.name != "shape";  // shapes, run when named
  }
  return t;
}

// Every method's fit says when its sphere is far wider than the points (a shrub or a lawn, not a
// ball): whichever caller runs it (a stage, compare, the benches, Python).
std::vector<FitMethod> WithShapeCheck(std::vector<FitMethod> table) {
  for (FitMethod& m : table) {
    // A clipped shape is judged by its own residuals (its message and rms), not as the sphere of
    // its volume.
    if (m.name == "shape") continue;
    m.bind = [bind = m.bind](const Options& o) -> BoundFit {
      return [fit = bind(o)](const FitInputs& in) {
        SphereFitResult r = fit(in);
        r.not_a_ball = NotABallReason(*in.points_mm, r, in.one_hedge);
        return r;
      };
    };
  }
  return table;
}

}  // namespace

const FitMethod* MostTrusted(const std::vector<std::string>& names) {
  const FitMethod* best = nullptr;
  for (const auto& m : FitMethods()) {
    if (std::find(names.begin(), names.end(), m.name) != names.end() && (best == nullptr || m.trust > best->trust)) {
      best = &m;
    }
  }
  return best;
}

const std::vector<FitMethod>& FitMethods() {
  static const std::vector<FitMethod> table = WithShapeCheck(MakeTable());
  return table;
}

std::vector<std::string> FitMethodNames() {
  std::vector<std::string> out;
  for (const auto& m : FitMethods()) out.push_back(m.name);
  return out;
}

const FitMethod& FindFitMethod(const std::string& name, const std::string& where) {
  for (const auto& m : FitMethods()) {
    if (m.name == name) return m;
  }
  const std::vector<std::string> names = FitMethodNames();
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  const std::string hint = pipeline::DidYouMean(name, names);
  throw Error(where + ": unknown method '" + name + "'" + (hint.empty() ? "" : " (did you mean '" + hint + "'?)") +
              "; choose from " + list + ", or all");
}

std::vector<std::string> SphereMethodNames() {
  std::vector<std::string> out;
  for (const auto& m : FitMethods()) {
    if (m.sphere) out.push_back(m.name);
  }
  return out;
}

std::vector<std::string> ParseMethodList(const std::string& text, const std::string& where) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string m; std::getline(ss, m, ',');) {
    if (m == "all") {
      for (const auto& n : SphereMethodNames()) {
        if (std::find(out.begin(), out.end(), n) == out.end()) out.push_back(n);
      }
    } else if (std::find(out.begin(), out.end(), m) == out.end()) {
      out.push_back(FindFitMethod(m, where).name);
    }
  }
  if (out.empty()) throw Error(where + ": name at least one method, or all");
  return out;
}

SphereFitResult RunFitMethod(const std::string& name, const std::vector<Eigen::Vector3d>& points_mm,
                             const std::map<std::string, pipeline::OptionValue>& given, std::uint64_t seed,
                             bool one_hedge, const std::vector<double>* pixel_mm,
                             const std::vector<cloud::TangentRay>* outline) {
  const FitMethod& m = FindFitMethod(name, "fit");
  std::map<std::string, pipeline::OptionValue> mine;
  for (const auto& spec : m.options) {
    auto it = given.find(spec.name);
    if (it != given.end()) mine[spec.name] = it->second;
  }
  pipeline::StageInfo info{m.stage, m.description, m.options, {}, {}, {}};
  const BoundFit fit = m.bind(pipeline::ResolveOptions(info, mine, m.stage));
  FitInputs in;
  in.points_mm = &points_mm;
  in.seed = seed;
  in.one_hedge = one_hedge;
  in.pixel_mm = pixel_mm;
  in.outline = outline;
  return fit(in);
}

void QuietSolverWarnings() { FLAGS_minloglevel = google::GLOG_ERROR; }

}  // namespace hedgefit::fitting
