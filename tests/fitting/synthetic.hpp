#pragma once
// Synthetic spheres with exact truth for the fitting tests.

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

namespace hedgefit::testing {

constexpr double kPi = 3.14159265358979323846;

/// n points on the cap of half-angle `half_angle_deg` around `axis` (unit), uniform by
/// area, each moved along its normal by N(0, sigma_mm).
inline std::vector<Eigen::Vector3d> Cap(const Eigen::Vector3d& center, double radius, double half_angle_deg,
                                        const Eigen::Vector3d& axis, std::size_t n, double sigma_mm,
                                        std::mt19937_64& rng) {
  const Eigen::Quaterniond to_axis = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis.normalized());
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, sigma_mm > 0 ? sigma_mm : 1.0);
  const double cos_max = std::cos(half_angle_deg * kPi / 180.0);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double c = cos_max + (1.0 - cos_max) * u(rng);
    const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
    const double phi = 2 * kPi * u(rng);
    const Eigen::Vector3d normal = to_axis * Eigen::Vector3d(s * std::cos(phi), s * std::sin(phi), c);
    const double e = sigma_mm > 0 ? noise(rng) : 0.0;
    pts.push_back(center + (radius + e) * normal);
  }
  return pts;
}

/// Appends outliers uniform in the points' bounding box grown by `margin_mm`, so that
/// they make up `fraction` of the result.
inline void AddOutliers(std::vector<Eigen::Vector3d>* pts, double fraction, double margin_mm, std::mt19937_64& rng) {
  Eigen::Vector3d lo = pts->front(), hi = pts->front();
  for (const auto& p : *pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  lo.array() -= margin_mm;
  hi.array() += margin_mm;
  const auto count = static_cast<std::size_t>(std::lround(fraction / (1 - fraction) * double(pts->size())));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::size_t i = 0; i < count; ++i) {
    pts->push_back(lo + (hi - lo).cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng))));
  }
}

/// A leafy ball seen by a camera at the origin: points on the envelope (radius `radius`) where
/// it faces the camera (normal within `half_angle_deg` of the direction to the camera, in front of
/// the limb, as densely as a camera's pixels see it: fewer than n points), then
/// deeper along the line of sight by an exponential leaf depth of mean `leaf_depth_mm` (the
/// gaps one sees into; a share `clipped_share` of the leaves lies on the envelope, cut flush by the
/// shears), then noise of `sigma_mm` along the ray, as stereo gives it.
inline std::vector<Eigen::Vector3d> LeafyCap(const Eigen::Vector3d& center, double radius, double leaf_depth_mm,
                                             double half_angle_deg, std::size_t n, double sigma_mm,
                                             std::mt19937_64& rng, double clipped_share = 0.0) {
  const Eigen::Vector3d to_camera = (-center).normalized();
  std::vector<Eigen::Vector3d> normals = Cap(Eigen::Vector3d::Zero(), 1.0, half_angle_deg, to_camera, n, 0.0, rng);
  std::exponential_distribution<double> depth(1.0 / leaf_depth_mm);
  std::normal_distribution<double> noise(0.0, sigma_mm);
  std::uniform_real_distribution<double> clip(0.0, 1.0), keep(0.0, 1.0);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(n);
  for (const Eigen::Vector3d& nrm : normals) {
    const Eigen::Vector3d hit = center + radius * nrm;
    const Eigen::Vector3d ray = hit.normalized();
    // Beyond the limb the envelope faces away: the camera does not see it (a wide cap of a near
    // ball, e.g. r 920 mm at 2 m, whose limb is 63 degrees from the view axis).
    if (ray.dot(nrm) >= 0) continue;
    // A camera samples the surface per pixel, so a patch seen at incidence i gets cos(i) as many
    // points as one seen face-on: kept with that probability (uniform by area, a 70 degree cap of
    // a near ball put a tenth of its points beyond 84 degrees, where the envelope fit clamps
    // cos(i) at 0.1 and reads their depth too shallow).
    if (keep(rng) > -ray.dot(nrm)) continue;
    // A clipped hedge: the shears leave a share of the leaves cut flush with the envelope.
    const double u = clipped_share > 0 && clip(rng) < clipped_share ? 0.0 : depth(rng);
    // A grazing ray that meets no leaf before it leaves the ball again (the chord) sees past it:
    // no point of this ball.
    if (u > 2.0 * -ray.dot(nrm) * radius) continue;
    pts.push_back(hit + (u + noise(rng)) * ray);
  }
  return pts;
}

}  // namespace hedgefit::testing
