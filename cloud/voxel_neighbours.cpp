#include "cloud/voxel_neighbours.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <thread>

namespace hedgefit::cloud::internal {

namespace {

// Median distance to the k-th neighbour, from a random subset rescaled to the full
// density. Only speed depends on this estimate, never the result.
double EstimateKthDistance(const std::vector<Eigen::Vector3f>& pts, std::size_t k) {
  const std::size_t n = pts.size();
  const std::size_t subset = std::min<std::size_t>(n, 20000);
  const std::size_t queries = std::min<std::size_t>(n, 64);
  std::mt19937 rng(12345);  // fixed, so the grid (and so the timing) does not vary run to run
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  std::vector<Eigen::Vector3f> sub(subset);
  for (auto& p : sub) p = pts[pick(rng)];
  // In the subset the same ball holds about k * subset / n points.
  const std::size_t ks =
      std::min(subset - 1, std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(double(k) * subset / n))));
  std::vector<double> radii;
  std::vector<float> d(subset);
  for (std::size_t q = 0; q < queries; ++q) {
    const Eigen::Vector3f& p = pts[pick(rng)];
    for (std::size_t j = 0; j < subset; ++j) d[j] = (sub[j] - p).squaredNorm();
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(ks), d.end());
    radii.push_back(std::sqrt(double(d[ks])));
  }
  std::nth_element(radii.begin(), radii.begin() + static_cast<std::ptrdiff_t>(radii.size() / 2), radii.end());
  return radii[radii.size() / 2];
}

}  // namespace

std::vector<float> GridMeanKnnDistances(const PointCloud& cloud, int mean_k, int num_threads) {
  std::vector<float> out(cloud.size(), 0.0f);
  const std::size_t k = static_cast<std::size_t>(mean_k) + 1;  // includes the query point itself
  std::vector<std::uint32_t> finite;
  std::vector<Eigen::Vector3f> finite_pts;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (IsFinite(cloud.points_mm[i])) {
      finite.push_back(static_cast<std::uint32_t>(i));
      finite_pts.push_back(cloud.points_mm[i]);
    }
  }
  const std::size_t n = finite.size();
  if (n == 0) return out;

  Eigen::Vector3d lo = finite_pts[0].cast<double>(), hi = lo;
  for (const auto& p : finite_pts) {
    lo = lo.cwiseMin(p.cast<double>());
    hi = hi.cwiseMax(p.cast<double>());
  }
  const Eigen::Vector3d extent = hi - lo;
  const double diag = extent.norm();
  const double rho0 = n > k ? EstimateKthDistance(finite_pts, k) : diag;
  // Cells of 1.5 typical k-th distances (fastest on real stereo clouds: larger cells make
  // consecutive queries share boxes); coarser if the (y, z) row table would be too big.
  constexpr double kMaxRows = double(1 << 24);
  double h = std::max(rho0 * 1.5, diag * 1e-6);
  if (!(h > 0)) h = 1.0;  // every point identical
  h = std::max(h, std::sqrt((extent.y() + h) * (extent.z() + h) / kMaxRows));
  h = std::max(h, extent.x() / double(1u << 30));
  const double inv_h = 1.0 / h;
  const std::uint32_t nx = static_cast<std::uint32_t>(extent.x() * inv_h) + 1;
  const std::uint32_t ny = static_cast<std::uint32_t>(extent.y() * inv_h) + 1;
  const std::uint32_t nz = static_cast<std::uint32_t>(extent.z() * inv_h) + 1;
  auto cell = [&](double v, double origin, std::uint32_t count) {
    const double c = std::floor((v - origin) * inv_h);
    return static_cast<std::uint32_t>(std::clamp(c, 0.0, double(count - 1)));
  };

  // Sort points by (z, y, x) cell; each (y, z) row is then one contiguous range, sorted by x cell.
  struct Item {
    std::uint64_t key;
    std::uint32_t index;  // into finite
  };
  std::vector<Item> items(n);
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3f& p = finite_pts[j];
    const std::uint64_t row = std::uint64_t(cell(p.z(), lo.z(), nz)) * ny + cell(p.y(), lo.y(), ny);
    items[j] = {(row << 32) | cell(p.x(), lo.x(), nx), static_cast<std::uint32_t>(j)};
  }
  std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) { return a.key < b.key; });
  std::vector<float> xs(n), ys(n), zs(n);
  std::vector<std::uint32_t> cx(n);
  std::vector<std::uint32_t> row_begin(std::size_t(ny) * nz + 1, 0);
  for (std::size_t s = 0; s < n; ++s) {
    const Eigen::Vector3f& p = finite_pts[items[s].index];
    xs[s] = p.x();
    ys[s] = p.y();
    zs[s] = p.z();
    cx[s] = static_cast<std::uint32_t>(items[s].key & 0xffffffffu);
    ++row_begin[(items[s].key >> 32) + 1];
  }
  for (std::size_t r = 1; r < row_begin.size(); ++r) row_begin[r] += row_begin[r - 1];

  std::atomic<std::size_t> next{0};
  constexpr std::size_t kChunk = 2048;
  auto worker = [&]() {
    std::vector<float> near(n);
    std::vector<float> scratch;
    std::vector<std::pair<std::ptrdiff_t, std::ptrdiff_t>> ranges;
    std::array<std::uint32_t, 6> cached_box{1, 0, 1, 0, 1, 0};  // empty
    float guess = static_cast<float>(rho0 * rho0);  // k-th squared distance of the previous query
    for (;;) {
      const std::size_t first = next.fetch_add(kChunk);
      if (first >= n) break;
      const std::size_t last = std::min(n, first + kChunk);
      for (std::size_t s = first; s < last; ++s) {
        const float qx = xs[s], qy = ys[s], qz = zs[s];
        // Neighbouring queries have similar k-th distances: start just above the previous one.
        double rho2 = std::max(double(guess) * 1.15, 1e-30);
        std::size_t count = 0;
        for (;;) {
          // Every point within sqrt(rho2) of q lies in this box of cells (slightly padded
          // so float rounding of the distance cannot put a counted point outside it).
          const double rho = std::sqrt(rho2) * (1 + 1e-5) + 1e-9 * diag;
          const std::uint32_t x0 = cell(qx - rho, lo.x(), nx), x1 = cell(qx + rho, lo.x(), nx);
          const std::uint32_t y0 = cell(qy - rho, lo.y(), ny), y1 = cell(qy + rho, lo.y(), ny);
          const std::uint32_t z0 = cell(qz - rho, lo.z(), nz), z1 = cell(qz + rho, lo.z(), nz);
          const float limit = static_cast<float>(rho2);
          const std::array<std::uint32_t, 6> box{x0, x1, y0, y1, z0, z1};
          if (box != cached_box) {  // consecutive queries often share a box: reuse its ranges
            cached_box = box;
            ranges.clear();
            for (std::uint32_t iz = z0; iz <= z1; ++iz) {
              for (std::uint32_t iy = y0; iy <= y1; ++iy) {
                const std::size_t row = std::size_t(iz) * ny + iy;
                const std::uint32_t* rb = cx.data() + row_begin[row];
                const std::uint32_t* re = cx.data() + row_begin[row + 1];
                if (rb == re) continue;
                const std::uint32_t* b = std::lower_bound(rb, re, x0);
                const std::uint32_t* e = std::upper_bound(b, re, x1);
                if (b != e) ranges.emplace_back(b - cx.data(), e - cx.data());
              }
            }
          }
          count = 0;
          for (const auto& [b, e] : ranges) {
            const std::size_t len = static_cast<std::size_t>(e - b);
            if (scratch.size() < len) scratch.resize(len);
            float* dd = scratch.data();
            const float* px = xs.data() + b;
            const float* py = ys.data() + b;
            const float* pz = zs.data() + b;
            // Same float operations, in the same order, as FLANN's and nanoflann's L2, so every
            // distance matches PCL's bit for bit; a separate loop so it vectorises.
            for (std::size_t j = 0; j < len; ++j) {
              const float ex = qx - px[j], ey = qy - py[j], ez = qz - pz[j];
              float acc = ex * ex;
              acc += ey * ey;
              acc += ez * ez;
              dd[j] = acc;
            }
            for (std::size_t j = 0; j < len; ++j) {  // branch-free compaction
              near[count] = dd[j];
              count += dd[j] <= limit ? 1 : 0;
            }
          }
          const bool whole_grid = x0 == 0 && y0 == 0 && z0 == 0 && x1 == nx - 1 && y1 == ny - 1 && z1 == nz - 1;
          if (count >= k || (whole_grid && rho2 >= diag * diag)) break;
          rho2 = std::max(rho2 * 2.0, 1e-12 * diag * diag + 1e-30);
        }
        // PCL divides by mean_k even when the cloud holds fewer than k points; so do we.
        const std::size_t kk = std::min(k, count);
        // Sum of sqrt over the kk smallest squared distances. The query itself is among
        // them at distance 0 and adds nothing, as in PCL. Values clearly below the previous
        // k-th distance are certainly in; only the few near it need ordering.
        const float sure = guess * 0.8f;
        double sum = 0.0;
        std::size_t in = 0;
        std::size_t ring_size = 0;
        for (std::size_t j = 0; j < count; ++j) {
          const float v = near[j];
          if (v <= sure) {
            sum += std::sqrt(static_cast<double>(v));
            ++in;
          } else {
            near[ring_size++] = v;  // j >= ring_size: never overwrites an unread value
          }
        }
        float kth;
        if (in <= kk) {
          const std::size_t need = kk - in;  // ring_size >= need since count >= kk
          float* ring = near.data();
          std::sort(ring, ring + ring_size);
          for (std::size_t j = 0; j < need; ++j) sum += std::sqrt(static_cast<double>(ring[j]));
          kth = need > 0 ? ring[need - 1] : sure;
        } else {  // the guess was too high: select among everything again
          count = 0;
          for (const auto& [b, e] : ranges) {
            for (std::ptrdiff_t j = b; j < e; ++j) {
              const float ex = qx - xs[j], ey = qy - ys[j], ez = qz - zs[j];
              float acc = ex * ex;
              acc += ey * ey;
              acc += ez * ez;
              near[count] = acc;
              count += acc <= sure ? 1 : 0;
            }
          }
          std::nth_element(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(kk - 1),
                           near.begin() + static_cast<std::ptrdiff_t>(count));
          sum = 0.0;
          for (std::size_t j = 0; j < kk; ++j) sum += std::sqrt(static_cast<double>(near[j]));
          kth = near[kk - 1];
        }
        guess = kth;
        out[finite[items[s].index]] = static_cast<float>(sum / mean_k);
      }
    }
  };
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  unsigned threads = num_threads > 0 ? static_cast<unsigned>(num_threads) : hw;
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, (n + kChunk - 1) / kChunk));
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  return out;
}

}  // namespace hedgefit::cloud::internal
