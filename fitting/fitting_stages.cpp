// Thin adapters from declared options to the fitting free functions.

#include "fitting/fitting_stages.hpp"

#include <cmath>

#include "cloud/point_cloud.hpp"
#include "fitting/algebraic_fit.hpp"
#include "fitting/geometric_fit.hpp"
#include "fitting/ransac_fit.hpp"

namespace hedgefit::fitting {

namespace {

using cloud::Context;
using cloud::Options;

// Finite points of the current cloud, in double.
std::vector<Eigen::Vector3d> CloudPoints(Context& ctx) {
  const cloud::PointCloud& c = ctx.Get<cloud::PointCloud>("cloud");
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(c.size());
  for (const auto& p : c.points_mm) {
    if (cloud::IsFinite(p)) pts.push_back(p.cast<double>());
  }
  return pts;
}

void Record(Context& ctx, const SphereFitResult& r) {
  ctx.Note("converged", r.converged);
  if (r.converged) {
    ctx.Note("center_mm", std::vector<double>{r.sphere.center_mm.x(), r.sphere.center_mm.y(), r.sphere.center_mm.z()});
    ctx.Note("radius_mm", r.sphere.radius_mm);
    ctx.Note("rms_mm", r.rms_mm);
    ctx.Note("inliers", static_cast<std::int64_t>(r.inliers));
  }
  if (r.std_error_mm) {
    const auto& e = *r.std_error_mm;
    ctx.Note("std_error_mm", std::vector<double>{e[0], e[1], e[2], e[3]});
  }
  if (!r.message.empty()) ctx.Note("message", r.message);
  if (auto* fits = ctx.Find<std::vector<SphereFitResult>>("fits")) {
    fits->push_back(r);
  } else {
    ctx.Put("fits", std::vector<SphereFitResult>{r});
  }
}

void AddAlgebraic(cloud::Registry& r, const std::string& name, AlgebraicMethod method, const std::string& what) {
  r.Add(cloud::StageInfo{name, what, {}, {"cloud"}, {"fits"}, {}},
        cloud::MakeFactory([method](const Options&, Context& ctx) {
          AlgebraicFitOptions o;
          o.method = method;
          Record(ctx, FitSphereAlgebraic(CloudPoints(ctx), o));
        }));
}

}  // namespace

void RegisterFittingStages(cloud::Registry& r) {
  using namespace hedgefit::cloud;
  AddAlgebraic(r, "fitters.algebraic", AlgebraicMethod::kKasa,
               "The paper's algebraic least-squares sphere (Kasa): fast, biased small on partial caps");
  AddAlgebraic(r, "fitters.pratt", AlgebraicMethod::kPratt, "Pratt's (1987) algebraic sphere fit");
  AddAlgebraic(r, "fitters.taubin", AlgebraicMethod::kTaubin, "Taubin's (1991) algebraic sphere fit");
  AddAlgebraic(r, "fitters.hyper", AlgebraicMethod::kHyper,
               "Hyper algebraic sphere fit (Al-Sharadqah & Chernov 2009): no second-order bias");
  {
    const std::string name = "fitters.ransac";
    StageInfo info{name,
                   "PCL sample consensus on SACMODEL_SPHERE, seeded, on centred data, radius limits re-checked",
                   {StringOption("method", "ransac", "estimator").Choices({"ransac", "msac", "lmeds", "prosac", "mlesac"}),
                    DoubleOption("distance_threshold", 10.0, "inlier band around the sphere", "mm").Min(1e-9),
                    IntOption("max_iterations", 10000, "samples drawn at most", "samples").Range(1, 100000000),
                    DoubleOption("probability", 0.99, "chance of one outlier-free sample").Range(1e-6, 0.999999),
                    DoubleOption("min_radius", 0.0, "smallest sphere accepted", "mm").Min(0),
                    DoubleOption("max_radius", 1e9, "largest sphere accepted", "mm").Min(0),
                    BoolOption("optimize", true, "refine on the inliers"),
                    DoubleOption("sample_radius", 0.0, "draw each sample within this distance (0 = anywhere)", "mm").Min(0),
                    IntOption("seed", -1, "sampler seed; -1 = the pipeline's --seed").Min(-1),
                    BoolOption("keep_inliers", false, "replace 'cloud' by the inliers, for later stages")},
                   {"cloud"},
                   {"fits"},
                   {}};
    r.Add(info, [name](const Options& o) -> std::unique_ptr<Stage> {
      RansacFitOptions p;
      p.method = ParseConsensus(o.GetString("method"));
      p.distance_threshold_mm = o.GetDouble("distance_threshold");
      p.max_iterations = static_cast<int>(o.GetInt("max_iterations"));
      p.probability = o.GetDouble("probability");
      p.min_radius_mm = o.GetDouble("min_radius");
      p.max_radius_mm = o.GetDouble("max_radius");
      p.optimize = o.GetBool("optimize");
      p.sample_radius_mm = o.GetDouble("sample_radius");
      p = CheckedParams(p, name);
      const std::int64_t seed = o.GetInt("seed");
      const bool keep = o.GetBool("keep_inliers");
      return std::make_unique<LambdaStage>(o, [p, seed, keep](const Options&, Context& ctx) {
        RansacFitOptions run = p;
        run.seed = seed >= 0 ? static_cast<std::uint64_t>(seed) : ctx.seed;
        ctx.Note("seed", static_cast<std::int64_t>(run.seed));
        PointCloud& c = ctx.Get<PointCloud>("cloud");
        std::vector<std::size_t> finite_index;
        std::vector<Eigen::Vector3d> pts;
        for (std::size_t i = 0; i < c.size(); ++i) {
          if (IsFinite(c.points_mm[i])) {
            pts.push_back(c.points_mm[i].cast<double>());
            finite_index.push_back(i);
          }
        }
        std::vector<std::size_t> inliers;
        const SphereFitResult res = FitSphereRansac(pts, run, &inliers);
        Record(ctx, res);
        if (keep && res.converged) {
          for (auto& i : inliers) i = finite_index[i];
          c = Select(c, inliers);
        }
      });
    });
  }
  {
    const std::string name = "fitters.geometric";
    StageInfo info{name,
                   "Ceres orthogonal-distance sphere fit (residual |p - c| - r), robust loss optional, with standard errors",
                   {StringOption("initial", "hyper", "start from this fit, or 'previous' (the last fit in the pipeline)")
                        .Choices({"kasa", "pratt", "taubin", "hyper", "previous"}),
                    StringOption("loss", "none", "robust loss").Choices({"none", "huber", "cauchy", "tukey"}),
                    DoubleOption("loss_scale", 5.0, "residual where the loss starts to down-weight", "mm").Min(1e-9),
                    StringOption("derivatives", "analytic", "Jacobians").Choices({"analytic", "automatic"}),
                    IntOption("max_iterations", 100, "Levenberg-Marquardt iterations at most", "iterations").Range(1, 10000),
                    BoolOption("covariance", true, "compute standard errors of centre and radius")},
                   {"cloud"},
                   {"fits"},
                   {}};
    r.Add(info, [name](const Options& o) -> std::unique_ptr<Stage> {
      GeometricFitOptions p;
      const std::string initial = o.GetString("initial");
      const bool from_previous = initial == "previous";
      if (!from_previous) {
        p.initial = initial == "kasa"     ? AlgebraicMethod::kKasa
                    : initial == "pratt"  ? AlgebraicMethod::kPratt
                    : initial == "taubin" ? AlgebraicMethod::kTaubin
                                          : AlgebraicMethod::kHyper;
      }
      p.loss = ParseLoss(o.GetString("loss"));
      p.loss_scale_mm = o.GetDouble("loss_scale");
      p.analytic_derivatives = o.GetString("derivatives") == "analytic";
      p.max_iterations = static_cast<int>(o.GetInt("max_iterations"));
      p.compute_covariance = o.GetBool("covariance");
      p = CheckedParams(p, name);
      return std::make_unique<LambdaStage>(o, [p, from_previous, name](const Options&, Context& ctx) {
        const Sphere* start = nullptr;
        Sphere previous;
        if (from_previous) {
          const auto* fits = ctx.Find<std::vector<SphereFitResult>>("fits");
          if (fits == nullptr || fits->empty() || !fits->back().converged) {
            throw Error("stage '" + name + "', option 'initial': 'previous' needs a converged fit from an earlier stage");
          }
          previous = fits->back().sphere;
          start = &previous;
        }
        Record(ctx, FitSphereGeometric(CloudPoints(ctx), p, start));
      });
    });
  }
}

}  // namespace hedgefit::fitting
