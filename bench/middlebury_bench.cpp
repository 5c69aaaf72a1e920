// Matching quality and time on three real pairs with ground-truth disparity, in one run:
// Middlebury 2014 Motorcycle (quarter size, float truth), Middlebury 2006 Aloe (a plant, JPEG,
// integer truth) and Middlebury 2003 Cones (truth on a 1/4 px grid). Matchers: stock OpenCV
// SGBM MODE_HH (the paper's matcher) and MODE_SGBM_3WAY, the paper's improvements (LRC,
// background filling, bilateral), and hedgefit's matcher without and with its sub-pixel
// refinement. All on the whole frame, with the same search range and thread count.
//
// Scores on the non-occluded pixels with known truth:
//  - bad-2.0, bad-1.0, bad-0.5: |d - truth| above the threshold, holes counted as bad
//    (Middlebury's measure, against the truth as stored);
//  - sub-px: mean |error| of the measured (not rejected, not filled) pixels within 1 px of
//    the truth, i.e. where matching found the right surface and only the sub-pixel part is
//    judged. A truth stored on a grid (Aloe: 1 px, Cones: 1/4 px) carries its own rounding
//    error of up to half a step, which would reward an estimate snapped to whole pixels; so
//    sub-px and locking are judged against the de-quantised truth (DequantiseTruth: a local
//    5x5 plane that explains the stored values to within half a step) on the pixels where
//    such a plane exists. "sub-px stored" is the same against the truth as stored;
//  - locking: the largest mean signed error over 8 bins of the truth's fractional part
//    (SGBM's parabola pulls estimates to whole pixels);
//  - bad-0.5 dq: bad-0.5 against the de-quantised truth on the pixels where it exists (a truth
//    stored in whole pixels, as Aloe's, makes bad-0.5 score its own rounding: an estimate
//    pixel-locked to the stored integer looks right);
//  - b0.5 +off: bad-0.5 against the truth as stored plus the pair's truth offset (below);
//  - measured %: share of the scored pixels with a matched (not filled) disparity.
// Each pair's truth offset, printed above its table, is how far the truth sits from the
// disparity its own views agree on, with no matcher involved (TruthOffsetFromViews: the
// de-quantised truth's surface held fixed, one offset freed). A truth that describes its views
// reads a few hundredths of a pixel; a shifted one reads its shift, and bad-0.5 against it
// then favours a matcher that errs by the same shift.
// The pair's residual vertical disparity, as hedgefit's matcher estimates and removes it before
// its refinement, is printed under each pair's table.
// Usage: bench_middlebury [--repeats N] [--pairs motorcycle,aloe,cones] [--refine-radius N]
//        (data: $HEDGEFIT_DATA_DIR or ../shared/data)

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/bench_util.hpp"
#include "pipeline/error.hpp"
#include "stereo/matching.hpp"
#include "bench/middlebury.hpp"

namespace {

using namespace hedgefit::stereo;
using namespace hedgefit::bench;

struct SubpixelScore {
  double mean_abs = 0, mean_abs_stored = 0, bias = 0, spread = 0, locking = 0, measured_percent = 0;
};

SubpixelScore ScoreSubpixel(const DisparityMap& m, const TruthPair& p, const cv::Mat& fine, const cv::Mat& planar) {
  double sum = 0, sum_stored = 0, sum_signed = 0;
  std::vector<float> errors;
  long n = 0, n_stored = 0, measured = 0, scored = 0;
  double bin_sum[8] = {0}, bin_n[8] = {0};
  for (int y = 0; y < p.truth.rows; ++y) {
    for (int x = 0; x < p.truth.cols; ++x) {
      const float t = p.truth.at<float>(y, x);
      if (!p.mask.at<std::uint8_t>(y, x) || !std::isfinite(t)) continue;
      ++scored;
      const float d = m.disparity.at<float>(y, x);
      if (!std::isfinite(d) || m.rejected.at<std::uint8_t>(y, x)) continue;
      ++measured;
      if (std::abs(d - t) < 1.0) sum_stored += std::abs(d - t), ++n_stored;
      if (!planar.at<std::uint8_t>(y, x)) continue;
      const float tf = fine.at<float>(y, x);
      if (std::abs(d - tf) < 1.0) {
        sum += std::abs(d - tf), sum_signed += d - tf, ++n;
        errors.push_back(d - tf);
        const int bin = std::min(7, static_cast<int>((tf - std::floor(tf)) * 8));
        bin_sum[bin] += d - tf, bin_n[bin] += 1;
      }
    }
  }
  SubpixelScore s;
  s.mean_abs = sum / double(std::max(1L, n));
  s.mean_abs_stored = sum_stored / double(std::max(1L, n_stored));
  s.bias = sum_signed / double(std::max(1L, n));
  for (const float e : errors) s.spread += std::abs(e - s.bias);
  s.spread /= double(std::max<std::size_t>(1, errors.size()));
  for (int k = 0; k < 8; ++k) s.locking = std::max(s.locking, std::abs(bin_sum[k] / std::max(1.0, bin_n[k])));
  s.measured_percent = 100.0 * double(measured) / double(std::max(1L, scored));
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 3;
  std::string pairs = "motorcycle,aloe,cones";
  int refine_radius = hedgefit::stereo::SgbmOptions().refine_radius;
  const int done = hedgefit::bench::ParseOptionPairs(
      argc, argv, "bench_middlebury", "[--repeats N] [--pairs a,b,c] [--refine-radius N]",
      [&](const std::string& a, const char* v) {
        if (a == "--repeats") repeats = std::max(1, std::atoi(v));
        else if (a == "--pairs") pairs = v;
        else if (a == "--refine-radius") refine_radius = std::max(1, std::atoi(v));
        else return false;
        return true;
      });
  if (done >= 0) return done;
  const char* env = std::getenv("HEDGEFIT_DATA_DIR");
  const std::string data = env ? env : HEDGEFIT_DEFAULT_DATA_DIR;
  std::printf("hedgefit bench_middlebury: %u hardware threads, median of %d runs; whole frame, search range from the truth\n",
              std::thread::hardware_concurrency(), repeats);
  std::stringstream list(pairs);
  for (std::string name; std::getline(list, name, ',');) {
    TruthPair p;
    try {
      p = LoadTruthPair(data, name);
    } catch (const hedgefit::Error& e) {
      std::fprintf(stderr, "bench_middlebury: %s (set HEDGEFIT_DATA_DIR)\n", e.what());
      return 1;
    }
    cv::Mat planar;
    const cv::Mat fine = DequantiseTruth(p.truth, p.truth_step, 2, &planar);
    const double planar_share = 100.0 * cv::countNonZero(planar & p.mask) / std::max(1, cv::countNonZero(p.mask));
    std::printf("\n%s: %dx%d, %d disparities, truth step %.2f px, %.0f %% of the scored pixels with a planar truth\n",
                p.name.c_str(), p.left.cols, p.left.rows, p.num_disparities, p.truth_step, planar_share);
    const TruthOffset offset = TruthOffsetFromViews(p.left, p.right, fine, planar);
    std::printf("truth offset: the views agree best under the truth %+.3f px (photometric rms %.2f -> %.2f grey levels, "
                "%ld pixels)\n",
                offset.offset_px, offset.rms_at_zero, offset.rms_at_offset, offset.pixels);
    const cv::Mat truth_offset = p.truth + offset.offset_px;  // inf stays inf
    std::printf("%-44s %7s %7s %7s %7s %9s %7s %8s %7s %7s %7s %9s %6s\n", "matcher", "bad-2.0", "bad-1.0", "bad-0.5",
                "b0.5 dq", "b0.5 +off", "sub-px", "sub-px*", "bias", "spread", "locking", "measured", "ms");
    SgbmOptions ours;
    ours.num_disparities = p.num_disparities;
    ours.refine_radius = refine_radius;
    // A dense map: a pixel the refinement cannot settle keeps SGBM's value. The capture path
    // drops it instead (it only leaves a hole in the cloud); that is the last row.
    ours.refine_drop_uncertain = false;
    SgbmOptions dropping = ours;
    dropping.refine_drop_uncertain = true;
    SgbmOptions stock = ours;  // SGBM alone: no check, no filling, no refinement
    stock.lrc_tolerance_px = -1;
    stock.fill_holes = false;
    stock.refine_radius = 0;
    SgbmOptions stock3 = stock;
    stock3.mode = SgbmMode::kSgbm3Way;
    SgbmOptions unrefined = ours;
    unrefined.refine_radius = 0;
    SgbmOptions along_rows = ours;  // the refinement without the vertical correction
    along_rows.correct_vertical = false;
    SgbmOptions paper = unrefined;  // the paper's improvements: check, filling, bilateral
    paper.bilateral_sigma_disp = 1.5;
    const cv::Mat planar_scored = planar & p.mask;
    VerticalDisparity vertical;
    auto row = [&](const char* label, const SgbmOptions& o) {
      DisparityMap m;
      const double ms = hedgefit::bench::MedianMs(repeats, [&] { m = ComputeDisparity(p.left, p.right, o); });
      const BadPixelScore b2 = ScoreDisparity(m.disparity, p.truth, p.mask, 2.0);
      const BadPixelScore b1 = ScoreDisparity(m.disparity, p.truth, p.mask, 1.0);
      const BadPixelScore b05 = ScoreDisparity(m.disparity, p.truth, p.mask, 0.5);
      const BadPixelScore b05_fine = ScoreDisparity(m.disparity, fine, planar_scored, 0.5);
      const BadPixelScore b05_offset = ScoreDisparity(m.disparity, truth_offset, p.mask, 0.5);
      const SubpixelScore s = ScoreSubpixel(m, p, fine, planar);
      std::printf("%-44s %6.1f%% %6.1f%% %6.1f%% %6.1f%% %8.1f%% %7.3f %8.3f %+7.3f %7.3f %7.3f %8.1f%% %6.0f\n", label,
                  b2.bad_percent, b1.bad_percent, b05.bad_percent, b05_fine.bad_percent, b05_offset.bad_percent,
                  s.mean_abs, s.mean_abs_stored,
                  s.bias, s.spread, s.locking, s.measured_percent, ms);
      if (m.vertical.samples > 0) vertical = m.vertical;
    };
    row("stock OpenCV SGBM HH", stock);
    row("stock OpenCV SGBM 3-way", stock3);
    row("paper: HH + LRC, filling, bilateral", paper);
    row("hedgefit without refinement (HH, LRC, fill)", unrefined);
    row("hedgefit, refined along the rows as they are", along_rows);
    row("hedgefit (HH, LRC, fill, sub-pixel refinement)", ours);
    row("hedgefit, uncertain pixels dropped (clouds)", dropping);
    std::printf("residual vertical disparity (right row - left row): %+.3f px at the centre, %+.3f across, %+.3f down "
                "(%d windows)%s\n",
                vertical.offset_px, vertical.slope_x_px, vertical.slope_y_px, vertical.samples,
                vertical.applied ? "; removed before the refinement" : "; below correct_vertical_min, left alone");
  }
  std::printf("\nsub-px: against the de-quantised truth on planar pixels; sub-px*: against the truth as stored\n");
  return 0;
}
