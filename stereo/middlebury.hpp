#pragma once
/// Middlebury ground truth: PFM disparity maps and the bad-N error statistic.

#include <opencv2/core.hpp>
#include <string>

namespace hedgefit::stereo {

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

}  // namespace hedgefit::stereo
