#include "cloud/filters.hpp"
#include "pipeline/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <unordered_map>

#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_parallel_plane.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>
#include <pcl/sample_consensus/sac_model_plane.h>

#include "pipeline/error.hpp"
#include "cloud/pcl_adapter.hpp"
#include "cloud/neighbour_search.hpp"
#include "cloud/pixel_grid.hpp"
#include "cloud/squared_distance.hpp"
#include "cloud/voxel_neighbours.hpp"

namespace hedgefit::cloud {

using pipeline::OptionTable;
using pipeline::ParallelFor;

namespace {

// Builds a FilterResult from per-point keep flags (non-finite points never kept).
FilterResult Finish(const PointCloud& cloud, std::vector<bool> keep, bool keep_organized) {
  FilterResult r;
  std::vector<std::size_t> kept_idx;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const bool finite = IsFinite(cloud.points_mm[i]);
    if (!finite) {
      ++r.nonfinite;
      keep[i] = false;
    } else if (keep[i]) {
      ++r.kept;
      kept_idx.push_back(i);
    } else {
      ++r.removed;
    }
  }
  r.cloud = keep_organized ? MaskOrganized(cloud, keep) : Select(cloud, kept_idx);
  return r;
}

}  // namespace

FilterResult RemoveNonFinite(const PointCloud& cloud) {
  return Finish(cloud, std::vector<bool>(cloud.size(), true), false);
}

const OptionTable<StatisticalOutlierOptions>& StatisticalOutlierOptions::Table() {
  using O = StatisticalOutlierOptions;
  static const auto table =
      OptionTable<O>()
          .Add("mean_k", &O::mean_k, "neighbours used for each point's mean distance", "points").Range(1, 10000)
          .Add("stddev_mul", &O::stddev_mul, "threshold in standard deviations above the mean distance", "sigma")
          .Add("threads", &O::num_threads, "worker threads, 0 = all cores", "threads").Range(0, 1024)
          .Add("keep_organized", &O::keep_organized, "set removed points to NaN instead of dropping them");
  return table;
}

void StatisticalOutlierOptions::Check() const { Table().Validate(*this); }

std::vector<float> MeanNeighbourDistances(const PointCloud& cloud, int mean_k, int num_threads) {
  return internal::GridMeanKnnDistances(cloud, mean_k, num_threads);
}

std::vector<bool> StatisticalInliers(const PointCloud& cloud, const StatisticalOutlierOptions& options,
                                     double* threshold) {
  options.Check();
  const std::vector<float> distances = MeanNeighbourDistances(cloud, options.mean_k, options.num_threads);
  // Mean and sample standard deviation exactly as PCL accumulates them (float squares, double sums).
  double sum = 0, sq_sum = 0;
  std::size_t valid = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!IsFinite(cloud.points_mm[i])) continue;
    const float d = distances[i];
    sum += d;
    sq_sum += d * d;
    ++valid;
  }
  std::vector<bool> keep(cloud.size(), false);
  if (valid == 0) return keep;
  const double n = static_cast<double>(valid);
  const double mean = sum / n;
  const double variance = valid > 1 ? (sq_sum - sum * sum / n) / (n - 1) : 0.0;
  const double limit = mean + options.stddev_mul * std::sqrt(std::max(variance, 0.0));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    keep[i] = IsFinite(cloud.points_mm[i]) && !(distances[i] > limit);
  }
  if (threshold) *threshold = limit;
  return keep;
}

FilterResult StatisticalOutlierRemoval(const PointCloud& cloud, const StatisticalOutlierOptions& options) {
  double threshold = 0;
  std::vector<bool> keep = StatisticalInliers(cloud, options, &threshold);
  FilterResult r = Finish(cloud, std::move(keep), options.keep_organized);
  r.threshold = threshold;
  return r;
}

const OptionTable<RadiusOutlierOptions>& RadiusOutlierOptions::Table() {
  using O = RadiusOutlierOptions;
  static const auto table =
      OptionTable<O>()
          .Add("radius", &O::radius_mm, "neighbourhood radius", "mm").Min(1e-9)
          .Add("min_neighbours", &O::min_neighbours, "other points needed within radius", "points").Range(0, 1000000)
          .Add("threads", &O::num_threads, "worker threads, 0 = all cores", "threads").Range(0, 1024)
          .Add("keep_organized", &O::keep_organized, "set removed points to NaN instead of dropping them");
  return table;
}

void RadiusOutlierOptions::Check() const { Table().Validate(*this); }

FilterResult RadiusOutlierRemoval(const PointCloud& cloud, const RadiusOutlierOptions& options) {
  options.Check();
  const internal::FiniteIndex index(cloud);
  const auto& finite = index.finite();
  std::vector<bool> keep(cloud.size(), false);
  std::vector<char> keep_finite(finite.size(), 0);  // vector<bool> is not thread-safe per element
  const float sq_radius = static_cast<float>(options.radius_mm * options.radius_mm);
  // The count includes the query point itself, as PCL's does.
  const std::size_t needed = static_cast<std::size_t>(options.min_neighbours) + 1;
  ParallelFor(finite.size(), options.num_threads, 1024, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      keep_finite[j] = index.CountWithin(cloud.points_mm[finite[j]].data(), sq_radius, needed) >= needed;
    }
  });
  for (std::size_t j = 0; j < finite.size(); ++j) keep[finite[j]] = keep_finite[j] != 0;
  FilterResult r = Finish(cloud, std::move(keep), options.keep_organized);
  r.threshold = options.radius_mm;
  return r;
}

const OptionTable<LocalOutlierOptions>& LocalOutlierOptions::Table() {
  using O = LocalOutlierOptions;
  static const auto table =
      OptionTable<O>()
          .Add("k", &O::k, "neighbours compared with each point", "points").Range(2, 1000)
          .Add("threshold", &O::threshold, "remove points whose local outlier factor exceeds this", "ratio").Min(1.0)
          .Add("neighbours", &O::neighbours,
               "pixels: on a stereo capture's cloud (pixel_u, pixel_v) each point's neighbours from the pixels about "
               "it where those surely hold the nearest (a facing surface), else from a 3-D search: the same "
               "neighbours, found faster; space: a 3-D search for every point")
          .Choices({"pixels", "space"})
          .Add("threads", &O::num_threads, "worker threads, 0 = all cores", "threads").Range(0, 1024)
          .Add("keep_organized", &O::keep_organized, "set removed points to NaN instead of dropping them");
  return table;
}

void LocalOutlierOptions::Check() const { Table().Validate(*this); }

namespace {

// Below this many points left to a 3-D search, NearestOthers scans every point for them instead
// of building a k-d tree: on a stereo capture's cloud the image grid answers all but a few dozen
// (66 of a lab ball's 10,888), and building the tree over all of them (about 1.5 ms on one core)
// cost more than scanning every point for those few (about 25 us a point among 10,000).
constexpr std::size_t kFewForTheTree = 96;

// The `kk` nearest others of each point in `rest` (positions in `finite`), written as
// NearestOthers writes them, by scanning every finite point. Each squared distance is summed as
// nanoflann's L2_Simple_Adaptor sums it (x, y, z in turn, the same expressions), so the
// distances are the k-d tree's to the bit; ties are ordered by position in `finite`.
void NearestOthersByScan(const PointCloud& cloud, const std::vector<std::uint32_t>& finite, std::size_t kk,
                         const std::vector<std::size_t>& rest, int num_threads, std::vector<std::uint32_t>* nbr,
                         std::vector<float>* dist) {
  const std::size_t n = finite.size();
  std::vector<float> xs(n), ys(n), zs(n);
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3f& p = cloud.points_mm[finite[j]];
    xs[j] = p.x(), ys[j] = p.y(), zs[j] = p.z();
  }
  ParallelFor(rest.size(), num_threads, 4, [&](std::size_t begin, std::size_t end) {
    std::vector<float> sq(n), order(n);
    std::vector<std::pair<float, std::uint32_t>> best;
    for (std::size_t r = begin; r < end; ++r) {
      const std::size_t j = rest[r];
      const float qx = xs[j], qy = ys[j], qz = zs[j];
      for (std::size_t i = 0; i < n; ++i) {
        sq[i] = internal::SquaredDistanceAsTrees(qx - xs[i], qy - ys[i], qz - zs[i]);
      }
      // The kk-th smallest distance of the others (the point itself is one 0 among them), then
      // every other within it, ordered by distance and position: the kk nearest, ties by position.
      order = sq;
      std::nth_element(order.begin(), order.begin() + std::ptrdiff_t(kk), order.end());
      const float within = order[kk];  // the (kk + 1)-th smallest, the point itself counted
      best.clear();
      for (std::size_t i = 0; i < n; ++i) {
        if (i != j && sq[i] <= within) best.emplace_back(sq[i], std::uint32_t(i));
      }
      std::sort(best.begin(), best.end());
      for (std::size_t t = 0; t < kk; ++t) {
        (*nbr)[j * kk + t] = best[t].second;
        (*dist)[j * kk + t] = std::sqrt(best[t].first);
      }
    }
  });
}

// Each finite point's `k` nearest others in 3-D, as positions in `finite` with their distances
// (row j of `nbr` and `dist`, the k-th nearest last): on the image grid where `grid` is given and
// its window surely holds them (PixelGrid::Nearest's `exact`), else with a k-d tree (built only
// when some point needs it). Either way the k nearest of the cloud.
void NearestOthers(const PointCloud& cloud, const std::vector<std::uint32_t>& finite, std::size_t kk,
                   const std::optional<internal::PixelGrid>& grid, int num_threads, std::vector<std::uint32_t>* nbr,
                   std::vector<float>* dist) {
  const std::size_t n = finite.size();
  nbr->assign(n * kk, 0);
  dist->assign(n * kk, 0.0f);
  std::vector<char> in_space(n, grid ? 0 : 1);
  if (grid) {
    std::vector<std::int32_t> pos_of(cloud.size(), -1);
    for (std::size_t j = 0; j < n; ++j) pos_of[finite[j]] = std::int32_t(j);
    ParallelFor(n, num_threads, 512, [&](std::size_t begin, std::size_t end) {
      std::vector<std::uint32_t> idx(kk);
      std::vector<float> sq(kk);
      std::vector<std::uint64_t> scratch;
      for (std::size_t j = begin; j < end; ++j) {
        bool exact = false;
        if (grid->Nearest(finite[j], kk, idx.data(), sq.data(), &scratch, &exact) < kk || !exact) {
          in_space[j] = 1;
          continue;
        }
        for (std::size_t t = 0; t < kk; ++t) {
          (*nbr)[j * kk + t] = std::uint32_t(pos_of[idx[t]]);
          (*dist)[j * kk + t] = std::sqrt(sq[t]);
        }
      }
    });
  }
  std::vector<std::size_t> rest;
  for (std::size_t j = 0; j < n; ++j) {
    if (in_space[j]) rest.push_back(j);
  }
  if (rest.empty()) return;
  if (rest.size() <= kFewForTheTree) {
    NearestOthersByScan(cloud, finite, kk, rest, num_threads, nbr, dist);
    return;
  }
  const internal::FiniteIndex index(cloud);
  ParallelFor(rest.size(), num_threads, 512, [&](std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> pos(kk + 1);
    std::vector<float> sq(kk + 1);
    for (std::size_t r = begin; r < end; ++r) {
      const std::size_t j = rest[r];
      const std::size_t found = index.Nearest(cloud.points_mm[finite[j]].data(), kk + 1, pos.data(), sq.data());
      // Drop the point itself (by position, so that a duplicate of it counts as a neighbour).
      std::size_t m = 0;
      for (std::size_t t = 0; t < found && m < kk; ++t) {
        if (pos[t] == j) continue;
        (*nbr)[j * kk + m] = pos[t];
        (*dist)[j * kk + m] = std::sqrt(sq[t]);
        ++m;
      }
      for (; m < kk; ++m) (*nbr)[j * kk + m] = (*nbr)[j * kk + m - 1], (*dist)[j * kk + m] = (*dist)[j * kk + m - 1];
    }
  });
}

std::vector<std::uint32_t> FiniteIndices(const PointCloud& cloud) {
  std::vector<std::uint32_t> finite;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (IsFinite(cloud.points_mm[i])) finite.push_back(static_cast<std::uint32_t>(i));
  }
  return finite;
}

}  // namespace

std::vector<float> LocalOutlierFactors(const PointCloud& cloud, int k, int num_threads, bool on_pixels) {
  if (k < 1) throw Error("filters.local_outlier: k must be at least 1");
  const std::vector<std::uint32_t> finite = FiniteIndices(cloud);
  const std::size_t n = finite.size();
  std::vector<float> factors(cloud.size(), 0.0f);
  if (n < 2) {
    for (std::uint32_t i : finite) factors[i] = 1.0f;
    return factors;
  }
  const std::size_t kk = std::min<std::size_t>(std::size_t(k), n - 1);
  // Pass 1: each point's k nearest others (by position in `finite`) and their distances.
  std::vector<std::uint32_t> nbr;
  std::vector<float> dist, kdist(n);
  NearestOthers(cloud, finite, kk, on_pixels ? internal::PixelGrid::Of(cloud) : std::nullopt, num_threads, &nbr, &dist);
  for (std::size_t j = 0; j < n; ++j) kdist[j] = dist[j * kk + kk - 1];
  // Pass 2: local reachability density, the inverse mean reach distance max(k-distance(o), d(p, o)).
  // Points stacked on one spot have a zero mean; a floor of 1e-9 mm keeps their density finite.
  std::vector<double> lrd(n);
  ParallelFor(n, num_threads, 2048, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      double sum = 0;
      for (std::size_t t = 0; t < kk; ++t) sum += std::max(kdist[nbr[j * kk + t]], dist[j * kk + t]);
      lrd[j] = 1.0 / std::max(sum / double(kk), 1e-9);
    }
  });
  // Pass 3: the factor, the neighbours' mean density over the point's own.
  ParallelFor(n, num_threads, 2048, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      double sum = 0;
      for (std::size_t t = 0; t < kk; ++t) sum += lrd[nbr[j * kk + t]];
      factors[finite[j]] = static_cast<float>(sum / double(kk) / lrd[j]);
    }
  });
  return factors;
}

FilterResult LocalOutlierRemoval(const PointCloud& cloud, const LocalOutlierOptions& options) {
  options.Check();
  const std::vector<float> factors =
      LocalOutlierFactors(cloud, options.k, options.num_threads, options.neighbours == "pixels");
  std::vector<bool> keep(cloud.size(), false);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    keep[i] = IsFinite(cloud.points_mm[i]) && !(factors[i] > options.threshold);
  }
  FilterResult r = Finish(cloud, std::move(keep), options.keep_organized);
  r.threshold = options.threshold;
  return r;
}

const OptionTable<SpacingOutlierOptions>& SpacingOutlierOptions::Table() {
  using O = SpacingOutlierOptions;
  static const auto table =
      OptionTable<O>()
          .Add("mean_k", &O::mean_k, "neighbours used for each point's mean distance", "points").Range(1, 10000)
          .Add("max_ratio", &O::max_ratio,
               "remove points whose mean neighbour distance, in pixel footprints, exceeds this many times the cloud's median", "ratio")
          .Min(1.0)
          .Add("threads", &O::num_threads, "worker threads, 0 = all cores", "threads").Range(0, 1024)
          .Add("keep_organized", &O::keep_organized, "set removed points to NaN instead of dropping them");
  return table;
}

void SpacingOutlierOptions::Check() const { Table().Validate(*this); }

namespace {

// Per-point mean neighbour distance over pixel footprint (unnormalised), and the median of it.
std::vector<float> FootprintDistances(const PointCloud& cloud, int mean_k, int num_threads, double* median,
                                      double* median_footprint) {
  std::vector<float> d = MeanNeighbourDistances(cloud, mean_k, num_threads);
  const auto field = cloud.fields.find(kPixelSizeField);
  const bool has = field != cloud.fields.end() && field->second.size() == cloud.size();
  std::vector<float> ratios, footprints;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!IsFinite(cloud.points_mm[i])) continue;
    const float px = has ? field->second[i] : 1.0f;
    const float fp = std::isfinite(px) && px > 0 ? px : 1.0f;
    d[i] /= fp;
    ratios.push_back(d[i]);
    footprints.push_back(fp);
  }
  auto median_of = [](std::vector<float>& v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return double(v[v.size() / 2]);
  };
  *median = median_of(ratios);
  *median_footprint = median_of(footprints);
  return d;
}

}  // namespace

std::vector<float> SpacingRatios(const PointCloud& cloud, int mean_k, int num_threads) {
  double median = 0, footprint = 0;
  std::vector<float> d = FootprintDistances(cloud, mean_k, num_threads, &median, &footprint);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    d[i] = IsFinite(cloud.points_mm[i]) && median > 0 ? float(d[i] / median) : 0.0f;
  }
  return d;
}

FilterResult SpacingOutlierRemoval(const PointCloud& cloud, const SpacingOutlierOptions& options) {
  options.Check();
  double median = 0, footprint = 0;
  const std::vector<float> d = FootprintDistances(cloud, options.mean_k, options.num_threads, &median, &footprint);
  const double limit = options.max_ratio * median;
  std::vector<bool> keep(cloud.size(), false);
  for (std::size_t i = 0; i < cloud.size(); ++i) keep[i] = IsFinite(cloud.points_mm[i]) && !(d[i] > limit);
  FilterResult r = Finish(cloud, std::move(keep), options.keep_organized);
  r.threshold = limit * footprint;
  return r;
}

const OptionTable<HedgeOutlierOptions>& HedgeOutlierOptions::Table() {
  using O = HedgeOutlierOptions;
  static const auto table =
      OptionTable<O>()
          .Add("shells", &O::shells,
               "for hedges found by depth (a hedge_id field): statistical (mean_k 30, 1 sigma) or local (as a stereo "
               "capture of one hedge)")
          .Choices({"statistical", "local"})
          .Add("neighbours", &O::neighbours,
               "the local outlier factor's neighbours: pixels (from the pixels about each point where they surely "
               "hold the nearest, as filters.local_outlier) or space (a 3-D search)")
          .Choices({"pixels", "space"})
          .Add("per_hedge", &O::per_hedge,
               "shells statistical: each hedge against its own points' statistics, so its cleaning does not depend on "
               "what else the cloud holds (false: the whole cloud's)")
          .Add("threads", &O::num_threads, "worker threads, 0 = all cores", "threads").Range(0, 1024);
  return table;
}

void HedgeOutlierOptions::Check() const { Table().Validate(*this); }

bool HedgeOutlierIsLocal(const PointCloud& cloud, const HedgeOutlierOptions& options) {
  const bool footprints = cloud.fields.count(kPixelSizeField) != 0;
  const bool shells = cloud.fields.count(kHedgeIdField) != 0;
  return footprints && (!shells || options.shells == "local");
}

FilterResult HedgeOutlierRemoval(const PointCloud& cloud, const HedgeOutlierOptions& options) {
  options.Check();
  if (!HedgeOutlierIsLocal(cloud, options)) {
    StatisticalOutlierOptions so;
    so.mean_k = 30;
    so.stddev_mul = 1.0;
    so.num_threads = options.num_threads;
    // Hedges found by depth are judged each against its own points' neighbour distances, so a
    // hedge's cleaning, and so its fit, does not depend on what else the frame holds (a cloud split
    // into one file per hedge by `convert` is cleaned by `compare` as `measure` cleaned it whole).
    const std::vector<HedgeGroup> groups = HedgeGroups(cloud);
    if (groups.size() < 2 || !options.per_hedge) return StatisticalOutlierRemoval(cloud, so);
    // Points of no hedge are judged against the whole cloud's statistics; when every finite point
    // belongs to a hedge (as a segmented capture's do), that pass would be overwritten point by
    // point below, and is skipped (it cost as much as the hedges' own).
    std::size_t in_hedges = 0;
    for (const HedgeGroup& g : groups) in_hedges += g.indices.size();
    std::vector<bool> keep = in_hedges + CountNonFinite(cloud) < cloud.size() ? StatisticalInliers(cloud, so, nullptr)
                                                                              : std::vector<bool>(cloud.size(), false);
    for (const HedgeGroup& g : groups) {
      const std::vector<bool> own = StatisticalInliers(Select(cloud, g.indices), so, nullptr);
      for (std::size_t j = 0; j < g.indices.size(); ++j) keep[g.indices[j]] = own[j];
    }
    return Finish(cloud, std::move(keep), so.keep_organized);
  }
  LocalOutlierOptions lo;
  lo.num_threads = options.num_threads;
  lo.neighbours = options.neighbours;
  const FilterResult local = LocalOutlierRemoval(cloud, lo);
  SpacingOutlierOptions sp;
  sp.num_threads = options.num_threads;
  FilterResult r = SpacingOutlierRemoval(local.cloud, sp);
  r.removed += local.removed;
  r.nonfinite = local.nonfinite;
  return r;
}

const OptionTable<VoxelGridOptions>& VoxelGridOptions::Table() {
  using O = VoxelGridOptions;
  static const auto table =
      OptionTable<O>()
          .Add("leaf", &O::leaf_mm, "voxel edge length", "mm").Min(1e-6)
          .Add("min_points_per_voxel", &O::min_points_per_voxel, "drop voxels with fewer points", "points").Range(1, 1000000);
  return table;
}

void VoxelGridOptions::Check() const { Table().Validate(*this); }

FilterResult VoxelGrid(const PointCloud& cloud, const VoxelGridOptions& options) {
  options.Check();
  FilterResult r;
  struct Entry {
    std::uint64_t key;
    std::uint32_t index;
  };
  std::vector<Entry> entries;
  entries.reserve(cloud.size());
  Eigen::Vector3f lo, hi;
  if (!Bounds(cloud, &lo, &hi)) throw Error("filters.voxel_grid: the cloud has no finite points");
  const double inv = 1.0 / options.leaf_mm;
  const double span = ((hi - lo).cast<double>() * inv).maxCoeff();
  if (span >= double(1 << 21)) {
    throw Error("leaf: " + std::to_string(options.leaf_mm) + " mm gives more than 2^21 voxels along one axis of this cloud; use a larger leaf");
  }
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points_mm[i];
    if (!IsFinite(p)) {
      ++r.nonfinite;
      continue;
    }
    // Same voxel assignment as PCL: floor(p / leaf), here relative to the minimum (21 bits per axis).
    const auto q = ((p.cast<double>() * inv).array().floor() - (lo.cast<double>() * inv).array().floor()).cast<std::uint64_t>();
    entries.push_back({(q[2] << 42) | (q[1] << 21) | q[0], static_cast<std::uint32_t>(i)});
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.key < b.key || (a.key == b.key && a.index < b.index);
  });
  PointCloud& out = r.cloud;
  for (std::size_t b = 0; b < entries.size();) {
    std::size_t e = b;
    while (e < entries.size() && entries[e].key == entries[b].key) ++e;
    const std::size_t n = e - b;
    if (n >= static_cast<std::size_t>(options.min_points_per_voxel)) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      Eigen::Vector3d color = Eigen::Vector3d::Zero();
      for (std::size_t j = b; j < e; ++j) {
        sum += cloud.points_mm[entries[j].index].cast<double>();
        if (cloud.HasColor()) {
          const Rgb& c = cloud.colors[entries[j].index];
          color += Eigen::Vector3d(c[0], c[1], c[2]);
        }
      }
      out.points_mm.push_back((sum / double(n)).cast<float>());
      if (cloud.HasColor()) {
        color /= double(n);
        out.colors.push_back(Rgb{static_cast<std::uint8_t>(std::lround(color[0])),
                                 static_cast<std::uint8_t>(std::lround(color[1])),
                                 static_cast<std::uint8_t>(std::lround(color[2]))});
      }
      for (const auto& [name, values] : cloud.fields) {
        if (values.empty()) continue;
        double s = 0;
        for (std::size_t j = b; j < e; ++j) s += values[entries[j].index];
        out.fields[name].push_back(static_cast<float>(s / double(n)));
      }
      r.kept += 1;
    }
    b = e;
  }
  r.removed = entries.size() - r.kept;  // merged into a centroid or in a sparse voxel
  out.Flatten();
  r.threshold = options.leaf_mm;
  return r;
}

const OptionTable<CropBoxOptions>& CropBoxOptions::Table() {
  using O = CropBoxOptions;
  static const auto table = OptionTable<O>()
                                .Add("min", &O::min_mm, "box corner [x, y, z]", "mm")
                                .Add("max", &O::max_mm, "opposite corner [x, y, z]", "mm")
                                .Add("negative", &O::negative, "keep the points outside the box")
                                .Add("keep_organized", &O::keep_organized, "set removed points to NaN instead of dropping them");
  return table;
}

void CropBoxOptions::Check() const {
  Table().Validate(*this);
  for (int a = 0; a < 3; ++a) {
    if (min_mm[a] > max_mm[a]) {
      throw Error(std::string("option 'min'/'max': min ") + "xyz"[a] + " (" + std::to_string(min_mm[a]) + ") is above max " +
                  "xyz"[a] + " (" + std::to_string(max_mm[a]) + "); swap them");
    }
  }
}

FilterResult CropBox(const PointCloud& cloud, const CropBoxOptions& options) {
  options.Check();
  std::vector<bool> keep(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points_mm[i];
    const bool inside = (p.array() >= options.min_mm.array()).all() && (p.array() <= options.max_mm.array()).all();
    keep[i] = inside != options.negative;
  }
  return Finish(cloud, std::move(keep), options.keep_organized);
}

const OptionTable<PassThroughOptions>& PassThroughOptions::Table() {
  using O = PassThroughOptions;
  static const auto table =
      OptionTable<O>()
          .Add("field", &O::field, "field to test: x, y, z, range (distance from the sensor) or an extra field")
          .Add("min", &O::min, "inclusive lower limit", "field unit (mm for x y z)")
          .Add("max", &O::max, "inclusive upper limit", "field unit (mm for x y z)")
          .Add("negative", &O::negative, "keep the points outside [min, max]")
          .Add("keep_organized", &O::keep_organized, "set removed points to NaN instead of dropping them");
  return table;
}

void PassThroughOptions::Check() const {
  Table().Validate(*this);
  if (field.empty()) throw Error("option 'field': name the field to test (x, y, z or an extra field)");
  if (min > max) throw Error("option 'min'/'max': need min <= max");
}

FilterResult PassThrough(const PointCloud& cloud, const PassThroughOptions& options) {
  options.Check();
  const std::vector<float>* values = nullptr;
  int axis = -1;
  if (options.field == "x" || options.field == "y" || options.field == "z") {
    axis = options.field[0] - 'x';
  } else if (options.field == "range") {
    axis = 3;  // distance from the sensor at the origin
  } else {
    auto it = cloud.fields.find(options.field);
    if (it == cloud.fields.end() || it->second.empty()) {
      std::string have = "x, y, z, range";
      for (const auto& [name, v] : cloud.fields) have += ", " + name;
      throw Error("option 'field': the cloud has no field '" + options.field + "'; it has " + have);
    }
    values = &it->second;
  }
  std::vector<bool> keep(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double v = axis == 3 ? double(cloud.points_mm[i].norm()) : axis >= 0 ? cloud.points_mm[i][axis] : (*values)[i];
    const bool inside = v >= options.min && v <= options.max;
    keep[i] = inside != options.negative;
  }
  return Finish(cloud, std::move(keep), options.keep_organized);
}

const OptionTable<PlaneRemovalOptions>& PlaneRemovalOptions::Table() {
  using O = PlaneRemovalOptions;
  static const auto table =
      OptionTable<O>()
          .Add("distance_threshold", &O::distance_threshold_mm, "points this close to a plane are removed", "mm").Min(1e-9)
          .Add("min_inliers", &O::min_inliers, "stop when the best plane has fewer points", "points").Range(3, 1000000000)
          .Add("max_planes", &O::max_planes, "planes to remove at most", "planes").Range(1, 1000)
          .Add("max_iterations", &O::max_iterations, "RANSAC samples per plane", "samples").Range(1, 10000000);
  return table;
}

void PlaneRemovalOptions::Check() const { Table().Validate(*this); }

namespace {

// PCL seeds its sampler with a constant; this exposes the seed.
class SeededPlaneModel : public pcl::SampleConsensusModelPlane<pcl::PointXYZ> {
 public:
  SeededPlaneModel(const PointCloudConstPtr& cloud, const pcl::Indices& indices, std::uint64_t seed)
      : pcl::SampleConsensusModelPlane<pcl::PointXYZ>(cloud, indices, false) {
    rng_alg_.seed(static_cast<unsigned>(seed ^ (seed >> 32)));
  }
};

}  // namespace

FilterResult RemovePlanes(const PointCloud& cloud, const PlaneRemovalOptions& options) {
  options.Check();
  QuietPcl();
  Eigen::Vector3f lo, hi;
  std::vector<bool> keep(cloud.size(), false);
  if (!Bounds(cloud, &lo, &hi)) return Finish(cloud, keep, false);
  // PCL works in float: centre the coordinates first.
  const Eigen::Vector3f mid = 0.5f * (lo + hi);
  auto pc = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pc->resize(cloud.size());
  pcl::Indices remaining;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f q = cloud.points_mm[i] - mid;
    (*pc)[i] = pcl::PointXYZ(q.x(), q.y(), q.z());
    if (IsFinite(cloud.points_mm[i])) {
      remaining.push_back(static_cast<int>(i));
      keep[i] = true;
    }
  }
  int planes = 0;
  for (; planes < options.max_planes && remaining.size() >= static_cast<std::size_t>(options.min_inliers); ++planes) {
    auto model = std::make_shared<SeededPlaneModel>(pc, remaining, options.seed + static_cast<std::uint64_t>(planes));
    pcl::RandomSampleConsensus<pcl::PointXYZ> sac(model, options.distance_threshold_mm);
    sac.setMaxIterations(options.max_iterations);
    if (!sac.computeModel()) break;
    pcl::Indices inliers;
    sac.getInliers(inliers);
    if (inliers.size() < static_cast<std::size_t>(options.min_inliers)) break;
    for (int i : inliers) keep[static_cast<std::size_t>(i)] = false;
    pcl::Indices next;
    for (int i : remaining) {
      if (keep[static_cast<std::size_t>(i)]) next.push_back(i);
    }
    remaining.swap(next);
  }
  FilterResult r = Finish(cloud, std::move(keep), false);
  r.threshold = planes;
  return r;
}

std::optional<Plane> FindPlane(const std::vector<Eigen::Vector3f>& points, const PlaneSearch& search) {
  if (points.size() < 3) return std::nullopt;
  QuietPcl();
  // PCL works in float: centre the coordinates first.
  Eigen::Vector3f mid = Eigen::Vector3f::Zero();
  for (const auto& p : points) mid += p;
  mid /= float(points.size());
  auto pc = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pc->resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f q = points[i] - mid;
    (*pc)[i] = pcl::PointXYZ(q.x(), q.y(), q.z());
  }
  class SeededModel : public pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ> {
   public:
    SeededModel(const PointCloudConstPtr& cloud, std::uint64_t seed)
        : pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>(cloud, false) {
      rng_alg_.seed(static_cast<unsigned>(seed ^ (seed >> 32)));
    }
  };
  auto model = std::make_shared<SeededModel>(pc, search.seed);
  model->setAxis(search.axis.normalized());
  model->setEpsAngle(search.max_angle_deg * 3.14159265358979323846 / 180.0);
  pcl::RandomSampleConsensus<pcl::PointXYZ> sac(model, search.distance_threshold_mm);
  sac.setMaxIterations(search.max_iterations);
  if (!sac.computeModel()) return std::nullopt;
  pcl::Indices inliers;
  sac.getInliers(inliers);
  if (inliers.size() < 3) return std::nullopt;
  Eigen::VectorXf coefficients, refined;
  sac.getModelCoefficients(coefficients);
  model->optimizeModelCoefficients(inliers, coefficients, refined);
  Plane plane;
  plane.normal = refined.head<3>();
  const float norm = plane.normal.norm();
  if (!(norm > 0)) return std::nullopt;
  plane.normal /= norm;
  plane.d = refined[3] / norm - plane.normal.dot(mid);
  plane.inliers = inliers.size();
  return plane;
}

}  // namespace hedgefit::cloud
