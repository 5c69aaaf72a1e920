#pragma once
// Exact k-nearest-neighbour search and radius counting over the finite points of a cloud (nanoflann k-d tree),
// Private to cloud/.

#include <nanoflann.hpp>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud::internal {

/// The finite points of a cloud, and a k-d tree over them.
class FiniteIndex {
 public:
  explicit FiniteIndex(const PointCloud& cloud) : cloud_(cloud) {
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (IsFinite(cloud.points_mm[i])) finite_.push_back(static_cast<std::uint32_t>(i));
    }
    tree_ = std::make_unique<Tree>(3, *this, nanoflann::KDTreeSingleIndexAdaptorParams(12));
  }
  // nanoflann dataset interface (positions in finite_ order).
  std::size_t kdtree_get_point_count() const { return finite_.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return cloud_.points_mm[finite_[i]][dim]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }

  /// Cloud index of the i-th finite point.
  const std::vector<std::uint32_t>& finite() const { return finite_; }

  /// The `k` nearest finite points to `query` (positions in finite(), nearest first) and their
  /// squared distances; fewer when the cloud has fewer. The query point itself is among them.
  std::size_t Nearest(const float* query, std::size_t k, std::uint32_t* positions, float* sq_distances) const {
    return tree_->knnSearch(query, k, positions, sq_distances);
  }

  /// Number of points strictly within sqrt(sq_radius), including the query point, up to `cap`.
  std::size_t CountWithin(const float* query, float sq_radius, std::size_t cap) const {
    CountingResultSet rs{sq_radius, 0, cap};
    tree_->findNeighbors(rs, query, nanoflann::SearchParams(0, 0, false));
    return rs.count;
  }

 private:
  struct CountingResultSet {
    float radius;
    std::size_t count;
    std::size_t cap;
    bool full() const { return true; }
    bool addPoint(float dist, std::uint32_t) {
      if (dist < radius) ++count;
      return count < cap;  // stop once the answer is known
    }
    float worstDist() const { return radius; }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, FiniteIndex>, FiniteIndex, 3,
                                                   std::uint32_t>;
  const PointCloud& cloud_;
  std::vector<std::uint32_t> finite_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace hedgefit::cloud::internal
