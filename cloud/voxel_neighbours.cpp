#include "cloud/voxel_neighbours.hpp"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "cloud/squared_distance.hpp"
#include "pipeline/parallel.hpp"

namespace hedgefit::cloud::internal {

using pipeline::ParallelFor;

namespace {

bool g_force_portable = false;

// Median distance to the k-th neighbour, from a random subset rescaled to the full
// density. Only speed depends on this estimate, never the result.
double EstimateKthDistance(const std::vector<Eigen::Vector3f>& pts, std::size_t k) {
  const std::size_t n = pts.size();
  const std::size_t subset = std::min<std::size_t>(n, 8000);
  const std::size_t queries = std::min<std::size_t>(n, 32);
  std::mt19937 rng(12345);  // fixed, so the grid (and so the timing) does not vary run to run
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  std::vector<Eigen::Vector3f> sub(subset);
  for (auto& p : sub) p = pts[pick(rng)];
  // In the subset the same ball holds about k * subset / n points.
  const std::size_t ks =
      std::min(subset - 1, std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(double(k) * subset / n))));
  std::vector<double> radii;
  std::vector<float> d(subset), smallest;
  for (std::size_t q = 0; q < queries; ++q) {
    const Eigen::Vector3f& p = pts[pick(rng)];
    for (std::size_t j = 0; j < subset; ++j) d[j] = (sub[j] - p).squaredNorm();
    // The (ks + 1)-th smallest, as nth_element would place at d[ks], from a max-heap of the ks + 1
    // smallest so far: most distances fail the one comparison with its top, where nth_element
    // partitions the whole subset (2.5 ms of the 32 queries on a lab ball's 10,888 points).
    smallest.assign(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(ks + 1));
    std::make_heap(smallest.begin(), smallest.end());
    for (std::size_t j = ks + 1; j < subset; ++j) {
      if (d[j] < smallest.front()) {
        std::pop_heap(smallest.begin(), smallest.end());
        smallest.back() = d[j];
        std::push_heap(smallest.begin(), smallest.end());
      }
    }
    radii.push_back(std::sqrt(double(smallest.front())));
  }
  std::nth_element(radii.begin(), radii.begin() + static_cast<std::ptrdiff_t>(radii.size() / 2), radii.end());
  return radii[radii.size() / 2];
}

// The two inner loops of every query, in a portable version and an AVX-512 one picked
// at run time. Both compute each squared distance with the same float operations in the
// same order as FLANN's and nanoflann's L2 (no FMA), so distances match PCL's bit for bit.

// Appends to near[count...] the squared distances <= limit from q to points [b, e);
// returns the new count. near needs 16 floats of slack past the last value it keeps.
std::size_t ScanPortable(const float* xs, const float* ys, const float* zs, std::size_t b, std::size_t e, float qx,
                         float qy, float qz, float limit, float* near, std::size_t count) {
  for (std::size_t j = b; j < e; ++j) {
    const float acc = SquaredDistanceAsTrees(qx - xs[j], qy - ys[j], qz - zs[j]);
    near[count] = acc;
    count += acc <= limit ? 1 : 0;  // branch-free compaction
  }
  return count;
}

// Sums sqrt of the values <= sure (into *sum, counting them in *in) and copies the others
// to ring (16 floats of slack needed); returns how many were copied. near is unchanged.
std::size_t SplitPortable(const float* near, std::size_t count, float sure, double* sum, std::size_t* in,
                          float* ring_out) {
  double s = 0.0;
  std::size_t ring = 0, n_in = 0;
  for (std::size_t j = 0; j < count; ++j) {
    const float v = near[j];
    if (v <= sure) {
      s += std::sqrt(static_cast<double>(v));
      ++n_in;
    } else {
      ring_out[ring++] = v;
    }
  }
  *sum = s;
  *in = n_in;
  return ring;
}

// The 10 compare-exchange layers of a 16-lane bitonic sort: each lane's partner, and
// which lanes keep the larger value.
struct BitonicNetwork {
  std::array<std::array<std::int32_t, 16>, 10> partner{};
  std::array<std::uint16_t, 10> take_max{};
};

const BitonicNetwork& Bitonic16() {
  static const BitonicNetwork net = [] {
    BitonicNetwork b;
    std::size_t l = 0;
    for (int k = 2; k <= 16; k *= 2) {
      for (int j = k / 2; j >= 1; j /= 2, ++l) {
        for (int i = 0; i < 16; ++i) {
          const int p = i ^ j;
          b.partner[l][static_cast<std::size_t>(i)] = p;
          const bool ascending = (i & k) == 0;
          if (ascending != (i < p)) b.take_max[l] = static_cast<std::uint16_t>(b.take_max[l] | (1u << i));
        }
      }
    }
    return b;
  }();
  return net;
}

#if defined(__x86_64__) && defined(__GNUC__)
#define HEDGEFIT_HAVE_AVX512_KERNELS 1
// GCC 12 reports its own intrinsics' deliberately undefined lanes as "maybe uninitialized".
#pragma GCC diagnostic push
#if !defined(__clang__)  // clang (the fuzz build) has no such group and warns about the name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"
__attribute__((target("avx512f"))) std::size_t ScanAvx512(const float* xs, const float* ys, const float* zs,
                                                         std::size_t b, std::size_t e, float qx, float qy, float qz,
                                                         float limit, float* near, std::size_t count) {
  const __m512 vx = _mm512_set1_ps(qx), vy = _mm512_set1_ps(qy), vz = _mm512_set1_ps(qz);
  const __m512 vl = _mm512_set1_ps(limit);
  for (std::size_t j = b; j < e; j += 16) {
    const __mmask16 valid = e - j >= 16 ? __mmask16(0xffff) : __mmask16((1u << (e - j)) - 1);
    const __m512 ex = _mm512_sub_ps(vx, _mm512_maskz_loadu_ps(valid, xs + j));
    const __m512 ey = _mm512_sub_ps(vy, _mm512_maskz_loadu_ps(valid, ys + j));
    const __m512 ez = _mm512_sub_ps(vz, _mm512_maskz_loadu_ps(valid, zs + j));
    __m512 acc = _mm512_mul_ps(ex, ex);
    acc = _mm512_add_ps(acc, _mm512_mul_ps(ey, ey));
    acc = _mm512_add_ps(acc, _mm512_mul_ps(ez, ez));
    const __mmask16 keep = _mm512_mask_cmp_ps_mask(valid, acc, vl, _CMP_LE_OQ);
    // Compress in a register, then a plain store: compress-to-memory is slow on some CPUs.
    _mm512_storeu_ps(near + count, _mm512_maskz_compress_ps(keep, acc));
    count += static_cast<std::size_t>(__builtin_popcount(keep));
  }
  return count;
}

__attribute__((target("avx512f"))) std::size_t SplitAvx512(const float* near, std::size_t count, float sure,
                                                          double* sum, std::size_t* in, float* ring_out) {
  const __m512 vs = _mm512_set1_ps(sure);
  __m512d acc_lo = _mm512_setzero_pd(), acc_hi = _mm512_setzero_pd();
  std::size_t ring = 0, n_in = 0;
  for (std::size_t j = 0; j < count; j += 16) {
    const __mmask16 valid = count - j >= 16 ? __mmask16(0xffff) : __mmask16((1u << (count - j)) - 1);
    const __m512 v = _mm512_maskz_loadu_ps(valid, near + j);
    const __mmask16 le = _mm512_mask_cmp_ps_mask(valid, v, vs, _CMP_LE_OQ);
    const __mmask16 gt = valid & static_cast<__mmask16>(~le);
    const __m512d d_lo = _mm512_cvtps_pd(_mm512_castps512_ps256(v));
    const __m512d d_hi = _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1)));
    acc_lo = _mm512_mask_add_pd(acc_lo, static_cast<__mmask8>(le & 0xff), acc_lo, _mm512_sqrt_pd(d_lo));
    acc_hi = _mm512_mask_add_pd(acc_hi, static_cast<__mmask8>(le >> 8), acc_hi, _mm512_sqrt_pd(d_hi));
    n_in += static_cast<std::size_t>(__builtin_popcount(le));
    _mm512_storeu_ps(ring_out + ring, _mm512_maskz_compress_ps(gt, v));
    ring += static_cast<std::size_t>(__builtin_popcount(gt));
  }
  *sum = _mm512_reduce_add_pd(acc_lo) + _mm512_reduce_add_pd(acc_hi);
  *in = n_in;
  return ring;
}

// Sorts up to 16 floats ascending with a bitonic network in one register.
__attribute__((target("avx512f"))) void Sort16Avx512(float* v, std::size_t n) {
  const BitonicNetwork& net = Bitonic16();
  const __mmask16 valid = static_cast<__mmask16>((1u << n) - 1);
  __m512 x = _mm512_mask_loadu_ps(_mm512_set1_ps(std::numeric_limits<float>::infinity()), valid, v);
  for (std::size_t l = 0; l < net.partner.size(); ++l) {
    const __m512 y = _mm512_permutexvar_ps(_mm512_loadu_si512(net.partner[l].data()), x);
    x = _mm512_mask_blend_ps(net.take_max[l], _mm512_min_ps(x, y), _mm512_max_ps(x, y));
  }
  _mm512_mask_storeu_ps(v, valid, x);
}
#pragma GCC diagnostic pop
#endif

void SortPortable(float* v, std::size_t n) { std::sort(v, v + n); }

struct Kernels {
  decltype(&ScanPortable) scan = &ScanPortable;
  decltype(&SplitPortable) split = &SplitPortable;
  decltype(&SortPortable) sort16 = &SortPortable;  ///< sorts at most 16 values
};

Kernels PickKernels() {
  Kernels k;
#ifdef HEDGEFIT_HAVE_AVX512_KERNELS
  if (!g_force_portable && __builtin_cpu_supports("avx512f")) {
    k.scan = &ScanAvx512;
    k.split = &SplitAvx512;
    k.sort16 = &Sort16Avx512;
  }
#endif
  return k;
}

// The finite points sorted by (z, y, x) cell of a grid whose cells are about 1.5 typical k-th
// distances: each (y, z) row of cells is one contiguous range of the sorted points, sorted by x cell.
struct SortedGrid {
  std::vector<std::uint32_t> finite;  // cloud index of each finite point
  std::vector<std::uint32_t> order;   // sorted position -> index into finite
  std::vector<float> xs, ys, zs;      // the sorted points
  std::vector<std::uint32_t> cx;      // their x cells
  std::vector<std::uint32_t> row_begin;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();
  double diag = 0, rho0 = 0, inv_h = 1;
  std::uint32_t nx = 1, ny = 1, nz = 1;

  std::uint32_t Cell(double v, double origin, std::uint32_t count) const {
    const double c = std::floor((v - origin) * inv_h);
    return static_cast<std::uint32_t>(std::clamp(c, 0.0, double(count - 1)));
  }
};

SortedGrid BuildGrid(const PointCloud& cloud, std::size_t k) {
  SortedGrid g;
  std::vector<Eigen::Vector3f> finite_pts;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (IsFinite(cloud.points_mm[i])) {
      g.finite.push_back(static_cast<std::uint32_t>(i));
      finite_pts.push_back(cloud.points_mm[i]);
    }
  }
  const std::size_t n = g.finite.size();
  if (n == 0) return g;
  Eigen::Vector3d lo = finite_pts[0].cast<double>(), hi = lo;
  for (const auto& p : finite_pts) {
    lo = lo.cwiseMin(p.cast<double>());
    hi = hi.cwiseMax(p.cast<double>());
  }
  g.lo = lo;
  const Eigen::Vector3d extent = hi - lo;
  g.diag = extent.norm();
  g.rho0 = n > k ? EstimateKthDistance(finite_pts, k) : g.diag;
  // Cells of 1.5 typical k-th distances (fastest on real stereo clouds: larger cells let
  // consecutive queries share boxes); coarser if the (y, z) row table would be too big.
  constexpr double kMaxRows = double(1 << 24);
  double h = std::max(g.rho0 * 1.5, g.diag * 1e-6);
  if (!(h > 0)) h = 1.0;  // every point identical
  h = std::max(h, std::sqrt((extent.y() + h) * (extent.z() + h) / kMaxRows));
  h = std::max(h, extent.x() / double(1u << 30));
  g.inv_h = 1.0 / h;
  g.nx = static_cast<std::uint32_t>(extent.x() * g.inv_h) + 1;
  g.ny = static_cast<std::uint32_t>(extent.y() * g.inv_h) + 1;
  g.nz = static_cast<std::uint32_t>(extent.z() * g.inv_h) + 1;
  // Sort points by (z, y, x) cell; each (y, z) row is then one contiguous range, sorted by x cell.
  struct Item {
    std::uint64_t key;
    std::uint32_t index;  // into finite
  };
  std::vector<Item> items(n);
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3f& p = finite_pts[j];
    const std::uint64_t row = std::uint64_t(g.Cell(p.z(), lo.z(), g.nz)) * g.ny + g.Cell(p.y(), lo.y(), g.ny);
    items[j] = {(row << 32) | g.Cell(p.x(), lo.x(), g.nx), static_cast<std::uint32_t>(j)};
  }
  std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) { return a.key < b.key; });
  g.xs.resize(n), g.ys.resize(n), g.zs.resize(n), g.cx.resize(n), g.order.resize(n);
  g.row_begin.assign(std::size_t(g.ny) * g.nz + 1, 0);
  for (std::size_t s = 0; s < n; ++s) {
    const Eigen::Vector3f& p = finite_pts[items[s].index];
    g.xs[s] = p.x();
    g.ys[s] = p.y();
    g.zs[s] = p.z();
    g.cx[s] = static_cast<std::uint32_t>(items[s].key & 0xffffffffu);
    g.order[s] = items[s].index;
    ++g.row_begin[(items[s].key >> 32) + 1];
  }
  for (std::size_t r = 1; r < g.row_begin.size(); ++r) g.row_begin[r] += g.row_begin[r - 1];
  return g;
}

// Scratch per worker, kept across its chunks (the buffers are as long as the cloud).
struct KnnScratch {
  std::vector<float> near, ring;
  std::vector<std::pair<std::ptrdiff_t, std::ptrdiff_t>> ranges;
  std::array<std::uint32_t, 6> cached_box{1, 0, 1, 0, 1, 0};  // empty
  float guess = 0;  // k-th squared distance of the previous query
};

// Gathers into sc.near the squared distances from sorted point `s` within a radius grown from the
// previous query's k-th distance until it holds k points (or the whole grid); returns their count.
std::size_t GatherNear(const SortedGrid& g, const Kernels& kernels, std::size_t s, std::size_t k, KnnScratch* sc) {
  const float qx = g.xs[s], qy = g.ys[s], qz = g.zs[s];
  // Neighbouring queries have similar k-th distances: start just above the previous one.
  double rho2 = std::max(double(sc->guess) * 1.12, 1e-30);
  std::size_t count = 0;
  for (;;) {
    // Every point within sqrt(rho2) of q lies in this box of cells (slightly padded so float
    // rounding of the distance cannot put a counted point outside it).
    const double rho = std::sqrt(rho2) * (1 + 1e-5) + 1e-9 * g.diag;
    const std::uint32_t x0 = g.Cell(qx - rho, g.lo.x(), g.nx), x1 = g.Cell(qx + rho, g.lo.x(), g.nx);
    const std::uint32_t y0 = g.Cell(qy - rho, g.lo.y(), g.ny), y1 = g.Cell(qy + rho, g.lo.y(), g.ny);
    const std::uint32_t z0 = g.Cell(qz - rho, g.lo.z(), g.nz), z1 = g.Cell(qz + rho, g.lo.z(), g.nz);
    const float limit = static_cast<float>(rho2);
    const std::array<std::uint32_t, 6> box{x0, x1, y0, y1, z0, z1};
    if (box != sc->cached_box) {  // consecutive queries often share a box: reuse its ranges
      sc->cached_box = box;
      sc->ranges.clear();
      for (std::uint32_t iz = z0; iz <= z1; ++iz) {
        for (std::uint32_t iy = y0; iy <= y1; ++iy) {
          const std::size_t row = std::size_t(iz) * g.ny + iy;
          const std::uint32_t* rb = g.cx.data() + g.row_begin[row];
          const std::uint32_t* re = g.cx.data() + g.row_begin[row + 1];
          if (rb == re) continue;
          const std::uint32_t* b = std::lower_bound(rb, re, x0);
          const std::uint32_t* e = std::upper_bound(b, re, x1);
          if (b != e) sc->ranges.emplace_back(b - g.cx.data(), e - g.cx.data());
        }
      }
    }
    count = 0;
    for (const auto& [b, e] : sc->ranges) {
      count = kernels.scan(g.xs.data(), g.ys.data(), g.zs.data(), static_cast<std::size_t>(b), static_cast<std::size_t>(e),
                           qx, qy, qz, limit, sc->near.data(), count);
    }
    const bool whole_grid = x0 == 0 && y0 == 0 && z0 == 0 && x1 == g.nx - 1 && y1 == g.ny - 1 && z1 == g.nz - 1;
    if (count >= k || (whole_grid && rho2 >= g.diag * g.diag)) return count;
    rho2 = std::max(rho2 * 2.0, 1e-12 * g.diag * g.diag + 1e-30);
  }
}

// The sum of the square roots of the kk smallest of the `count` squared distances in sc.near; the
// query itself is among them at distance 0 and adds nothing, as in PCL. Values clearly below the
// previous k-th distance are certainly in; only the few near it need ordering. Updates sc.guess.
double SumOfNearest(const Kernels& kernels, std::size_t count, std::size_t kk, KnnScratch* sc) {
  std::vector<float>& near = sc->near;
  std::vector<float>& ring = sc->ring;
  const float sure = sc->guess * 0.88f;
  double sum = 0.0;
  std::size_t in = 0;
  const std::size_t ring_size = kernels.split(near.data(), count, sure, &sum, &in, ring.data());
  float kth;
  if (in <= kk) {
    const std::size_t need = kk - in;  // ring_size >= need since count >= kk
    if (ring_size <= 16) {
      kernels.sort16(ring.data(), ring_size);
    } else {
      std::nth_element(ring.begin(), ring.begin() + static_cast<std::ptrdiff_t>(need),
                       ring.begin() + static_cast<std::ptrdiff_t>(ring_size));
    }
    for (std::size_t j = 0; j < need; ++j) sum += std::sqrt(static_cast<double>(ring[j]));
    kth = need > 0 ? *std::max_element(ring.begin(), ring.begin() + static_cast<std::ptrdiff_t>(need)) : sure;
  } else {  // the neighbourhood got denser than the guess: select among all of near
    std::nth_element(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(kk - 1),
                     near.begin() + static_cast<std::ptrdiff_t>(count));
    sum = 0.0;
    for (std::size_t j = 0; j < kk; ++j) sum += std::sqrt(static_cast<double>(near[j]));
    kth = near[kk - 1];
  }
  sc->guess = kth;
  return sum;
}

}  // namespace

std::vector<float> GridMeanKnnDistances(const PointCloud& cloud, int mean_k, int num_threads) {
  std::vector<float> out(cloud.size(), 0.0f);
  const std::size_t k = static_cast<std::size_t>(mean_k) + 1;  // includes the query point itself
  const SortedGrid g = BuildGrid(cloud, k);
  const std::size_t n = g.finite.size();
  if (n == 0) return out;
  constexpr std::size_t kChunk = 2048;
  const Kernels kernels = PickKernels();
  tbb::enumerable_thread_specific<KnnScratch> scratch([&] {
    KnnScratch sc;
    sc.near.resize(n + 16);  // slack for the vector kernels' full-width stores
    sc.ring.resize(n + 16);
    sc.guess = static_cast<float>(g.rho0 * g.rho0);
    return sc;
  });
  ParallelFor(n, num_threads, kChunk, [&](std::size_t first, std::size_t last) {
    KnnScratch& sc = scratch.local();
    for (std::size_t s = first; s < last; ++s) {
      const std::size_t count = GatherNear(g, kernels, s, k, &sc);
      // PCL divides by mean_k even when the cloud holds fewer than k points; so do we.
      const double sum = SumOfNearest(kernels, count, std::min(k, count), &sc);
      out[g.finite[g.order[s]]] = static_cast<float>(sum / mean_k);
    }
  });
  return out;
}

void ForcePortableKnn(bool portable) { g_force_portable = portable; }

}  // namespace hedgefit::cloud::internal
