#pragma once
/// Disparities to 3-D points in the unrectified left camera frame (mm), with per-point
/// disparity and depth uncertainty.

#include <opencv2/core.hpp>

#include "pipeline/option_table.hpp"
#include "cloud/point_cloud.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

struct ReprojectOptions {
  bool organized = false;          ///< keep the image grid (NaN where no point)
  bool extra_fields = true;        ///< add "disparity", "sigma_z", "pixel_mm" (Z / f), "pixel_u" and "pixel_v" fields per point
  double sigma_disparity_px = 0.2; ///< disparity noise for sigma_z = Z^2 sigma_d / (f b) where the
                                   ///< refinement gave no per-pixel estimate
  bool keep_filled = false;        ///< also reproject hole-filled (unmeasured) disparities
  void Check() const;
  static const pipeline::OptionTable<ReprojectOptions>& Table();  ///< the options, declared once
};

/// Disparity (rectified left, CV_32F, NaN = none) to points in the unrectified left camera
/// frame (mm, R1 transposed applied), coloured from `left_rect`, only where `mask` is set.
/// `disparity_sigma` (optional, CV_32F px, NaN = unknown): each pixel's own disparity
/// standard deviation (from the refinement) for its `sigma_z`. `hedge_labels` (optional,
/// CV_32S, hedge id per pixel, 0 = none) adds a "hedge_id" field, so the stages after can
/// split the cloud by hedge.
cloud::PointCloud Reproject(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& left_rect,
                            const StereoRig& rig, const ReprojectOptions& options,
                            const cv::Mat& disparity_sigma = cv::Mat(), const cv::Mat& hedge_labels = cv::Mat());

/// Reproject() over the mask less the `filled` pixels (unless options.keep_filled): what both
/// `convert` and the stereo.reproject stage write. `region` (optional): where the disparity can be
/// finite (stereo.sgbm's `matched_region`; NaN everywhere outside it); an unorganized cloud is read
/// over it only, and is the same cloud.
cloud::PointCloud ReprojectMeasured(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& filled,
                                    const cv::Mat& left_rect, const StereoRig& rig, const ReprojectOptions& options,
                                    const cv::Mat& disparity_sigma = cv::Mat(),
                                    const cv::Mat& hedge_labels = cv::Mat(), const cv::Rect& region = cv::Rect());

}  // namespace hedgefit::stereo
