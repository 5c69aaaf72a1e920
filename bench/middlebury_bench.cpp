// Matching quality and time on Middlebury 2014 Motorcycle (quarter size, real images with
// ground-truth disparity): stock OpenCV SGBM MODE_HH (the paper's matcher) beside
// hedgefit's improved matcher, with and without its sub-pixel refinement, in one run.
// Scores on the non-occluded mask, holes counted as bad: bad-2.0 (the measure),
// bad-1.0, bad-0.5, and the mean |error| of the measured pixels within 1 px of the truth
// (sub-pixel accuracy where the right surface was found), and pixel-locking: the largest
// mean signed error over 8 bins of the truth's fractional part.
// Usage: bench_middlebury [--repeats N]   (data: $HEDGEFIT_DATA_DIR or ../shared/data)

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "bench/bench_util.hpp"
#include "stereo/matching.hpp"
#include "stereo/middlebury.hpp"

int main(int argc, char** argv) {
  using namespace hedgefit::stereo;
  int repeats = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--repeats") repeats = std::atoi(argv[i + 1]);
  }
  const char* data = std::getenv("HEDGEFIT_DATA_DIR");
  const std::string dir = std::string(data ? data : HEDGEFIT_DEFAULT_DATA_DIR) + "/stereo_gt/middlebury2014_motorcycle_Q/";
  const cv::Mat l = cv::imread(dir + "im0.png"), r = cv::imread(dir + "im1.png");
  if (l.empty() || r.empty()) {
    std::fprintf(stderr, "bench_middlebury: %sim0.png: cannot read; set HEDGEFIT_DATA_DIR\n", dir.c_str());
    return 1;
  }
  const cv::Mat mask = cv::imread(dir + "mask0nocc.png", cv::IMREAD_GRAYSCALE) == 255;
  const cv::Mat truth = ReadPfm(dir + "disp0GT.pfm");

  SgbmOptions ours;
  ours.num_disparities = 80;  // ndisp = 70 in calib.txt
  SgbmOptions stock = ours;   // SGBM HH alone: no check, no filling, no refinement
  stock.lrc_tolerance_px = -1;
  stock.fill_holes = false;
  stock.refine_radius = 0;
  SgbmOptions unrefined = ours;
  unrefined.refine_radius = 0;
  SgbmOptions paper = unrefined;  // the paper's improvements: check, filling, bilateral
  paper.bilateral_sigma_disp = 1.5;

  std::printf("Middlebury 2014 Motorcycle (quarter size, %dx%d), non-occluded pixels, holes are bad; median of %d runs\n",
              l.cols, l.rows, repeats);
  std::printf("%-46s %7s %7s %7s %8s %8s %8s %7s\n", "matcher", "bad-2.0", "bad-1.0", "bad-0.5", "|e|<1px", "locking",
              "dense %", "ms");
  auto row = [&](const char* name, const SgbmOptions& o) {
    DisparityMap m;
    const double ms = hedgefit::bench::MedianMs(repeats, [&] { m = ComputeDisparity(l, r, o); });
    const BadPixelScore b2 = ScoreDisparity(m.disparity, truth, mask, 2.0);
    const BadPixelScore b1 = ScoreDisparity(m.disparity, truth, mask, 1.0);
    const BadPixelScore b05 = ScoreDisparity(m.disparity, truth, mask, 0.5);
    // Sub-pixel accuracy: mean |error| over the measured (not filled) pixels within 1 px of
    // the truth, where matching found the right surface and only the sub-pixel part differs.
    double sum = 0;
    long n = 0;
    // Pixel-locking: the mean signed error as a function of the truth's fractional part
    // (8 bins); SGBM's parabola pulls estimates to whole pixels, so this swings +-.
    double bin_sum[8] = {0}, bin_n[8] = {0};
    for (int y = 0; y < truth.rows; ++y) {
      for (int x = 0; x < truth.cols; ++x) {
        const float t = truth.at<float>(y, x), d = m.disparity.at<float>(y, x);
        if (!mask.at<std::uint8_t>(y, x) || !std::isfinite(t) || !std::isfinite(d) || m.rejected.at<std::uint8_t>(y, x)) {
          continue;
        }
        if (std::abs(d - t) < 1.0) {
          sum += std::abs(d - t), ++n;
          const int bin = std::min(7, static_cast<int>((t - std::floor(t)) * 8));
          bin_sum[bin] += d - t, bin_n[bin] += 1;
        }
      }
    }
    double locking = 0;
    for (int k = 0; k < 8; ++k) locking = std::max(locking, std::abs(bin_sum[k] / std::max(1.0, bin_n[k])));
    std::printf("%-46s %6.1f%% %6.1f%% %6.1f%% %8.3f %8.3f %8.1f %7.0f\n", name, b2.bad_percent, b1.bad_percent,
                b05.bad_percent, sum / double(std::max(1L, n)), locking, b2.density_percent, ms);
  };
  row("stock OpenCV SGBM HH", stock);
  row("+ LRC, background filling, bilateral (paper)", paper);
  row("+ LRC, background filling (no refinement)", unrefined);
  row("hedgefit: + LRC, filling, sub-pixel refinement", ours);
  return 0;
}
