#include "fitting/trim.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "cloud/error.hpp"

namespace hedgefit::fitting {

namespace {

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(std::floor(q * double(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
  return v[k];
}

}  // namespace

TrimPlan PlanTrim(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& target, const TrimOptions& o,
                  const Eigen::Vector3d& pole) {
  if (!(target.radius_mm > 0) || !std::isfinite(target.radius_mm) || !target.center_mm.allFinite()) {
    throw Error("trim: the target needs a finite centre and a radius > 0 mm");
  }
  if (!(o.bin_deg >= 0.1 && o.bin_deg <= 90)) throw Error("trim: option 'bin_deg' must be in [0.1, 90] degrees");
  if (!(o.tolerance_mm >= 0) || !std::isfinite(o.tolerance_mm)) throw Error("trim: option 'tolerance' must be >= 0 mm");
  if (o.min_bin_points < 1) throw Error("trim: option 'min_bin_points' must be >= 1");
  if (!pole.allFinite() || pole.norm() == 0) throw Error("trim: the grid's pole must be a non-zero vector");
  TrimPlan plan;
  plan.target = target;
  const double R = target.radius_mm;
  // An orthonormal frame with z along the pole: rings of equal cos(theta) about it.
  const Eigen::Vector3d z = pole.normalized();
  const Eigen::Vector3d x = z.unitOrthogonal(), y = z.cross(x);
  const double bin = o.bin_deg * M_PI / 180;
  const int sectors = std::max(4, static_cast<int>(std::lround(2 * M_PI / bin)));
  const int rings = std::max(2, static_cast<int>(std::lround(2.0 / bin)));  // cos(theta) steps of ~bin at the equator
  const double bin_solid_angle = 4 * M_PI / (double(rings) * double(sectors));
  std::map<long, std::vector<double>> bins;  // radius samples per seen bin
  std::vector<double> cut;
  plan.depth_mm.assign(points_mm.size(), std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = 0; i < points_mm.size(); ++i) {
    const Eigen::Vector3d d = points_mm[i] - target.center_mm;
    if (!d.allFinite()) continue;
    const double r = d.norm();
    ++plan.points;
    plan.depth_mm[i] = static_cast<float>(r - R);
    if (r - R > o.tolerance_mm) cut.push_back(r - R), ++plan.points_to_cut;
    if (r == 0) continue;
    const double c = std::clamp(d.dot(z) / r, -1.0, 1.0);
    const double phi = std::atan2(d.dot(y), d.dot(x)) + M_PI;
    const int ring = std::min(rings - 1, static_cast<int>((c + 1) / 2 * rings));
    const int sector = std::min(sectors - 1, static_cast<int>(phi / (2 * M_PI) * sectors));
    bins[long(ring) * sectors + sector].push_back(r);
  }
  double seen = 0, cut_angle = 0, volume_mm3 = 0;
  for (auto& [key, radii] : bins) {
    if (int(radii.size()) < o.min_bin_points) continue;
    seen += bin_solid_angle;
    const double r = Percentile(radii, 0.5);
    if (r - R > o.tolerance_mm) cut_angle += bin_solid_angle;
    if (r > R) volume_mm3 += bin_solid_angle * (r * r * r - R * R * R) / 3;
  }
  plan.seen_share = seen / (4 * M_PI);
  plan.cut_share = seen > 0 ? cut_angle / seen : 0;
  plan.volume_seen_l = volume_mm3 * 1e-6;
  plan.volume_all_round_l = plan.seen_share > 0 ? plan.volume_seen_l / plan.seen_share : 0;
  plan.cut_p50_mm = Percentile(cut, 0.5);
  plan.cut_p90_mm = Percentile(cut, 0.9);
  plan.cut_p99_mm = Percentile(cut, 0.99);
  plan.cut_max_mm = cut.empty() ? 0 : *std::max_element(cut.begin(), cut.end());
  return plan;
}

}  // namespace hedgefit::fitting
