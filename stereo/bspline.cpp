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
#include <cstring>
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

#ifdef HEDGEFIT_HAVE_AVX512_REMAP
// An 8 x 8 block of doubles transposed in registers: v[r] lane i becomes v[i] lane r (three rounds
// of two-register permutes, swapping blocks of 1, 2 and 4 lanes).
__attribute__((target("avx512f"), always_inline)) inline void Transpose8(__m512d v[8]) {
  const __m512i lo1 = _mm512_setr_epi64(0, 8, 2, 10, 4, 12, 6, 14), hi1 = _mm512_setr_epi64(1, 9, 3, 11, 5, 13, 7, 15);
  const __m512i lo2 = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13), hi2 = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
  const __m512i lo4 = _mm512_setr_epi64(0, 1, 2, 3, 8, 9, 10, 11), hi4 = _mm512_setr_epi64(4, 5, 6, 7, 12, 13, 14, 15);
  __m512d a[8], b[8];
  for (int k = 0; k < 8; k += 2) {  // a[k]: rows k, k+1 at columns 0, 2, 4, 6; a[k+1]: at 1, 3, 5, 7
    a[k] = _mm512_permutex2var_pd(v[k], lo1, v[k + 1]);
    a[k + 1] = _mm512_permutex2var_pd(v[k], hi1, v[k + 1]);
  }
  for (int h = 0; h < 8; h += 4) {  // rows h .. h+3: b[h + j] holds columns j and j + 4
    b[h + 0] = _mm512_permutex2var_pd(a[h], lo2, a[h + 2]);
    b[h + 2] = _mm512_permutex2var_pd(a[h], hi2, a[h + 2]);
    b[h + 1] = _mm512_permutex2var_pd(a[h + 1], lo2, a[h + 3]);
    b[h + 3] = _mm512_permutex2var_pd(a[h + 1], hi2, a[h + 3]);
  }
  for (int j = 0; j < 4; ++j) {
    v[j] = _mm512_permutex2var_pd(b[j], lo4, b[4 + j]);
    v[j + 4] = _mm512_permutex2var_pd(b[j], hi4, b[4 + j]);
  }
}

// GCC 12 reports its own intrinsics' deliberately undefined lanes as "maybe uninitialized".
#pragma GCC diagnostic push
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"
// 8 samples of a row as doubles: 8-bit or float, each the value RowPass reads.
__attribute__((target("avx512f"), always_inline)) inline __m512d Load8(const std::uint8_t* p) {
  return _mm512_cvtepi32_pd(_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
}
__attribute__((target("avx512f"), always_inline)) inline __m512d Load8(const float* p) {
  return _mm512_cvtps_pd(_mm256_loadu_ps(p));
}

// RowPass of all the channels of an image at once (8-bit colour or grey, or float grey), 8 rows to
// a group: one register holds a channel's coefficient k of the 8 rows, so each step of the
// recursion is one instruction for 8 rows, and a colour image's three channels are three
// independent chains (where RowPass runs four rows of one channel in scalar code, a channel at a
// time). Each row and channel does RowPass' arithmetic, operation for operation in its order (no
// fused multiply-adds in this file), so the coefficients are the same to the bit. The rows go into
// the registers through a buffer, k-major, by 8 x 8 transposes. One group of 8 rows (a lambda would
// not take the target, so RowPassAvx512 runs the groups).
template <typename T, int kChannels>
__attribute__((target("avx512f"))) void RowGroupAvx512(const cv::Mat& image, int g, double* c, cv::Mat* out) {
  constexpr int kRows = 8, C = kChannels;
  const double z = std::sqrt(3.0) - 2.0;  // the cubic spline's pole
  const int n = image.cols, horizon = std::min(n, 24);
  // c[(k * C + channel) * kRows + r]: row r's sample, then its coefficient, k
  auto at = [c](int k, int channel) { return c + (static_cast<std::ptrdiff_t>(k) * C + channel) * kRows; };
  const int y0 = g * kRows, rows = std::min(kRows, image.rows - y0);
  const T* s[kRows];
  for (int r = 0; r < kRows; ++r) s[r] = image.ptr<T>(y0 + std::min(r, rows - 1));  // spare lanes repeat a row
  int i = 0;
  for (; i + 8 <= C * n; i += 8) {  // 8 samples of 8 rows, transposed
    __m512d v[kRows];
    for (int r = 0; r < kRows; ++r) {
      v[r] = Load8(s[r] + i);
    }
    Transpose8(v);
    for (int j = 0; j < 8; ++j) _mm512_storeu_pd(c + static_cast<std::ptrdiff_t>(i + j) * kRows, v[j]);
  }
  for (; i < C * n; ++i) {
    for (int r = 0; r < kRows; ++r) c[static_cast<std::ptrdiff_t>(i) * kRows + r] = s[r][i];
  }
  const __m512d vz = _mm512_set1_pd(z);
  __m512d prev[C];
  for (int ch = 0; ch < C; ++ch) prev[ch] = _mm512_setzero_pd();
  double zk = 1;
  for (int k = 0; k < horizon; ++k, zk *= z) {  // causal pass, mirror boundary
    const __m512d vzk = _mm512_set1_pd(zk);
    for (int ch = 0; ch < C; ++ch) prev[ch] = _mm512_add_pd(prev[ch], _mm512_mul_pd(vzk, _mm512_loadu_pd(at(k, ch))));
  }
  for (int ch = 0; ch < C; ++ch) _mm512_storeu_pd(at(0, ch), prev[ch]);
  for (int k = 1; k < n; ++k) {
    for (int ch = 0; ch < C; ++ch) {
      prev[ch] = _mm512_add_pd(_mm512_loadu_pd(at(k, ch)), _mm512_mul_pd(vz, prev[ch]));
      _mm512_storeu_pd(at(k, ch), prev[ch]);
    }
  }
  const __m512d edge = _mm512_set1_pd(z / (z * z - 1));
  for (int ch = 0; ch < C; ++ch) {
    prev[ch] = _mm512_mul_pd(edge, _mm512_add_pd(prev[ch], _mm512_mul_pd(vz, _mm512_loadu_pd(at(n - 2, ch)))));
    _mm512_storeu_pd(at(n - 1, ch), prev[ch]);
  }
  for (int k = n - 2; k >= 0; --k) {
    for (int ch = 0; ch < C; ++ch) {
      prev[ch] = _mm512_mul_pd(vz, _mm512_sub_pd(prev[ch], _mm512_loadu_pd(at(k, ch))));
      _mm512_storeu_pd(at(k, ch), prev[ch]);
    }
  }
  const __m512d six = _mm512_set1_pd(6.0);
  float* o[kRows];
  for (int r = 0; r < kRows; ++r) o[r] = out->ptr<float>(y0 + std::min(r, rows - 1));
  for (i = 0; i + 8 <= C * n; i += 8) {  // back, 8 coefficients of 8 rows at a time
    __m512d v[kRows];
    for (int j = 0; j < 8; ++j) v[j] = _mm512_mul_pd(six, _mm512_loadu_pd(c + static_cast<std::ptrdiff_t>(i + j) * kRows));
    Transpose8(v);
    for (int r = 0; r < rows; ++r) _mm256_storeu_ps(o[r] + i, _mm512_cvtpd_ps(v[r]));
  }
  alignas(32) float lanes[kRows];
  for (; i < C * n; ++i) {
    _mm256_store_ps(lanes, _mm512_cvtpd_ps(_mm512_mul_pd(six, _mm512_loadu_pd(c + static_cast<std::ptrdiff_t>(i) * kRows))));
    for (int r = 0; r < rows; ++r) o[r][i] = lanes[r];
  }
}
#pragma GCC diagnostic pop

// RowPass of every channel of `image` (8-bit with 1 or 3 channels, or CV_32FC1) into `out`, 8 rows
// at a time: RowGroupAvx512's bits, which are RowPass'. False where this CPU or image has no such
// path (the caller runs RowPass).
bool RowPassAvx512(const cv::Mat& image, cv::Mat* out) {
  if (g_force_portable_remap || image.cols < 2 || !__builtin_cpu_supports("avx512f")) return false;
  void (*group)(const cv::Mat&, int, double*, cv::Mat*) = nullptr;
  if (image.type() == CV_8UC3) group = RowGroupAvx512<std::uint8_t, 3>;
  if (image.type() == CV_8UC1) group = RowGroupAvx512<std::uint8_t, 1>;
  if (image.type() == CV_32FC1) group = RowGroupAvx512<float, 1>;
  if (!group) return false;
  constexpr int kRows = 8;
  cv::parallel_for_(cv::Range(0, (image.rows + kRows - 1) / kRows), [&](const cv::Range& range) {
    std::vector<double> buffer(static_cast<std::size_t>(image.cols) * image.channels() * kRows);
    for (int g = range.start; g < range.end; ++g) group(image, g, buffer.data(), out);
  });
  return true;
}
#else
bool RowPassAvx512(const cv::Mat&, cv::Mat*) { return false; }
#endif

// One block of the column pass (columns x0 .. x0 + bw of `coeffs`, `c` n x kColumnBlock doubles of
// scratch): the row pass' recursion run down the image. Each column's arithmetic is exactly the
// row pass's, in the same order, and columns never mix, so the result is the same to the bit at
// any vector width: the body is compiled twice, for baseline x86-64 (SSE2, 2 columns an
// instruction) and for AVX-512 (GCC vectorises it with 4- and 8-double registers), and
// ColumnPassInPlace picks one at run time.
constexpr int kColumnBlock = 32;  // columns per block: n x 32 doubles stay in cache (faster than 16, 64, 128)
__attribute__((always_inline)) inline void ColumnBlock(cv::Mat* coeffs, int x0, int bw, double* c) {
  const double z = std::sqrt(3.0) - 2.0;
  const int n = coeffs->rows, horizon = std::min(n, 24);
  auto row = [&](int y) { return c + static_cast<std::size_t>(y) * kColumnBlock; };
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
void ColumnBlockPortable(cv::Mat* coeffs, int x0, int bw, double* c) { ColumnBlock(coeffs, x0, bw, c); }
#ifdef HEDGEFIT_HAVE_AVX512_REMAP
__attribute__((target("avx512f"))) void ColumnBlockAvx512(cv::Mat* coeffs, int x0, int bw, double* c) {
  ColumnBlock(coeffs, x0, bw, c);
}
#endif

// The column pass over the row pass' output, in place, a block of columns at a time with no
// transposes (twice as fast as transposing there and back). A block reads all its rows before it
// writes any, and blocks share no column, so the output can overwrite the input.
void ColumnPassInPlace(cv::Mat* coeffs) {
  const int n = coeffs->rows, w = coeffs->cols;
  if (n < 2) return;
  void (*block)(cv::Mat*, int, int, double*) = ColumnBlockPortable;
#ifdef HEDGEFIT_HAVE_AVX512_REMAP
  if (!g_force_portable_remap && __builtin_cpu_supports("avx512f")) block = ColumnBlockAvx512;
#endif
  cv::parallel_for_(cv::Range(0, (w + kColumnBlock - 1) / kColumnBlock), [&](const cv::Range& blocks) {
    std::vector<double> c(static_cast<std::size_t>(n) * kColumnBlock);
    for (int b = blocks.start; b < blocks.end; ++b) {
      const int x0 = b * kColumnBlock;
      block(coeffs, x0, std::min(kColumnBlock, w - x0), c.data());
    }
  });
}

}  // namespace

cv::Mat BSplineCoefficientsAlongRows(const cv::Mat& image) {
  if (image.type() != CV_32FC1) throw Error("BSplineCoefficientsAlongRows: needs a CV_32FC1 image");
  cv::Mat out(image.size(), CV_32F);
  if (!RowPassAvx512(image, &out)) RowPass<float>(image, 0, &out);
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
// The low and high 8 floats of a register, as doubles.
HEDGEFIT_AVX512 __m512d WidenLow(__m512 v) { return _mm512_cvtps_pd(_mm512_castps512_ps256(v)); }
HEDGEFIT_AVX512 __m512d WidenHigh(__m512 v) {
  return _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1)));
}

// The cubic B-spline weights of 8 positions at once, one per lane: BSplineWeights' arithmetic,
// operation for operation in its order.
HEDGEFIT_AVX512 void Weights8(__m512d t, __m512d w[4]) {
  const __m512d t2 = _mm512_mul_pd(t, t), t3 = _mm512_mul_pd(t2, t), u = _mm512_sub_pd(_mm512_set1_pd(1.0), t);
  const __m512d sixth = _mm512_set1_pd(1.0 / 6), three = _mm512_set1_pd(3.0);
  w[0] = _mm512_mul_pd(_mm512_mul_pd(_mm512_mul_pd(u, u), u), sixth);
  w[1] = _mm512_mul_pd(
      _mm512_add_pd(_mm512_sub_pd(_mm512_mul_pd(three, t3), _mm512_mul_pd(_mm512_set1_pd(6.0), t2)), _mm512_set1_pd(4.0)),
      sixth);
  w[2] = _mm512_mul_pd(_mm512_add_pd(_mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(-3.0), t3),
                                                                 _mm512_mul_pd(three, t2)),
                                                   _mm512_mul_pd(three, t)),
                                     _mm512_set1_pd(1.0)),
                       sixth);
  w[3] = _mm512_mul_pd(t3, sixth);
}

// A colour row of RemapBSplineInto's output, 8 pixels at a time. The 8 positions, their floors and
// their weights are worked out in one register each; then two pixels share a 512-bit register:
// lanes 0-3 hold the first pixel's channels (B, G, R and a copy of R), lanes 4-7 the second's, and
// a permute spreads each pixel's weight over its four lanes. Each of a pixel's four coefficient rows
// is 12 floats in a run (four taps of three channels); two masked loads and a permute put a tap of
// both pixels into one register. Every lane does the one-pixel loop's arithmetic for its channel,
// operation for operation in the same order: the position is the map's float less the crop's
// corner, in float, then widened; the weights are BSplineWeights'; the taps are summed left to
// right, the rows added to a sum that starts at 0; the sum is rounded to the nearest (ties to even,
// as cvRound) and clamped to 0-255, as cv::saturate_cast. This file is compiled without fused
// multiply-adds (stereo/CMakeLists.txt), so the output is the same to the bit (a test holds both
// paths against the per-channel reference). Returns the first column it did not do: a run of 8
// with a pixel off the source, or fewer than 8 left, is the caller's.
__attribute__((target("avx512f"))) int RemapColourOctetsAvx512(const cv::Vec2f* m, int cols, int x0, int y0,
                                                               const cv::Mat& coeffs, std::uint8_t* o, int x) {
  const float* base = coeffs.ptr<float>(0);
  const std::ptrdiff_t stride = static_cast<std::ptrdiff_t>(coeffs.step1());  // floats a row
  const __m512i taps01 = Taps(0), taps23 = Taps(2);
  const float fx0 = static_cast<float>(x0), fy0 = static_cast<float>(y0);
  const __m512 corner = _mm512_setr_ps(fx0, fy0, fx0, fy0, fx0, fy0, fx0, fy0, fx0, fy0, fx0, fy0, fx0, fy0, fx0, fy0);
  const __m512i split = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 1, 3, 5, 7, 9, 11, 13, 15);  // u's, then v's
  const __m256i zero8 = _mm256_setzero_si256(), u_end = _mm256_set1_epi32(coeffs.cols - 2),
                v_end = _mm256_set1_epi32(coeffs.rows - 2);
  const __m128i keep = _mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1);  // drop the copies of R
  for (; x + 8 <= cols; x += 8) {
    const __m512 uv = _mm512_permutexvar_ps(split, _mm512_sub_ps(_mm512_loadu_ps(&m[x][0]), corner));
    const __m512d u = WidenLow(uv), v = WidenHigh(uv);
    const __m512d fu = _mm512_roundscale_pd(u, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    const __m512d fv = _mm512_roundscale_pd(v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    const __m256i iu = _mm512_cvttpd_epi32(fu), iv = _mm512_cvttpd_epi32(fv);
    // Inside as the one-pixel loop's test: 1 <= iu and iu + 2 < cols, the same for iv (a position
    // off every int, NaN included, converts to INT_MIN and fails it).
    const __m256i in = _mm256_and_si256(_mm256_and_si256(_mm256_cmpgt_epi32(iu, zero8), _mm256_cmpgt_epi32(u_end, iu)),
                                        _mm256_and_si256(_mm256_cmpgt_epi32(iv, zero8), _mm256_cmpgt_epi32(v_end, iv)));
    if (_mm256_movemask_epi8(in) != -1) return x;
    alignas(32) int ius[8], ivs[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(ius), iu);
    _mm256_store_si256(reinterpret_cast<__m256i*>(ivs), iv);
    __m512d wx[4], wy[4];
    Weights8(_mm512_sub_pd(u, fu), wx);
    Weights8(_mm512_sub_pd(v, fv), wy);
    __m256i sums[4];
    for (int p = 0; p < 4; ++p) {
      const __m512i spread = _mm512_setr_epi64(2 * p, 2 * p, 2 * p, 2 * p, 2 * p + 1, 2 * p + 1, 2 * p + 1, 2 * p + 1);
      const __m512d wx0 = _mm512_permutexvar_pd(spread, wx[0]), wx1 = _mm512_permutexvar_pd(spread, wx[1]),
                    wx2 = _mm512_permutexvar_pd(spread, wx[2]), wx3 = _mm512_permutexvar_pd(spread, wx[3]);
      const float* pa = base + (ivs[2 * p] - 1) * stride + (ius[2 * p] - 1) * 3;
      const float* pb = base + (ivs[2 * p + 1] - 1) * stride + (ius[2 * p + 1] - 1) * 3;
      __m512d acc = _mm512_setzero_pd();
      for (int j = 0; j < 4; ++j) {
        const __m512 ra = _mm512_maskz_loadu_ps(0x0fff, pa + j * stride);
        const __m512 rb = _mm512_maskz_loadu_ps(0x0fff, pb + j * stride);
        const __m512 t01 = _mm512_permutex2var_ps(ra, taps01, rb), t23 = _mm512_permutex2var_ps(ra, taps23, rb);
        __m512d row = _mm512_mul_pd(wx0, WidenLow(t01));
        row = _mm512_add_pd(row, _mm512_mul_pd(wx1, WidenHigh(t01)));
        row = _mm512_add_pd(row, _mm512_mul_pd(wx2, WidenLow(t23)));
        row = _mm512_add_pd(row, _mm512_mul_pd(wx3, WidenHigh(t23)));
        acc = _mm512_add_pd(acc, _mm512_mul_pd(_mm512_permutexvar_pd(spread, wy[j]), row));
      }
      sums[p] = _mm512_cvtpd_epi32(acc);  // rounded as the MXCSR says (to nearest, ties to even), as cvRound
    }
    std::uint8_t* out = o + static_cast<std::ptrdiff_t>(x) * 3;
    for (int h = 0; h < 2; ++h) {  // pixels x + 4h .. x + 4h + 3: 12 bytes
      const __m512i both = _mm512_inserti64x4(_mm512_castsi256_si512(sums[2 * h]), sums[2 * h + 1], 1);
      const __m128i bytes =
          _mm_shuffle_epi8(_mm512_cvtusepi32_epi8(_mm512_max_epi32(both, _mm512_setzero_si512())), keep);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(out + 12 * h), bytes);
      const int tail = _mm_extract_epi32(bytes, 2);
      std::memcpy(out + 12 * h + 8, &tail, 4);
    }
  }
  return x;
}

// The least and greatest x and y of a map's columns 0 .. 8k - 1 of every row (k as many as fit),
// folded into the four bounds; returns 8k, the first column left to the caller. Min and max are
// exact and ignore NaN as the scalar loop's std::min and std::max do (a NaN position is the first
// operand, which _mm512_min_ps passes over), so the bounds are the scalar loop's.
__attribute__((target("avx512f"))) int MapBoundsAvx512(const cv::Mat& map_xy, float* x_lo, float* x_hi, float* y_lo,
                                                       float* y_hi) {
  const int whole = map_xy.cols / 8 * 8;
  const __m512 inf = _mm512_set1_ps(std::numeric_limits<float>::infinity());
  __m512 lo = inf, hi = _mm512_sub_ps(_mm512_setzero_ps(), inf);  // lanes alternate x, y
  for (int y = 0; y < map_xy.rows; ++y) {
    const float* m = map_xy.ptr<float>(y);
    for (int x = 0; x < whole; x += 8) {
      const __m512 v = _mm512_loadu_ps(m + 2 * x);
      lo = _mm512_min_ps(v, lo);
      hi = _mm512_max_ps(v, hi);
    }
  }
  alignas(64) float l[16], h[16];
  _mm512_store_ps(l, lo);
  _mm512_store_ps(h, hi);
  for (int k = 0; k < 16; k += 2) {
    *x_lo = std::min(*x_lo, l[k]), *x_hi = std::max(*x_hi, h[k]);
    *y_lo = std::min(*y_lo, l[k + 1]), *y_hi = std::max(*y_hi, h[k + 1]);
  }
  return whole;
}

#undef HEDGEFIT_AVX512

}  // namespace
#pragma GCC diagnostic pop
#endif

namespace {

// The least and greatest x and y a map holds (NaN passed over; +-infinity when there is none).
void MapBounds(const cv::Mat& map_xy, float* x_lo, float* x_hi, float* y_lo, float* y_hi) {
  *x_lo = *y_lo = std::numeric_limits<float>::infinity();
  *x_hi = *y_hi = -std::numeric_limits<float>::infinity();
  int from = 0;  // the first column the scalar loop below takes
#ifdef HEDGEFIT_HAVE_AVX512_REMAP
  if (!g_force_portable_remap && __builtin_cpu_supports("avx512f")) from = MapBoundsAvx512(map_xy, x_lo, x_hi, y_lo, y_hi);
#endif
  for (int y = 0; y < map_xy.rows; ++y) {
    const cv::Vec2f* m = map_xy.ptr<cv::Vec2f>(y);
    for (int x = from; x < map_xy.cols; ++x) {
      *x_lo = std::min(*x_lo, m[x][0]), *x_hi = std::max(*x_hi, m[x][0]);
      *y_lo = std::min(*y_lo, m[x][1]), *y_hi = std::max(*y_hi, m[x][1]);
    }
  }
}

}  // namespace

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
  float x_lo, x_hi, y_lo, y_hi;
  MapBounds(map_xy, &x_lo, &x_hi, &y_lo, &y_hi);
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
  if (!RowPassAvx512(crop, &coeffs)) {
    for (int c = 0; c < channels; ++c) RowPass<std::uint8_t>(crop, c, &coeffs);  // straight from the 8-bit crop
  }
#ifdef HEDGEFIT_HAVE_AVX512_REMAP
  const bool avx512 = channels == 3 && !g_force_portable_remap && __builtin_cpu_supports("avx512f");
#endif
  cv::Mat columns = coeffs.reshape(1);  // the column pass is per column: each channel's columns in turn
  ColumnPassInPlace(&columns);
  const int cw = crop.cols, ch = crop.rows;
  auto inside = [&](int iu, int iv) { return iu >= 1 && iu + 2 < cw && iv >= 1 && iv + 2 < ch; };
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
        while (x + 8 <= map_xy.cols) {
          x = RemapColourOctetsAvx512(m, map_xy.cols, x0, y0, coeffs, o, x);
          if (x + 8 <= map_xy.cols) {  // a run of 8 with a pixel off the source
            for (const int end = x + 8; x < end; ++x) one(x);
          }
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
