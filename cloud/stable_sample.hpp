#pragma once
/// A subset of points chosen by where each point lies, not by its place in the list.
///
/// Every n-th point by index makes the answer depend on the order the points come in: a file
/// written in another order (a PLY from another exporter, a cloud after a filter that sorts, a
/// PCD after `pdal translate`) or a cloud with one point more ahead of the others draws another
/// sample, and whatever is fitted or estimated from the sample moves by that sample's own error.
/// `find` on the real Wageningen garden's west half (docs/data.md) found 6 topiary in the file's
/// order and 5 in a shuffled copy of the same points. Here each point is kept or not by a hash of
/// the 1 mm grid cell it lies in, so which points are kept does not depend on their order or on
/// the others: a point added, removed or moved by a hair changes the subset by that point alone.

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace hedgefit::cloud {

/// A key for the unit grid cell holding (x, y, z), spread over all 64 bits: SplitMix64's
/// finaliser (Steele, Lea and Flood 2014) over the cell's three indices in turn.
inline std::uint64_t CellKey(double x, double y, double z) {
  const auto mix = [](std::uint64_t k) {
    k = (k ^ (k >> 30)) * 0xbf58476d1ce4e5b9ULL;
    k = (k ^ (k >> 27)) * 0x94d049bb133111ebULL;
    return k ^ (k >> 31);
  };
  std::uint64_t key = 0;
  for (const double v : {x, y, z}) key = mix(key ^ std::uint64_t(std::int64_t(std::floor(v))));
  return key;
}

/// The indices (in order) of about `most` of `points_mm` (x, y, z in mm; Eigen vectors of float
/// or double), each kept when the key (CellKey) of its grid cell `cell_mm` wide lies in the lowest
/// most / size of the keys' range. All of them when there are at most `most`; non-finite points
/// are never kept. `most` is a mean: the count kept varies by about its square root (points
/// sharing a cell go together). The cell is 1 mm for the fits, whose points a rounding-level
/// change moves by far less; a cloud whose unit is not yet known takes a share of its extent.
template <class Point>
std::vector<std::size_t> StableSample(const std::vector<Point>& points_mm, std::size_t most, double cell_mm = 1.0) {
  std::vector<std::size_t> kept;
  if (points_mm.size() <= most) {
    kept.reserve(points_mm.size());
    for (std::size_t i = 0; i < points_mm.size(); ++i) {
      if (points_mm[i].allFinite()) kept.push_back(i);
    }
    return kept;
  }
  const double share = double(most) / double(points_mm.size());
  const std::uint64_t below = std::uint64_t(std::ldexp(share, 64));
  kept.reserve(most + most / 8);
  for (std::size_t i = 0; i < points_mm.size(); ++i) {
    const Point& q = points_mm[i];
    if (!q.allFinite()) continue;
    if (CellKey(double(q[0]) / cell_mm, double(q[1]) / cell_mm, double(q[2]) / cell_mm) < below) kept.push_back(i);
  }
  return kept;
}

/// The points StableSample keeps, themselves.
template <class Point>
std::vector<Point> StablePoints(const std::vector<Point>& points_mm, std::size_t most, double cell_mm = 1.0) {
  std::vector<Point> out;
  for (const std::size_t i : StableSample(points_mm, most, cell_mm)) out.push_back(points_mm[i]);
  return out;
}

/// The indices of the finite points of `points_mm` in an order that is a property of the points,
/// not of the list: along a Z-order (Morton) curve over their bounding box, 2^21 steps a side,
/// ties broken by the coordinates themselves. Points next to each other in it lie near each other
/// in space, as in a scan's or a tiled model's own order, so every n-th point of it is a sample
/// spread evenly over the cloud, and the same whatever order the cloud came in. Exact duplicates
/// keep their order in the list; their coordinates are the same.
template <class Point>
std::vector<std::size_t> SpatialOrder(const std::vector<Point>& points_mm) {
  std::vector<std::size_t> idx;
  idx.reserve(points_mm.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i = 0; i < points_mm.size(); ++i) {
    if (!points_mm[i].allFinite()) continue;
    idx.push_back(i);
    const Eigen::Vector3d q = points_mm[i].template cast<double>();
    lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  }
  if (idx.empty()) return idx;
  constexpr int kBits = 21;
  const double step = std::max((hi - lo).maxCoeff() / double((1 << kBits) - 1), 1e-300);
  // The cell's three indices, their bits interleaved (x lowest).
  const auto spread = [](std::uint64_t v) {
    v &= 0x1fffffULL;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
  };
  std::vector<std::pair<std::uint64_t, std::size_t>> keyed;
  keyed.reserve(idx.size());
  for (const std::size_t i : idx) {
    const Eigen::Vector3d q = (points_mm[i].template cast<double>() - lo) / step;
    keyed.emplace_back(spread(std::uint64_t(q.x())) | spread(std::uint64_t(q.y())) << 1 | spread(std::uint64_t(q.z())) << 2, i);
  }
  std::stable_sort(keyed.begin(), keyed.end(), [&](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first < b.first;
    const Point& p = points_mm[a.second];
    const Point& q = points_mm[b.second];
    return std::array<double, 3>{double(p[0]), double(p[1]), double(p[2])} <
           std::array<double, 3>{double(q[0]), double(q[1]), double(q[2])};
  });
  for (std::size_t k = 0; k < keyed.size(); ++k) idx[k] = keyed[k].second;
  return idx;
}

}  // namespace hedgefit::cloud
