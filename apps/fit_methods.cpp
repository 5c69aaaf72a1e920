#include "apps/fit_methods.hpp"

#include "fitting/algebraic_fit.hpp"
#include "fitting/geometric_fit.hpp"
#include "fitting/ransac_fit.hpp"

namespace hedgefit::apps {

fitting::SphereFitResult RunFitMethod(const std::string& method, const std::vector<Eigen::Vector3d>& pts,
                                      const FitMethodOptions& a) {
  using namespace fitting;
  auto algebraic = [&](AlgebraicMethod m) {
    AlgebraicFitOptions o;
    o.method = m;
    return FitSphereAlgebraic(pts, o);
  };
  RansacFitOptions ro;
  ro.distance_threshold_mm = a.ransac_threshold_mm;
  ro.min_radius_mm = a.min_radius_mm;
  ro.max_radius_mm = a.max_radius_mm;
  ro.seed = a.seed;
  ro.sample_radius_mm = a.sample_radius_mm;
  if (method == "kasa") return algebraic(AlgebraicMethod::kKasa);
  if (method == "pratt") return algebraic(AlgebraicMethod::kPratt);
  if (method == "taubin") return algebraic(AlgebraicMethod::kTaubin);
  if (method == "hyper") return algebraic(AlgebraicMethod::kHyper);
  if (method == "ransac") return FitSphereRansac(pts, ro);
  if (method == "geometric") return FitSphereGeometric(pts, {});
  // RANSAC to find the inliers, then the geometric fit on them from RANSAC's sphere.
  std::vector<std::size_t> inliers;
  const fitting::SphereFitResult coarse = FitSphereRansac(pts, ro, &inliers);
  fitting::SphereFitResult r;
  if (!coarse.converged) {
    r = coarse;
  } else {
    std::vector<Eigen::Vector3d> in;
    in.reserve(inliers.size());
    for (std::size_t i : inliers) in.push_back(pts[i]);
    r = FitSphereGeometric(in, {}, &coarse.sphere);
    r.wall_ms += coarse.wall_ms;
    r.points_used = pts.size();
  }
  r.method = "ransac_geometric";
  return r;
}

}  // namespace hedgefit::apps
