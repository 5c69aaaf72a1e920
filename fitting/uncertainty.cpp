#include "fitting/uncertainty.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Geometry>

#include "pipeline/parallel.hpp"
#include "pipeline/print.hpp"
#include "fitting/geometric_fit.hpp"

namespace hedgefit::fitting {

namespace {

double Median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Up to `max_points` of `points`, evenly taken.
std::vector<Eigen::Vector3d> EvenSubset(const std::vector<Eigen::Vector3d>& points, std::size_t max_points) {
  std::vector<Eigen::Vector3d> subset;
  const std::size_t step = std::max<std::size_t>(1, points.size() / std::max<std::size_t>(1, max_points));
  for (std::size_t i = 0; i < points.size(); i += step) subset.push_back(points[i]);
  return subset;
}

// Sum of squared deviations of (cx, cy, cz, r) estimates from their mean.
Eigen::Vector4d SquaredDeviations(const std::vector<Eigen::Vector4d>& estimates) {
  Eigen::Vector4d mean = Eigen::Vector4d::Zero();
  for (const auto& e : estimates) mean += e;
  mean /= double(estimates.size());
  Eigen::Vector4d ss = Eigen::Vector4d::Zero();
  for (const auto& e : estimates) ss += (e - mean).cwiseAbs2();
  return ss;
}

// Geometric least squares from `start`: the refit the jackknife and the perturbations repeat
// (Gauss-Newton from so close a start; Ceres' solver, set up afresh for each, cost 5x as much,
// bench_fitters). Where Gauss-Newton does not settle (a cap too small to pin the sphere), Ceres'
// damped search as before.
std::optional<Eigen::Vector4d> Refit(const std::vector<Eigen::Vector3d>& points, const Sphere& start) {
  std::optional<Sphere> f = RefitSphereGeometric(points, start);
  if (!f) {
    GeometricFitOptions go;
    go.compute_covariance = false;
    go.num_threads = 1;
    const SphereFitResult damped = FitSphereGeometric(points, go, &start);
    if (damped.sphere.center_mm.allFinite()) f = damped.sphere;
  }
  if (!f) return std::nullopt;
  return Eigen::Vector4d(f->center_mm.x(), f->center_mm.y(), f->center_mm.z(), f->radius_mm);
}

// The delete-a-group jackknife's standard errors of (cx, cy, cz, r): `points` refitted from
// `sphere` without each of `groups` groups in turn (`group` gives each point's), an empty group
// skipped (a cap seen from one side leaves patches empty); nullopt with fewer than 4 refits. The
// refits run in parallel and are gathered in group order: the same result on any core count.
std::optional<Eigen::Vector4d> GroupJackknife(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& group,
                                              int groups, const Sphere& sphere) {
  std::vector<std::optional<Eigen::Vector4d>> by_group(static_cast<std::size_t>(groups));
  pipeline::ParallelFor(by_group.size(), 0, 1, [&](std::size_t b, std::size_t e) {
    std::vector<Eigen::Vector3d> rest;
    for (std::size_t g = b; g < e; ++g) {
      rest.clear();
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (group[i] != int(g)) rest.push_back(points[i]);
      }
      if (rest.size() == points.size()) continue;
      by_group[g] = Refit(rest, sphere);
    }
  });
  std::vector<Eigen::Vector4d> estimates;
  for (const auto& e : by_group) {
    if (e) estimates.push_back(*e);
  }
  if (estimates.size() < 4) return std::nullopt;
  const double n = double(estimates.size());
  return Eigen::Vector4d((SquaredDeviations(estimates) * (n - 1) / n).cwiseSqrt());
}

}  // namespace

std::vector<Eigen::Vector3d> SupportingPoints(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& sphere) {
  // Only points near the surface can support it: a robust fit (RANSAC) of a ball on a lawn may
  // rest on a tenth of the cloud, and a median over the whole cloud would then be the lawn's.
  // The window, 50 mm or a tenth of the radius, holds any leaf layer and stereo noise.
  const double window = std::max(50.0, 0.1 * sphere.radius_mm);
  std::vector<double> res;
  res.reserve(points_mm.size());
  for (const auto& p : points_mm) {
    if (!p.allFinite()) continue;
    const double e = (p - sphere.center_mm).norm() - sphere.radius_mm;
    if (std::abs(e) <= window) res.push_back(e);
  }
  if (res.size() < 5) return {};
  const double med = Median(res);
  std::vector<double> dev(res.size());
  for (std::size_t i = 0; i < res.size(); ++i) dev[i] = std::abs(res[i] - med);
  const double band = 3.0 * 1.4826 * Median(dev);
  std::vector<Eigen::Vector3d> out;
  for (const auto& p : points_mm) {
    if (!p.allFinite()) continue;
    const double e = (p - sphere.center_mm).norm() - sphere.radius_mm;
    if (std::abs(e) <= window && std::abs(e - med) <= band) out.push_back(p);
  }
  return out;
}

std::optional<Eigen::Vector4d> ScatterStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                               double correlation_area) {
  if (support.size() <= 4) return std::nullopt;
  // Residual e = |p - c| - r; de/dc = -(p - c)/|p - c|, de/dr = -1.
  Eigen::Matrix4d JtJ = Eigen::Matrix4d::Zero();
  double sum = 0, sum2 = 0;
  for (const auto& p : support) {
    const Eigen::Vector3d d = p - sphere.center_mm;
    const double n = d.norm();
    if (!(n > 0)) continue;
    Eigen::Vector4d j;
    j << -d / n, -1.0;
    JtJ += j * j.transpose();
    const double e = n - sphere.radius_mm;
    sum += e;
    sum2 += e * e;
  }
  const double count = double(support.size());
  const double mean = sum / count;
  const double var = std::max(0.0, sum2 / count - mean * mean) * count / (count - 4.0);
  Eigen::FullPivLU<Eigen::Matrix4d> lu(JtJ);
  if (!lu.isInvertible()) return std::nullopt;
  const Eigen::Matrix4d cov = lu.inverse() * var * std::max(1.0, correlation_area);
  return Eigen::Vector4d(cov.diagonal().cwiseMax(0).cwiseSqrt());
}

std::optional<Eigen::Vector4d> BlockJackknifeStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                      std::size_t max_points) {
  if (support.size() < 64) return std::nullopt;
  const std::vector<Eigen::Vector3d> subset = EvenSubset(support, max_points);
  // Patches on the sphere: the polar angle from the axis towards the camera (at the origin;
  // the z axis when the centre is the origin) split at its median, times 8 azimuth sectors.
  Eigen::Vector3d axis = -sphere.center_mm;
  axis = axis.norm() > 1e-9 ? Eigen::Vector3d(axis.normalized()) : Eigen::Vector3d(0, 0, -1);
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  std::vector<double> polar(subset.size());
  std::vector<int> sector(subset.size());
  for (std::size_t i = 0; i < subset.size(); ++i) {
    const Eigen::Vector3d d = (subset[i] - sphere.center_mm).normalized();
    polar[i] = d.dot(axis);
    double az = std::atan2(d.dot(v), d.dot(u));
    if (az < 0) az += 2 * M_PI;
    sector[i] = std::min(7, static_cast<int>(az / (2 * M_PI) * 8));
  }
  const double median_polar = Median(polar);
  std::vector<int> group(subset.size());
  for (std::size_t i = 0; i < subset.size(); ++i) group[i] = sector[i] + (polar[i] >= median_polar ? 8 : 0);
  return GroupJackknife(subset, group, 16, sphere);
}

std::optional<Eigen::Vector4d> BandJackknifeStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                     const Eigen::Vector3d& up, int bands, std::size_t max_points) {
  if (support.size() < 64 || bands < 4 || !(up.norm() > 0)) return std::nullopt;
  const std::vector<Eigen::Vector3d> subset = EvenSubset(support, max_points);
  const Eigen::Vector3d u = up.normalized();
  // Each point's band by its rank in height: equal counts, so no band is a handful of points.
  std::vector<std::size_t> order(subset.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return subset[a].dot(u) < subset[b].dot(u); });
  std::vector<int> band(subset.size());
  for (std::size_t k = 0; k < order.size(); ++k) band[order[k]] = int(k * std::size_t(bands) / order.size());
  return GroupJackknife(subset, band, bands, sphere);
}

double StudentT95(int dof) {
  // Tabulated to 30 degrees of freedom; beyond, the Cornish-Fisher series about 1.96.
  static constexpr double kT[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
                                  2.201,  2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
                                  2.080,  2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};
  if (dof < 1) return std::numeric_limits<double>::infinity();
  if (dof <= 30) return kT[dof - 1];
  const double z = 1.959964, n = double(dof);
  return z + (z * z * z + z) / (4 * n) + (5 * std::pow(z, 5) + 16 * z * z * z + 3 * z) / (96 * n * n);
}

std::optional<Eigen::Vector4d> RingJackknifeStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                     const Eigen::Vector3d& scanner, const Eigen::Vector3d& spin_axis,
                                                     std::size_t max_points) {
  if (support.size() < 64 || !(spin_axis.norm() > 0)) return std::nullopt;
  const std::vector<Eigen::Vector3d> subset = EvenSubset(support, max_points);
  const Eigen::Vector3d a = spin_axis.normalized();
  std::vector<std::pair<double, std::size_t>> el;  // degrees, index
  for (std::size_t i = 0; i < subset.size(); ++i) {
    const Eigen::Vector3d v = subset[i] - scanner;
    const double range = v.norm();
    if (range > 0) el.emplace_back(std::asin(std::clamp(v.dot(a) / range, -1.0, 1.0)) * 180 / M_PI, i);
  }
  if (el.size() < 64) return std::nullopt;
  std::sort(el.begin(), el.end());
  // Rings part where consecutive elevations lie more than 0.08 degrees apart (the finest
  // 128-laser heads space their lasers 0.1 degrees or more); a ring wider than 0.3 degrees is a
  // spread of elevations, not a laser's cone (cloud::ScannerRings' test).
  constexpr double kGap = 0.08, kWidest = 0.3;
  std::vector<int> ring(subset.size(), -1);
  int rings = 0;
  double first = el.front().first;
  for (std::size_t k = 0; k < el.size(); ++k) {
    if (k > 0 && el[k].first - el[k - 1].first > kGap) {
      ++rings;
      first = el[k].first;
    }
    if (el[k].first - first > kWidest) return std::nullopt;
    ring[el[k].second] = rings;
  }
  ++rings;
  if (rings < 4) return std::nullopt;
  std::vector<Eigen::Vector3d> kept;
  std::vector<int> group;
  for (std::size_t i = 0; i < subset.size(); ++i) {
    if (ring[i] >= 0) kept.push_back(subset[i]), group.push_back(ring[i]);
  }
  const auto se = GroupJackknife(kept, group, rings, sphere);
  if (!se) return std::nullopt;
  return Eigen::Vector4d(*se * (StudentT95(rings - 1) / 1.959964));
}

std::optional<Eigen::Vector4d> PerturbationStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                    const cloud::PointPerturbation& perturbation,
                                                    std::size_t max_points) {
  if (perturbation.samples < 2 || !perturbation.apply || support.size() < 5) return std::nullopt;
  const std::vector<Eigen::Vector3d> subset = EvenSubset(support, max_points);
  // In parallel, gathered in draw order (as the jackknife).
  std::vector<std::optional<Eigen::Vector4d>> by_draw(std::size_t(perturbation.samples));
  pipeline::ParallelFor(by_draw.size(), 0, 1, [&](std::size_t b, std::size_t e) {
    std::vector<Eigen::Vector3d> moved, finite;
    for (std::size_t s = b; s < e; ++s) {
      perturbation.apply(int(s), subset, &moved);
      finite.clear();
      for (const auto& p : moved) {
        if (p.allFinite()) finite.push_back(p);
      }
      if (finite.size() >= 5) by_draw[s] = Refit(finite, sphere);
    }
  });
  std::vector<Eigen::Vector4d> draws;
  for (const auto& e : by_draw) {
    if (e) draws.push_back(*e);
  }
  if (draws.size() < 2) return std::nullopt;
  return Eigen::Vector4d((SquaredDeviations(draws) / double(draws.size() - 1)).cwiseSqrt());
}

void AddUncertainty(const std::vector<Eigen::Vector3d>& points_mm, const cloud::PointPerturbation* rig,
                    SphereFitResult* fit, const cloud::PointPerturbation* matching) {
  if (!fit->converged) return;
  const std::vector<Eigen::Vector3d> support = SupportingPoints(points_mm, fit->sphere);
  if (!fit->std_error_mm) fit->std_error_mm = ScatterStdError(support, fit->sphere);
  // Stereo errors are shared by neighbouring points (matching windows, smoothing, the rim): the
  // block jackknife over surface patches counts what they share; keep the larger of the two
  // (unless the method's own errors already count them).
  if (const auto jack = fit->std_error_own ? std::nullopt : BlockJackknifeStdError(support, fit->sphere)) {
    fit->std_error_mm = fit->std_error_mm ? Eigen::Vector4d(fit->std_error_mm->cwiseMax(*jack)) : *jack;
  }
  if (rig && rig->samples > 1) fit->rig_std_error_mm = PerturbationStdError(support, fit->sphere, *rig);
  if (matching && matching->samples > 1) fit->matching_std_error_mm = PerturbationStdError(support, fit->sphere, *matching);
  // A sphere whose radius the points do not pin (its 95 % interval wider than the radius: a
  // consensus that picked a few hundred points of a lamppost, a fit to a wall) is no ball to act
  // on, however small its residuals; find refuses such a shape the same way
  // (`max_axis_uncertainty`).
  if (const auto total = TotalStdError(*fit); total && !fit->not_a_ball && 1.96 * total->w() > fit->sphere.radius_mm) {
    fit->not_a_ball = pipeline::Format(
        "the radius' 95 %% interval (+-%.0f mm) is wider than the radius itself (%.0f mm): the points do not pin a sphere",
        1.96 * total->w(), fit->sphere.radius_mm);
  }
}

std::optional<Eigen::Vector4d> TotalStdError(const SphereFitResult& fit) {
  if (!fit.std_error_mm && !fit.rig_std_error_mm && !fit.matching_std_error_mm) return std::nullopt;
  Eigen::Vector4d v = Eigen::Vector4d::Zero();
  for (const auto* part : {&fit.std_error_mm, &fit.rig_std_error_mm, &fit.matching_std_error_mm}) {
    if (*part) v += (*part)->cwiseAbs2();
  }
  return Eigen::Vector4d(v.cwiseSqrt());
}

}  // namespace hedgefit::fitting
