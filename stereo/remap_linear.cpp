#include "stereo/remap_linear.hpp"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HEDGEFIT_HAVE_AVX512_LINEAR 1
#endif

#include <algorithm>
#include <array>
#include <cstdint>

namespace hedgefit::stereo {

namespace {

bool g_force_portable = false;

// OpenCV's bilinear weights for fixed-point maps (imgwarp.cpp, initInterTab2D): entry 32 fy + fx
// holds the four corners' weights (top-left, top-right, bottom-left, bottom-right) of the fraction
// (fx, fy) / 32, in units of 2^-15. Every product of the 1-D weights is a whole number of units, so
// each entry is exact, save one: at (0, 0) the top-left's 32768 saturates to a short's 32767 and
// OpenCV's correction of the sum puts the missing unit on the bottom-right corner.
struct WeightTable {
  std::array<std::array<std::int32_t, 4>, 1024> w;
  WeightTable() {
    for (int fy = 0; fy < 32; ++fy) {
      for (int fx = 0; fx < 32; ++fx) {
        w[std::size_t(fy * 32 + fx)] = {(32 - fx) * (32 - fy) * 32, fx * (32 - fy) * 32, (32 - fx) * fy * 32,
                                        fx * fy * 32};
      }
    }
    w[0] = {32767, 0, 0, 1};
  }
};

const WeightTable& Weights() {
  static const WeightTable table;
  return table;
}

// One pixel as remapBilinear's border branch works it out (its inner branch gives the same where
// all four corners are in the source): each corner in the source adds its value times its weight,
// a corner outside adds the border's 0; then (sum + 2^14) >> 15, saturated to 8 bits.
inline void RemapPixel(const cv::Mat& source, int sx, int sy, unsigned fxy, std::uint8_t* out) {
  const int cn = source.channels();
  const auto& w = Weights().w[fxy & 1023u];
  const int xs[4] = {sx, sx + 1, sx, sx + 1}, ys[4] = {sy, sy, sy + 1, sy + 1};
  for (int c = 0; c < cn; ++c) {
    int sum = 0;
    for (int k = 0; k < 4; ++k) {
      if (xs[k] >= 0 && xs[k] < source.cols && ys[k] >= 0 && ys[k] < source.rows) {
        sum += int(source.ptr<std::uint8_t>(ys[k])[xs[k] * cn + c]) * w[std::size_t(k)];
      }
    }
    out[c] = cv::saturate_cast<std::uint8_t>((sum + (1 << 14)) >> 15);
  }
}

#ifdef HEDGEFIT_HAVE_AVX512_LINEAR
// GCC 12 reports its own intrinsics' deliberately undefined lanes as "maybe uninitialized".
#pragma GCC diagnostic push
#if !defined(__clang__)  // clang (the fuzz build) has no such group and warns about the name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"
// The weight pairs of 16 fractions (the fraction word's low 10 bits: 32 fy + fx), as the table's
// entries: top-left | top-right << 16 in `top`, bottom-left | bottom-right << 16 in `bottom`, for
// _mm512_madd_epi16 against pairs of neighbouring pixels' values. (32 - fx) (32 - fy) 32 fits a
// short but at (0, 0), whose entry is the table's own.
__attribute__((target("avx512f,avx512bw"), always_inline)) inline void WeightPairs(__m512i f, __m512i* top,
                                                                                     __m512i* bottom) {
  const __m512i fx = _mm512_and_si512(f, _mm512_set1_epi32(31)), fy = _mm512_srli_epi32(f, 5);
  const __m512i left_right = _mm512_or_si512(_mm512_sub_epi32(_mm512_set1_epi32(32), fx), _mm512_slli_epi32(fx, 16));
  *top = _mm512_mullo_epi32(left_right, _mm512_slli_epi32(_mm512_sub_epi32(_mm512_set1_epi32(32), fy), 5));
  *bottom = _mm512_mullo_epi32(left_right, _mm512_slli_epi32(fy, 5));
  const __mmask16 whole = _mm512_cmpeq_epi32_mask(f, _mm512_setzero_si512());
  *top = _mm512_mask_mov_epi32(*top, whole, _mm512_set1_epi32(32767));
  *bottom = _mm512_mask_mov_epi32(*bottom, whole, _mm512_set1_epi32(1 << 16));
}

// Channel c of 16 pixels added into `result` (byte c of each lane): the top pairs (pixel, right
// neighbour) and the bottom pairs, each as two shorts a lane, against their weight pairs; the
// rounded sum is 0-255 already (the weights sum to 2^15 and every value is 0-255).
__attribute__((target("avx512f,avx512bw"), always_inline)) inline __m512i AddChannel(__m512i result, int c, __m512i top,
                                                                                      __m512i bottom, __m512i wt,
                                                                                      __m512i wb) {
  const __m512i sum = _mm512_add_epi32(_mm512_add_epi32(_mm512_madd_epi16(top, wt), _mm512_madd_epi16(bottom, wb)),
                                       _mm512_set1_epi32(1 << 14));
  return _mm512_or_si512(result, _mm512_slli_epi32(_mm512_srai_epi32(sum, 15), 8 * c));
}

// 16 pixels of an 8-bit colour row at once, from column x; returns the first column not done (a
// run of 16 with a pixel whose four corners are not all in the source is left to RemapPixel, as
// are the last columns). A channel's two top values (the pixel's and its right neighbour's) go
// into one 32-bit lane as two shorts, and one madd with the lane's top weight pair gives both
// products summed; the bottom row likewise; integer sums, so the same bits as RemapPixel.
// A rectification's run of 16 mostly reads one source row pair within 20 columns: then each
// source row's 64 bytes from the run's first corner are loaded once (masked at the row's end) and
// the values are picked from them by byte permutes. Otherwise each pixel's corner is gathered as
// 4 bytes from its first byte (B, G, R of it and B of its right neighbour) and 4 from its third
// (R of it and the neighbour's B, G, R), so that no read passes the neighbour's last byte.
__attribute__((target("avx512f,avx512bw,avx512vbmi"))) int ColourRowAvx512(const cv::Mat& source, const short* xy,
                                                                            const std::uint16_t* fxy, int cols,
                                                                            std::uint8_t* out) {
  const std::uint8_t* base = source.ptr<std::uint8_t>(0);
  const int step = int(source.step[0]);
  const __m512i step_v = _mm512_set1_epi32(step), three = _mm512_set1_epi32(3);
  const __m512i x_end = _mm512_set1_epi32(source.cols - 1), y_end = _mm512_set1_epi32(source.rows - 1);
  const __m512i byte = _mm512_set1_epi32(0xff), fraction = _mm512_set1_epi32(1023);
  const __m512i span = _mm512_set1_epi32(20);
  const __mmask64 low_bytes = 0x5555555555555555ull;  // bytes 0 and 2 of every lane: two shorts
  // Each 128-bit lane's four pixels' B, G, R packed to 12 bytes, then the 12 words of 16 pixels.
  const __m512i pack = _mm512_broadcast_i32x4(_mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1));
  const __m512i words = _mm512_setr_epi32(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, 0, 0, 0, 0);
  int x = 0;
  for (; x + 16 <= cols; x += 16) {
    const __m512i both = _mm512_loadu_si512(xy + 2 * x);
    const __m512i sx = _mm512_srai_epi32(_mm512_slli_epi32(both, 16), 16), sy = _mm512_srai_epi32(both, 16);
    // All four corners inside: 0 <= sx < cols - 1 and 0 <= sy < rows - 1 (unsigned: a negative fails).
    if (__mmask16(_mm512_cmplt_epu32_mask(sx, x_end) & _mm512_cmplt_epu32_mask(sy, y_end)) != 0xffff) return x;
    __m512i wt, wb;
    WeightPairs(_mm512_and_si512(_mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(fxy + x))),
                                 fraction),
                &wt, &wb);
    const int sx0 = xy[2 * x], sy0 = xy[2 * x + 1];
    const __m512i dx = _mm512_sub_epi32(sx, _mm512_set1_epi32(sx0));
    __m512i result = _mm512_setzero_si512();
    if (_mm512_cmpeq_epi32_mask(sy, _mm512_set1_epi32(sy0)) == 0xffff && _mm512_cmplt_epu32_mask(dx, span) == 0xffff) {
      // One row pair; every corner's bytes within 64 of the first's: (dx + 1) 3 + 2 < 64.
      const int left = (source.cols - sx0) * 3;  // bytes from the first corner to the row's end
      const __mmask64 in_row = left >= 64 ? ~__mmask64(0) : (__mmask64(1) << left) - 1;
      const std::uint8_t* p = base + std::ptrdiff_t(sy0) * step + std::ptrdiff_t(sx0) * 3;
      const __m512i row0 = _mm512_maskz_loadu_epi8(in_row, p), row1 = _mm512_maskz_loadu_epi8(in_row, p + step);
      // Byte 0 of each lane: the pixel's channel; byte 2: its right neighbour's (3 bytes on).
      const __m512i at = _mm512_mullo_epi32(dx, three);
      const __m512i pick = _mm512_or_si512(at, _mm512_slli_epi32(_mm512_add_epi32(at, three), 16));
      for (int c = 0; c < 3; ++c) {
        const __m512i idx = _mm512_add_epi32(pick, _mm512_set1_epi32(c | (c << 16)));
        const __m512i top = _mm512_maskz_permutexvar_epi8(low_bytes, idx, row0);
        const __m512i bottom = _mm512_maskz_permutexvar_epi8(low_bytes, idx, row1);
        result = AddChannel(result, c, top, bottom, wt, wb);
      }
    } else {
      const __m512i at = _mm512_add_epi32(_mm512_mullo_epi32(sy, step_v), _mm512_mullo_epi32(sx, three));
      const __m512i below = _mm512_add_epi32(at, step_v);
      const __m512i t0 = _mm512_i32gather_epi32(at, base, 1), t2 = _mm512_i32gather_epi32(at, base + 2, 1);
      const __m512i b0 = _mm512_i32gather_epi32(below, base, 1), b2 = _mm512_i32gather_epi32(below, base + 2, 1);
      for (int c = 0; c < 3; ++c) {
        // Channel c of the pixel: byte c of the first gather; of its right neighbour: byte c + 1 of
        // the second.
        const __m512i top =
            _mm512_or_si512(_mm512_and_si512(_mm512_srli_epi32(t0, 8 * c), byte),
                            _mm512_slli_epi32(_mm512_and_si512(_mm512_srli_epi32(t2, 8 * (c + 1)), byte), 16));
        const __m512i bottom =
            _mm512_or_si512(_mm512_and_si512(_mm512_srli_epi32(b0, 8 * c), byte),
                            _mm512_slli_epi32(_mm512_and_si512(_mm512_srli_epi32(b2, 8 * (c + 1)), byte), 16));
        result = AddChannel(result, c, top, bottom, wt, wb);
      }
    }
    const __m512i packed = _mm512_permutexvar_epi32(words, _mm512_shuffle_epi8(result, pack));
    _mm512_mask_storeu_epi32(out + 3 * x, 0x0fff, packed);
  }
  return x;
}

#pragma GCC diagnostic pop

bool HasAvx512() {
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
         __builtin_cpu_supports("avx512vbmi");
}
#endif

}  // namespace

void ForcePortableLinearRemap(bool portable) { g_force_portable = portable; }

void RemapLinearFixed(const cv::Mat& source, const cv::Mat& map1, const cv::Mat& map2, cv::Mat* out) {
  bool fast = false;
#ifdef HEDGEFIT_HAVE_AVX512_LINEAR
  // Offsets into the source are 32-bit.
  fast = !g_force_portable && source.type() == CV_8UC3 && map1.type() == CV_16SC2 && map2.type() == CV_16UC1 &&
         map1.size() == map2.size() && !source.empty() && source.data != out->data &&
         double(source.step[0]) * source.rows < 2e9 && HasAvx512();
#endif
  if (!fast) {
    cv::remap(source, *out, map1, map2, cv::INTER_LINEAR);
    return;
  }
#ifdef HEDGEFIT_HAVE_AVX512_LINEAR
  out->create(map1.size(), source.type());
  cv::parallel_for_(
      cv::Range(0, map1.rows),
      [&](const cv::Range& rows) {
        for (int y = rows.start; y < rows.end; ++y) {
          const short* xy = map1.ptr<short>(y);
          const std::uint16_t* fxy = map2.ptr<std::uint16_t>(y);
          std::uint8_t* o = out->ptr<std::uint8_t>(y);
          int x = 0;
          while (x < map1.cols) {
            x += ColourRowAvx512(source, xy + 2 * x, fxy + x, map1.cols - x, o + 3 * x);
            // A run with a corner off the source (or the row's last columns): pixel by pixel up to
            // the next 16.
            const int stop = std::min(map1.cols, x + 16);
            for (; x < stop; ++x) RemapPixel(source, xy[2 * x], xy[2 * x + 1], fxy[x], o + 3 * x);
          }
        }
      },
      double(map1.total()) / double(1 << 16));
#endif
}

}  // namespace hedgefit::stereo
