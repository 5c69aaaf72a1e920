#include "fitting/sphere_fit.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>

namespace hedgefit::fitting {

std::optional<std::string> DegeneracyFromMoments(std::size_t n, bool finite, const Eigen::Vector3d& mean,
                                                 const Eigen::Matrix3d& covariance) {
  if (n < 4) return "need at least 4 points to fit a sphere, got " + std::to_string(n);
  if (!finite) return std::string("points contain NaN or Inf; remove them first (filters.nonfinite)");
  const double scale = covariance.trace();
  // Relative to the spread and to where the cloud is: rounding of coordinates of size
  // |mean| leaves about 1e-16 |mean| of apparent spread.
  if (!(scale > 1e-24 * (mean.squaredNorm() + 1.0))) {
    return std::string("all points coincide; a sphere is not determined");
  }
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance / scale).eigenvalues();
  constexpr double kFlat = 1e-12;  // eigenvalue share of the total spread
  if (ev[1] < kFlat) return std::string("points are collinear; a sphere is not determined");
  if (ev[0] < kFlat) return std::string("points are coplanar; a sphere is not determined");
  return std::nullopt;
}

std::optional<std::string> DegeneracyReason(const std::vector<Eigen::Vector3d>& points_mm) {
  const std::size_t n = points_mm.size();
  if (n < 4) return DegeneracyFromMoments(n, true, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero());
  bool finite = true;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_mm) {
    finite = finite && p.allFinite();
    mean += p;
  }
  if (!finite) return DegeneracyFromMoments(n, false, mean, Eigen::Matrix3d::Zero());
  mean /= double(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points_mm) cov += (p - mean) * (p - mean).transpose();
  return DegeneracyFromMoments(n, true, mean, cov / double(n));
}

double PrincipalSpan(const std::vector<Eigen::Vector3d>& points_mm, const Eigen::Vector3d& viewpoint_mm) {
  if (points_mm.size() < 2) return 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_mm) mean += p;
  mean /= double(points_mm.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points_mm) cov += (p - mean) * (p - mean).transpose();
  cov /= double(points_mm.size());
  // Across the line of sight when the viewpoint is well outside the points: a camera's depth
  // noise, along the rays, must not count as extent (at 24 m a stereo point scatters by 0.2 m).
  const Eigen::Vector3d sight = mean - viewpoint_mm;
  if (sight.squaredNorm() > cov.trace()) {
    const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - sight.normalized() * sight.normalized().transpose();
    cov = across * cov * across;
  }
  const Eigen::Vector3d axis = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(2);
  std::vector<double> t(points_mm.size());
  for (std::size_t i = 0; i < points_mm.size(); ++i) t[i] = axis.dot(points_mm[i] - mean);
  // Percentiles, so a few stray points (lawn at the ball's foot) do not widen it.
  const auto lo = t.begin() + std::ptrdiff_t(0.02 * double(t.size() - 1));
  const auto hi = t.begin() + std::ptrdiff_t(0.98 * double(t.size() - 1));
  std::nth_element(t.begin(), lo, t.end());
  const double low = *lo;
  std::nth_element(t.begin(), hi, t.end());
  return *hi - low;
}

double OutsideShare(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& sphere) {
  const double beyond = kOutsideRadiusShare * sphere.radius_mm;
  std::size_t outside = 0;
  for (const auto& p : points_mm) outside += (p - sphere.center_mm).norm() - sphere.radius_mm > beyond ? 1 : 0;
  return double(outside) / double(std::max<std::size_t>(1, points_mm.size()));
}

std::optional<std::string> NotABallReason(const std::vector<Eigen::Vector3d>& points_mm, const SphereFitResult& fit,
                                          bool one_hedge) {
  if (!fit.converged) return std::nullopt;
  const double span = std::max(PrincipalSpan(points_mm), 1e-9), diameter = 2 * fit.sphere.radius_mm;
  char why[240];
  if (diameter > kMaxSphereToSpan * span) {
    std::snprintf(why, sizeof(why),
                  "the sphere (r %.0f mm) is %.1f times as wide as the points (%.0f mm across): they are a shallow "
                  "patch of it, not a ball",
                  fit.sphere.radius_mm, diameter / span, span);
    return std::string(why);
  }
  if (one_hedge || fit.inliers >= fit.points_used) {
    const double beyond = kOutsideRadiusShare * fit.sphere.radius_mm;
    const double share = OutsideShare(points_mm, fit.sphere);
    if (share > kMaxOutsideShare) {
      std::snprintf(why, sizeof(why),
                    "%.0f%% of the points lie more than %.0f mm outside the sphere (r %.0f mm): not one ball (a "
                    "shrub's lobes, a ball with something else, or noise of a tenth of its radius)",
                    100 * share, beyond, fit.sphere.radius_mm);
      return std::string(why);
    }
  }
  return std::nullopt;
}

double RmsResidual(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& sphere) {
  if (points_mm.empty()) return 0.0;
  double ss = 0.0;
  for (const auto& p : points_mm) {
    const double e = (p - sphere.center_mm).norm() - sphere.radius_mm;
    ss += e * e;
  }
  return std::sqrt(ss / double(points_mm.size()));
}

std::vector<Eigen::Vector3d> ToDouble(const std::vector<Eigen::Vector3f>& points_mm) {
  std::vector<Eigen::Vector3d> out(points_mm.size());
  for (std::size_t i = 0; i < points_mm.size(); ++i) out[i] = points_mm[i].cast<double>();
  return out;
}

std::optional<double> SphereFitResult::Extra(const std::string& name) const {
  for (const auto& [key, values] : extras) {
    if (key == name && !values.empty()) return values.front();
  }
  return std::nullopt;
}

void SphereFitResult::SetExtra(const std::string& name, std::vector<double> values) {
  for (auto& [key, v] : extras) {
    if (key == name) {
      v = std::move(values);
      return;
    }
  }
  extras.emplace_back(name, std::move(values));
}

}  // namespace hedgefit::fitting
