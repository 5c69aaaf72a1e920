#include "cloud/point_cloud.hpp"

#include <cmath>

#include "pipeline/error.hpp"

#include <limits>

namespace hedgefit::cloud {

void PointCloud::CheckConsistent(const std::string& what) const {
  const std::size_t n = points_mm.size();
  if (!colors.empty() && colors.size() != n) {
    throw Error(what + ": " + std::to_string(colors.size()) + " colours for " +
                std::to_string(n) + " points; give one colour per point or none");
  }
  for (const auto& [name, values] : fields) {
    if (!values.empty() && values.size() != n) {
      throw Error(what + ": field '" + name + "' has " + std::to_string(values.size()) +
                  " values for " + std::to_string(n) + " points");
    }
  }
  if (static_cast<std::size_t>(width) * height != n) {
    throw Error(what + ": width*height = " + std::to_string(width) + "*" +
                std::to_string(height) + " does not match " + std::to_string(n) + " points");
  }
}

std::vector<Eigen::Vector3d> PointsAt(const PointCloud& cloud, const std::vector<std::size_t>& indices) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(indices.size());
  for (std::size_t i : indices) out.push_back(cloud.points_mm[i].cast<double>());
  return out;
}

std::vector<double> FieldAt(const PointCloud& cloud, const std::string& name, const std::vector<std::size_t>& indices) {
  std::vector<double> out;
  const auto it = cloud.fields.find(name);
  if (it == cloud.fields.end() || it->second.size() != cloud.size()) return out;
  out.reserve(indices.size());
  for (std::size_t i : indices) out.push_back(double(it->second[i]));
  return out;
}

void SetPoints(const std::vector<Eigen::Vector3d>& xyz, PointCloud* cloud) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  double largest = 0;
  for (const auto& p : xyz) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    largest = std::max(largest, p.cwiseAbs().maxCoeff());
  }
  cloud->offset = Eigen::Vector3d::Zero();
  const double side = largest > 0 ? (hi - lo).maxCoeff() : 0.0;
  if (largest > kShiftAbove || (largest > kShiftFarAbove && largest > kShiftFarFor * side)) {
    cloud->offset = (1000.0 * ((lo + hi) / 2000.0).array().round()).matrix();
  }
  cloud->points_mm.clear();
  cloud->points_mm.reserve(xyz.size());
  for (const auto& p : xyz) cloud->points_mm.push_back((p - cloud->offset).cast<float>());
}

PointCloud Select(const PointCloud& cloud, const std::vector<std::size_t>& indices) {
  PointCloud out;
  out.offset = cloud.offset;
  out.points_mm.reserve(indices.size());
  for (std::size_t i : indices) out.points_mm.push_back(cloud.points_mm[i]);
  if (cloud.HasColor()) {
    out.colors.reserve(indices.size());
    for (std::size_t i : indices) out.colors.push_back(cloud.colors[i]);
  }
  for (const auto& [name, values] : cloud.fields) {
    if (values.empty()) continue;
    std::vector<float>& dst = out.fields[name];
    dst.reserve(indices.size());
    for (std::size_t i : indices) dst.push_back(values[i]);
  }
  out.Flatten();
  return out;
}

std::vector<HedgeGroup> HedgeGroups(const PointCloud& cloud) {
  auto it = cloud.fields.find(kHedgeIdField);
  if (it == cloud.fields.end() || it->second.empty()) {
    HedgeGroup all;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (IsFinite(cloud.points_mm[i])) all.indices.push_back(i);
    }
    return {all};
  }
  std::map<int, std::vector<std::size_t>> by_id;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float id = it->second[i];
    if (IsFinite(cloud.points_mm[i]) && std::isfinite(id) && id >= 1) by_id[int(std::lround(id))].push_back(i);
  }
  std::vector<HedgeGroup> out;
  for (auto& [id, indices] : by_id) out.push_back(HedgeGroup{id, std::move(indices)});
  return out;
}

PointCloud MaskOrganized(const PointCloud& cloud, const std::vector<bool>& keep) {
  PointCloud out = cloud;
  const Eigen::Vector3f nan = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = 0; i < out.points_mm.size(); ++i) {
    if (!keep[i]) out.points_mm[i] = nan;
  }
  return out;
}

std::size_t CountNonFinite(const PointCloud& cloud) {
  std::size_t n = 0;
  for (const auto& p : cloud.points_mm) n += IsFinite(p) ? 0 : 1;
  return n;
}

bool Bounds(const PointCloud& cloud, Eigen::Vector3f* min_mm, Eigen::Vector3f* max_mm) {
  bool any = false;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : cloud.points_mm) {
    if (!IsFinite(p)) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    any = true;
  }
  if (any) {
    *min_mm = lo;
    *max_mm = hi;
  }
  return any;
}

}  // namespace hedgefit::cloud
