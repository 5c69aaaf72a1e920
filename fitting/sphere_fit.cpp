#include "fitting/sphere_fit.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

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

}  // namespace hedgefit::fitting
