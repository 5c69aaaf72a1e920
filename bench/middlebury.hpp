#pragma once
/// Middlebury ground truth: PFM disparity maps and the bad-N error statistic.

#include <opencv2/core.hpp>
#include <string>

namespace hedgefit::bench {

/// Reads a PFM file (grey, float32, either endianness; rows stored bottom to top) into a
/// CV_32F image, top row first. Throws hedgefit::Error naming the file.
cv::Mat ReadPfm(const std::string& path);

struct BadPixelScore {
  double bad_percent = 0;      ///< |d - truth| > threshold, or no disparity, in % of scored pixels
  double density_percent = 0;  ///< scored pixels with a disparity, %
  long scored = 0;             ///< pixels with finite truth inside the mask
};

/// Scores `disparity` (CV_32F, NaN = none) against `truth` (CV_32F, inf = unknown) on the
/// pixels where `mask` is non-zero (empty mask = everywhere). Holes count as bad.
BadPixelScore ScoreDisparity(const cv::Mat& disparity, const cv::Mat& truth, const cv::Mat& mask, double threshold_px);

/// A rectified pair with ground-truth disparity, as shipped in data/stereo_gt.
struct TruthPair {
  std::string name;
  cv::Mat left, right;  ///< 8-bit BGR or grey
  cv::Mat truth;        ///< CV_32F px, left view; +inf where unknown
  cv::Mat mask;         ///< CV_8U: non-occluded pixels with known truth
  int num_disparities = 0;  ///< search range covering the truth, multiple of 16
  double truth_step = 0;    ///< quantisation of the stored truth (px); 0 = float truth
};

/// Loads one of the pairs under `data_dir`/stereo_gt: "motorcycle" (Middlebury 2014, quarter
/// size, PFM truth, non-occluded mask), "aloe" (Middlebury 2006, JPEG, 8-bit integer truth,
/// 0 unknown; no occlusion mask, so the mask is the known truth) or "cones" (Middlebury 2003
/// via CNES Pandora, float truth on a 1/4 px grid, occlusion mask). Throws hedgefit::Error
/// naming the file that cannot be read.
TruthPair LoadTruthPair(const std::string& data_dir, const std::string& name);

/// Truth without its storage quantisation: where the stored truth in the (2r+1)^2 window
/// is known everywhere, holds at least two stored values (a window of one value only says
/// the truth lies within half a step) and a least-squares plane explains it to within 3/4 of a
/// step at every pixel (half a step of rounding, a quarter of slack for the fit), the plane's value at the centre replaces the stored one (a slanted
/// planar surface rounded to the grid); elsewhere the stored value stays, and `planar`
/// (optional, CV_8U) is 0.
/// With step 0 the truth is returned unchanged and every known pixel counts as planar.
cv::Mat DequantiseTruth(const cv::Mat& truth, double step, int radius, cv::Mat* planar = nullptr);

/// How far a truth sits from the disparity its own views agree on, with no matcher involved.
struct TruthOffset {
  double offset_px = 0;  ///< the views agree best under truth + offset_px
  double rms_at_zero = 0, rms_at_offset = 0;  ///< the views' photometric residual (grey levels)
  long pixels = 0;       ///< pixels judged; 0 = too few to say
};

/// Holds the truth's own surface fixed and frees one number: the offset o that minimises, over
/// the pixels whose whole (2 radius + 1)^2 window has a known `planar` truth, the squared
/// difference between the left view and the right view read at x - truth(x, y) - o (cubic
/// B-splines along the rows), both less their (2 radius + 1)^2 mean (so an exposure offset
/// between the cameras does not matter). Searched on a 0.05 px grid over +-1 px and refined by a
/// parabola. A truth that describes its views reads 0 to within a few hundredths of a pixel
/// (Middlebury 2014 Motorcycle, 2003 Cones); a truth stored with a convention of its own (a shift,
/// a rounding that is not to the nearest) reads that shift, which every correct matcher also shows
/// against it. `truth` is usually DequantiseTruth's output. Fewer than 1000 such pixels: 0.
TruthOffset TruthOffsetFromViews(const cv::Mat& left, const cv::Mat& right, const cv::Mat& truth, const cv::Mat& planar,
                                 int radius = 2);

}  // namespace hedgefit::bench
