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

#include <cmath>
#include <cstddef>
#include <cstdint>
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

}  // namespace hedgefit::cloud
