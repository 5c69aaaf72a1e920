#pragma once
// Exact k-nearest-neighbour mean distances on a sorted grid. Private to cloud/.
//
// Points are sorted by (z, y, x) cell, so each (y, z) row of cells is one contiguous
// range. Queries run in that order, and each starts from the previous query's k-th
// distance: it scans the box of cells that holds the ball of slightly more than that
// radius, and accepts the answer only if the ball holds at least k points (then no
// point outside can be nearer); otherwise the ball grows. So the result is exact
// whatever the cell size or guess; those only decide the speed.

#include <cstdint>
#include <vector>

#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud::internal {

/// Mean distance to the `mean_k` nearest other points for every finite point
/// (0 for non-finite ones), as PCL's StatisticalOutlierRemoval computes it.
std::vector<float> GridMeanKnnDistances(const PointCloud& cloud, int mean_k, int num_threads);

/// Tests only: use the portable inner loops even where AVX-512 is available.
void ForcePortableKnn(bool portable);

}  // namespace hedgefit::cloud::internal
