#include "stereo/bspline.hpp"

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HEDGEFIT_HAVE_AVX512_REMAP 1
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "pipeline/error.hpp"

namespace hedgefit::stereo {

namespace {

bool g_force_portable_remap = false;

// The row prefilter of one channel of `image` (8-bit with any number of channels, or CV_32FC1),
// written to the same channel of `out` (float, the image's size: one channel, or as many as the
// image has, interleaved). An 8-bit sample is read straight into the
// double sums: the value is the float it would have been converted to, so the coefficients are
// the same bits as those of that channel split off and converted to float first, without the
// two full-size copies (a region of the paper's hedge size is 3.5 MB a plane, each a fresh
// allocation whose pages the kernel must fault in).
template <typename T>
void RowPass(const cv::Mat& image, int channel, cv::Mat* out) {
  const double z = std::sqrt(3.0) - 2.0;  // the cubic spline's pole
  const int n = image.cols, step = image.channels(), out_step = out->channels();
  if (n < 2) {
    for (int y = 0; y < image.rows; ++y) {
      const T* s = image.ptr<T>(y) + channel;
      float* o = out->ptr<float>(y) + channel;
      for (int k = 0; k < n; ++k) o[k * out_step] = static_cast<float>(s[k * step]);
    }
    return;
  }
  const int horizon = std::min(n, 24);  // |z|^24 ~ 2e-14
  // Four rows at a time, interleaved: each row's recursion is a chain of dependent multiply-adds,
  // and four independent chains keep the core busy where one would wait on each step. Each row's
  // arithmetic is the one-row recursion's, in the same order, so the result is the same to the bit.
  constexpr int kRows = 4;
  const int groups = (image.rows + kRows - 1) / kRows;
  cv::parallel_for_(cv::Range(0, groups), [&](const cv::Range& range) {
    std::vector<double> buffer(static_cast<std::size_t>(n) * kRows);
    double* c = buffer.data();  // c[k * kRows + r]: row r's coefficient k
    for (int g = range.start; g < range.end; ++g) {
      const int y0 = g * kRows, rows = std::min(kRows, image.rows - y0);
      const T* s[kRows];
      for (int r = 0; r < kRows; ++r) s[r] = image.ptr<T>(y0 + std::min(r, rows - 1)) + channel;  // spare lanes repeat a row
      double sum[kRows] = {0, 0, 0, 0}, zk = 1;
      for (int k = 0; k < horizon; ++k, zk *= z) {  // causal pass, mirror boundary
        for (int r = 0; r < kRows; ++r) sum[r] += zk * static_cast<double>(s[r][k * step]);
      }
      for (int r = 0; r < kRows; ++r) c[r] = sum[r];
      for (int k = 1; k < n; ++k) {
        double* ck = c + static_cast<std::ptrdiff_t>(k) * kRows;
        for (int r = 0; r < kRows; ++r) ck[r] = static_cast<double>(s[r][k * step]) + z * ck[r - kRows];
      }
      double* last = c + static_cast<std::ptrdiff_t>(n - 1) * kRows;
      for (int r = 0; r < kRows; ++r) last[r] = (z / (z * z - 1)) * (last[r] + z * last[r - kRows]);
      for (int k = n - 2; k >= 0; --k) {
        double* ck = c + static_cast<std::ptrdiff_t>(k) * kRows;
        for (int r = 0; r < kRows; ++r) ck[r] = z * (ck[r + kRows] - ck[r]);
      }
      for (int r = 0; r < rows; ++r) {
        float* o = out->ptr<float>(y0 + r) + channel;
        for (int k = 0; k < n; ++k) o[k * out_step] = static_cast<float>(6.0 * c[static_cast<std::ptrdiff_t>(k) * kRows + r]);
      }
    }
  });
}

// The column pass over the row pass' output, in place: the row pass' recursion run down the
// image for a block of columns at a time, with no transposes. Each column's arithmetic is exactly
// the row pass's, in the same order, so the result is the same to the bit; it is twice as fast as
// transposing there and back. A block reads all its rows before it writes any, and blocks share
// no column, so the output can overwrite the input.
void ColumnPassInPlace(cv::Mat* coeffs) {
  const double z = std::sqrt(3.0) - 2.0;
  const int n = coeffs->rows, w = coeffs->cols;
  if (n < 2) return;
  const int horizon = std::min(n, 24);
  constexpr int kBlock = 64;  // columns per block: n x 64 doubles stay in a core's cache
  cv::parallel_for_(cv::Range(0, (w + kBlock - 1) / kBlock), [&](const cv::Range& blocks) {
    std::vector<double> c(static_cast<std::size_t>(n) * kBlock);
    for (int b = blocks.start; b < blocks.end; ++b) {
      const int x0 = b * kBlock, bw = std::min(kBlock, w - x0);
      auto row = [&](int y) { return c.data() + static_cast<std::size_t>(y) * kBlock; };
      double* first = row(0);
      std::fill(first, first + bw, 0.0);
      double zk = 1;
      for (int k = 0; k < horizon; ++k, zk *= z) {  // causal pass, mirror boundary
        const float* s = coeffs->ptr<float>(k) + x0;
        for (int i = 0; i < bw; ++i) first[i] += zk * s[i];
      }
      for (int y = 1; y < n; ++y) {
        const float* s = coeffs->ptr<float>(y) + x0;
        double* cy = row(y);
        const double* prev = row(y - 1);
        for (int i = 0; i < bw; ++i) cy[i] = s[i] + z * prev[i];
      }
      double* last = row(n - 1);
      const double* before_last = row(n - 2);
      for (int i = 0; i < bw; ++i) last[i] = (z / (z * z - 1)) * (last[i] + z * before_last[i]);
      for (int y = n - 2; y >= 0; --y) {
        double* cy = row(y);
        const double* next = row(y + 1);
        for (int i = 0; i < bw; ++i) cy[i] = z * (next[i] - cy[i]);
      }
      for (int y = 0; y < n; ++y) {
        float* o = coeffs->ptr<float>(y) + x0;
        const double* cy = row(y);
        for (int i = 0; i < bw; ++i) o[i] = static_cast<float>(6.0 * cy[i]);
      }
    }
  });
}

}  // namespace

cv::Mat BSplineCoefficientsAlongRows(const cv::Mat& image) {
  if (image.type() != CV_32FC1) throw Error("BSplineCoefficientsAlongRows: needs a CV_32FC1 image");
  cv::Mat out(image.size(), CV_32F);
  RowPass<float>(image, 0, &out);
  return out;
}

cv::Mat BSplineCoefficients2D(const cv::Mat& image) {
  cv::Mat out = BSplineCoefficientsAlongRows(image);
  ColumnPassInPlace(&out);
  return out;
}

#if CV_SIMD128_64F
namespace {

// BSplineWeights (bspline.hpp) for two positions at once, one per lane, each lane's arithmetic
// that function's, in its order.
inline void BSplineWeights2(const cv::v_float64x2& t, cv::v_float64x2 w[4]) {
  const cv::v_float64x2 t2 = t * t, t3 = t2 * t, u = cv::v_setall_f64(1.0) - t;
  const cv::v_float64x2 sixth = cv::v_setall_f64(1.0 / 6);
  w[0] = u * u * u * sixth;
  w[1] = (cv::v_setall_f64(3.0) * t3 - cv::v_setall_f64(6.0) * t2 + cv::v_setall_f64(4.0)) * sixth;
  w[2] = (cv::v_setall_f64(-3.0) * t3 + cv::v_setall_f64(3.0) * t2 + cv::v_setall_f64(3.0) * t + cv::v_setall_f64(1.0)) *
         sixth;
  w[3] = t3 * sixth;
}

}  // namespace
#endif

#ifdef HEDGEFIT_HAVE_AVX512_REMAP
// GCC 12 reports its own intrinsics' deliberately undefined lanes as "maybe uninitialized".
#pragma GCC diagnostic push
#if !defined(__clang__)  // clang (the fuzz build) has no such group and warns about the name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"
namespace {

// The helpers below are inlined into the AVX-512 kernel (a lambda would not take its target).
#define HEDGEFIT_AVX512 __attribute__((target("avx512f"), always_inline)) inline

// Permute indices: taps k and k+1 of pixel a (the first register) and b (the second), each tap as
// (c0, c1, c2, c2); the low 8 floats are tap k, the high 8 tap k+1.
HEDGEFIT_AVX512 __m512i Taps(int k) {
  return _mm512_setr_epi32(3 * k, 3 * k + 1, 3 * k + 2, 3 * k + 2, 16 + 3 * k, 17 + 3 * k, 18 + 3 * k, 18 + 3 * k,
                           3 * k + 3, 3 * k + 4, 3 * k + 5, 3 * k + 5, 19 + 3 * k, 20 + 3 * k, 21 + 3 * k, 21 + 3 * k);
}
// a in lanes 0-3, b in lanes 4-7.
HEDGEFIT_AVX512 __m512d Pair(double a, double b) {
  return _mm512_insertf64x4(_mm512_set1_pd(a), _mm256_set1_pd(b), 1);
}
// The low and high 8 floats of a register, as doubles.
HEDGEFIT_AVX512 __m512d WidenLow(__m512 v) { return _mm512_cvtps_pd(_mm512_castps512_ps256(v)); }
HEDGEFIT_AVX512 __m512d WidenHigh(__m512 v) {
  return _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1)));
}

// A colour row of RemapBSplineInto's output, two pixels at a time in one 512-bit register: lanes
// 0-3 hold the first pixel's channels (B, G, R and a copy of R), lanes 4-7 the second's. Each of a
// pixel's four coefficient rows is 12 floats in a run (four taps of three channels); two masked
// loads and a permute put a tap of both pixels into one register. Every lane does the one-pixel
// loop's arithmetic for its channel, operation for operation in the same order: the weights are
// BSplineWeights', the taps are summed left to right, the rows added to a sum that starts at 0,
// and this file is compiled without fused multiply-adds (stereo/CMakeLists.txt), so the output is
// the same to the bit (a test holds both paths against the per-channel reference). Returns the
// first column it did not do: pairs with a pixel off the source are left to the caller.
__attribute__((target("avx512f"))) int RemapColourPairsAvx512(const cv::Vec2f* m, int cols, int x0, int y0,
                                                              const cv::Mat& coeffs, std::uint8_t* o, int x) {
  const int cw = coeffs.cols, ch = coeffs.rows;
  const __m512i taps01 = Taps(0), taps23 = Taps(2);
  for (; x + 1 < cols; x += 2) {
    const double ua = m[x][0] - x0, va = m[x][1] - y0, ub = m[x + 1][0] - x0, vb = m[x + 1][1] - y0;
    const int iua = FloorInt(ua), iva = FloorInt(va), iub = FloorInt(ub), ivb = FloorInt(vb);
    if (!(iua >= 1 && iua + 2 < cw && iva >= 1 && iva + 2 < ch && iub >= 1 && iub + 2 < cw && ivb >= 1 &&
          ivb + 2 < ch)) {
      return x;
    }
    double wxa[4], wya[4], wxb[4], wyb[4];
    BSplineWeights(ua - iua, wxa, nullptr);
    BSplineWeights(va - iva, wya, nullptr);
    BSplineWeights(ub - iub, wxb, nullptr);
    BSplineWeights(vb - ivb, wyb, nullptr);
    const __m512d wx0 = Pair(wxa[0], wxb[0]), wx1 = Pair(wxa[1], wxb[1]), wx2 = Pair(wxa[2], wxb[2]),
                  wx3 = Pair(wxa[3], wxb[3]);
    __m512d acc = _mm512_setzero_pd();
    for (int j = 0; j < 4; ++j) {
      const __m512 ra = _mm512_maskz_loadu_ps(0x0fff, coeffs.ptr<float>(iva - 1 + j) + (iua - 1) * 3);
      const __m512 rb = _mm512_maskz_loadu_ps(0x0fff, coeffs.ptr<float>(ivb - 1 + j) + (iub - 1) * 3);
      const __m512 t01 = _mm512_permutex2var_ps(ra, taps01, rb), t23 = _mm512_permutex2var_ps(ra, taps23, rb);
      __m512d row = _mm512_mul_pd(wx0, WidenLow(t01));
      row = _mm512_add_pd(row, _mm512_mul_pd(wx1, WidenHigh(t01)));
      row = _mm512_add_pd(row, _mm512_mul_pd(wx2, WidenLow(t23)));
      row = _mm512_add_pd(row, _mm512_mul_pd(wx3, WidenHigh(t23)));
      acc = _mm512_add_pd(acc, _mm512_mul_pd(Pair(wya[j], wyb[j]), row));
    }
    alignas(64) double lanes[8];
    _mm512_store_pd(lanes, acc);
    for (int c = 0; c < 3; ++c) {
      o[x * 3 + c] = cv::saturate_cast<std::uint8_t>(lanes[c]);
      o[(x + 1) * 3 + c] = cv::saturate_cast<std::uint8_t>(lanes[4 + c]);
    }
  }
  return x;
}

#undef HEDGEFIT_AVX512

}  // namespace
#pragma GCC diagnostic pop
#endif

void ForcePortableRemap(bool portable) { g_force_portable_remap = portable; }

void RemapBSplineInto(const cv::Mat& source, const cv::Mat& map_xy, cv::Mat out) {
  if (source.depth() != CV_8U || (source.channels() != 1 && source.channels() != 3)) {
    throw Error("RemapBSpline: needs an 8-bit grey or BGR image");
  }
  if (map_xy.type() != CV_32FC2) throw Error("RemapBSpline: needs a CV_32FC2 map");
  if (out.size() != map_xy.size() || out.type() != source.type()) {
    throw Error("RemapBSplineInto: the output must be the map's size and the source's type");
  }
  const int channels = source.channels();
  if (map_xy.empty()) return;
  // Only the part of the source the map reaches (plus the prefilter's reach) is filtered.
  float x_lo = std::numeric_limits<float>::infinity(), x_hi = -x_lo, y_lo = x_lo, y_hi = -x_lo;
  for (int y = 0; y < map_xy.rows; ++y) {
    const cv::Vec2f* m = map_xy.ptr<cv::Vec2f>(y);
    for (int x = 0; x < map_xy.cols; ++x) {
      x_lo = std::min(x_lo, m[x][0]), x_hi = std::max(x_hi, m[x][0]);
      y_lo = std::min(y_lo, m[x][1]), y_hi = std::max(y_hi, m[x][1]);
    }
  }
  if (!(x_lo <= x_hi && y_lo <= y_hi) || !std::isfinite(x_hi - x_lo) || !std::isfinite(y_hi - y_lo)) {
    out.setTo(cv::Scalar::all(0));  // no position on any source
    return;
  }
  constexpr int kMargin = 16;  // |z|^16 ~ 1e-9: the crop's edges do not reach the samples
  const int x0 = std::clamp(static_cast<int>(std::floor(x_lo)) - kMargin, 0, source.cols - 1);
  const int y0 = std::clamp(static_cast<int>(std::floor(y_lo)) - kMargin, 0, source.rows - 1);
  const int x1 = std::clamp(static_cast<int>(std::ceil(x_hi)) + kMargin + 1, x0 + 1, source.cols);
  const int y1 = std::clamp(static_cast<int>(std::ceil(y_hi)) + kMargin + 1, y0 + 1, source.rows);
  const cv::Mat crop = source(cv::Rect(x0, y0, x1 - x0, y1 - y0));
  // One coefficient image, the channels interleaved as in the source: a pixel's 4 x 4 samples of
  // every channel then lie in 4 runs of 12 floats instead of 12 runs of 4.
  cv::Mat coeffs(crop.size(), CV_32FC(channels));
  for (int c = 0; c < channels; ++c) RowPass<std::uint8_t>(crop, c, &coeffs);  // straight from the 8-bit crop
  cv::Mat columns = coeffs.reshape(1);  // the column pass is per column: each channel's columns in turn
  ColumnPassInPlace(&columns);
  const int cw = crop.cols, ch = crop.rows;
  auto inside = [&](int iu, int iv) { return iu >= 1 && iu + 2 < cw && iv >= 1 && iv + 2 < ch; };
#ifdef HEDGEFIT_HAVE_AVX512_REMAP
  const bool avx512 = channels == 3 && !g_force_portable_remap && __builtin_cpu_supports("avx512f");
#endif
  cv::parallel_for_(cv::Range(0, map_xy.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const cv::Vec2f* m = map_xy.ptr<cv::Vec2f>(y);
      std::uint8_t* o = out.ptr<std::uint8_t>(y);
      auto one = [&](int x) {  // one pixel
        const double u = m[x][0] - x0, v = m[x][1] - y0;
        const int iu = FloorInt(u), iv = FloorInt(v);
        if (!inside(iu, iv)) {
          for (int c = 0; c < channels; ++c) o[x * channels + c] = 0;
          return;
        }
        double wx[4], wy[4];
        BSplineWeights(u - iu, wx, nullptr);
        BSplineWeights(v - iv, wy, nullptr);
        for (int c = 0; c < channels; ++c) {
          double acc = 0;
          for (int j = 0; j < 4; ++j) {
            const float* row = coeffs.ptr<float>(iv - 1 + j) + (iu - 1) * channels + c;
            acc += wy[j] * (wx[0] * row[0] + wx[1] * row[channels] + wx[2] * row[2 * channels] + wx[3] * row[3 * channels]);
          }
          o[x * channels + c] = cv::saturate_cast<std::uint8_t>(acc);
        }
      };
      int x = 0;
#ifdef HEDGEFIT_HAVE_AVX512_REMAP
      if (avx512) {
        while (x + 1 < map_xy.cols) {
          x = RemapColourPairsAvx512(m, map_xy.cols, x0, y0, coeffs, o, x);
          if (x + 1 < map_xy.cols) one(x++);  // a pair with a pixel off the source
        }
      }
#endif
#if CV_SIMD128_64F
      // Two output pixels at a time, one in each lane of a pair of doubles: every lane does the
      // one-pixel arithmetic above, operation for operation in the same order (no fused
      // multiply-adds, which baseline x86-64 does not have), so the output is the same to the bit
      // (a test holds it against that loop); the sums are dependent chains, and two lanes halve
      // the instructions on them. A pair with a pixel off the source goes one pixel at a time.
      while (x + 1 < map_xy.cols) {
        const double ua = m[x][0] - x0, va = m[x][1] - y0, ub = m[x + 1][0] - x0, vb = m[x + 1][1] - y0;
        const int iua = FloorInt(ua), iva = FloorInt(va), iub = FloorInt(ub), ivb = FloorInt(vb);
        if (!inside(iua, iva) || !inside(iub, ivb)) {
          one(x++);
          continue;
        }
        cv::v_float64x2 wx[4], wy[4];
        BSplineWeights2(cv::v_float64x2(ua - iua, ub - iub), wx);
        BSplineWeights2(cv::v_float64x2(va - iva, vb - ivb), wy);
        for (int c = 0; c < channels; ++c) {
          cv::v_float64x2 acc = cv::v_setzero_f64();
          for (int j = 0; j < 4; ++j) {
            const float* ra = coeffs.ptr<float>(iva - 1 + j) + (iua - 1) * channels + c;
            const float* rb = coeffs.ptr<float>(ivb - 1 + j) + (iub - 1) * channels + c;
            const int s1 = channels, s2 = 2 * channels, s3 = 3 * channels;
            const cv::v_float64x2 row = wx[0] * cv::v_float64x2(ra[0], rb[0]) + wx[1] * cv::v_float64x2(ra[s1], rb[s1]) +
                                        wx[2] * cv::v_float64x2(ra[s2], rb[s2]) + wx[3] * cv::v_float64x2(ra[s3], rb[s3]);
            acc = acc + wy[j] * row;
          }
          double lanes[2];
          cv::v_store(lanes, acc);
          o[x * channels + c] = cv::saturate_cast<std::uint8_t>(lanes[0]);
          o[(x + 1) * channels + c] = cv::saturate_cast<std::uint8_t>(lanes[1]);
        }
        x += 2;
      }
#endif
      for (; x < map_xy.cols; ++x) one(x);
    }
  });
}

cv::Mat RemapBSpline(const cv::Mat& source, const cv::Mat& map_xy) {
  cv::Mat out(map_xy.size(), source.type());
  RemapBSplineInto(source, map_xy, out);
  return out;
}

}  // namespace hedgefit::stereo
