#include "cloud/pixel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

#include "cloud/squared_distance.hpp"

namespace hedgefit::cloud::internal {

std::optional<PixelGrid> PixelGrid::Of(const PointCloud& cloud) {
  const auto fu = cloud.fields.find(kPixelUField), fv = cloud.fields.find(kPixelVField),
             fp = cloud.fields.find(kPixelSizeField);
  if (fu == cloud.fields.end() || fv == cloud.fields.end() || fp == cloud.fields.end() ||
      cloud.fields.count("capture") != 0) {
    return std::nullopt;
  }
  const std::vector<float>&us = fu->second, &vs = fv->second;
  if (us.size() != cloud.size() || vs.size() != cloud.size() || fp->second.size() != cloud.size()) return std::nullopt;
  PixelGrid g(cloud);
  g.pixel_mm_ = &fp->second;
  int u_min = 0, v_min = 0, u_max = -1, v_max = -1;
  bool any = false;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!IsFinite(cloud.points_mm[i])) continue;
    const float u = us[i], v = vs[i];
    if (!(u >= 0 && v >= 0 && u < 1e6f && v < 1e6f) || u != std::floor(u) || v != std::floor(v)) return std::nullopt;
    const int iu = int(u), iv = int(v);
    if (!any) u_min = u_max = iu, v_min = v_max = iv, any = true;
    u_min = std::min(u_min, iu), u_max = std::max(u_max, iu), v_min = std::min(v_min, iv), v_max = std::max(v_max, iv);
  }
  if (!any) return std::nullopt;
  // A thinned capture keeps every stride-th pixel and row: the grid's step.
  int stride = 0;
  for (std::size_t i = 0; i < cloud.size() && stride != 1; ++i) {
    if (!IsFinite(cloud.points_mm[i])) continue;
    stride = std::gcd(stride, std::gcd(int(us[i]) - u_min, int(vs[i]) - v_min));
  }
  g.stride_ = std::max(1, stride);
  g.u0_ = u_min, g.v0_ = v_min;
  g.cols_ = (u_max - u_min) / g.stride_ + 1, g.rows_ = (v_max - v_min) / g.stride_ + 1;
  if (double(g.cols_) * double(g.rows_) > 64.0 * 1024 * 1024) return std::nullopt;
  g.cell_.assign(std::size_t(g.cols_) * std::size_t(g.rows_), -1);
  g.u_.assign(cloud.size(), -1), g.v_.assign(cloud.size(), -1);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!IsFinite(cloud.points_mm[i])) continue;
    const int gu = (int(us[i]) - u_min) / g.stride_, gv = (int(vs[i]) - v_min) / g.stride_;
    std::int32_t& c = g.cell_[std::size_t(gv) * std::size_t(g.cols_) + std::size_t(gu)];
    if (c >= 0) return std::nullopt;  // two points at one pixel: not one capture's grid
    c = std::int32_t(i);
    g.u_[i] = gu, g.v_[i] = gv;
  }
  return g;
}

int PixelGrid::HalfFor(std::size_t k) {
  int h = 1;
  while (std::size_t((2 * h + 1) * (2 * h + 1) - 1) < 2 * k) ++h;
  return h;
}

std::size_t PixelGrid::Nearest(std::size_t i, std::size_t k, std::uint32_t* indices, float* sq_distances,
                               std::vector<std::uint64_t>* scratch, bool* exact) const {
  *exact = false;
  const int u = u_[i], v = v_[i];
  if (u < 0 || k == 0) return 0;
  const Eigen::Vector3f& p = cloud_->points_mm[i];
  const float cos_axis = p.z() / p.norm();
  const float footprint = 0.95f * float(stride_) * (*pixel_mm_)[i] * cos_axis;
  auto& c = *scratch;
  // The window for k, then twice as wide where a slanted surface leaves the k-th nearest beyond
  // what the first can vouch for.
  std::size_t n = 0;
  for (int half = HalfFor(k), pass = 0; pass < 2 && !*exact; half *= 2, ++pass) {
    c.clear();
    for (int y = std::max(0, v - half); y <= std::min(rows_ - 1, v + half); ++y) {
      const std::int32_t* row = cell_.data() + std::size_t(y) * std::size_t(cols_);
      for (int x = std::max(0, u - half); x <= std::min(cols_ - 1, u + half); ++x) {
        const std::int32_t j = row[x];
        if (j < 0 || std::size_t(j) == i) continue;
        // The same float operations as the 3-D searches' L2, so equal neighbours tie alike.
        const Eigen::Vector3f& q = cloud_->points_mm[std::size_t(j)];
        const float acc = SquaredDistanceAsTrees(p.x() - q.x(), p.y() - q.y(), p.z() - q.z());
        // A non-negative float's bits order as the float does: distance and index in one key.
        std::uint32_t bits = 0;
        std::memcpy(&bits, &acc, sizeof bits);
        c.push_back((std::uint64_t(bits) << 32) | std::uint32_t(j));
      }
    }
    n = std::min(k, c.size());
    if (n == 0) return 0;
    // The k nearest, in no order but the k-th last (what the filters need: a set, its largest and
    // its sum).
    std::nth_element(c.begin(), c.begin() + std::ptrdiff_t(n - 1), c.end());
    const float reach = float(half + 1) * footprint;
    const std::uint64_t kth = c[n - 1] >> 32;
    float kth_sq = 0;
    std::memcpy(&kth_sq, &kth, sizeof kth_sq);
    *exact = n == k && std::isfinite(reach) && reach > 0 && kth_sq <= reach * reach;
  }
  for (std::size_t t = 0; t < n; ++t) {
    const std::uint32_t bits = std::uint32_t(c[t] >> 32);
    std::memcpy(&sq_distances[t], &bits, sizeof bits);
    indices[t] = std::uint32_t(c[t] & 0xffffffffu);
  }
  return n;
}

}  // namespace hedgefit::cloud::internal
