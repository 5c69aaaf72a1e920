#pragma once
/// From a stereo capture to a point cloud, as the paper does it: rectify, segment the
/// hedge (excess green), match with the improved SGBM over the hedge's region only, and
/// reproject to 3-D in the unrectified left camera frame (mm).

#include <opencv2/core.hpp>
#include <string>

#include "cloud/point_cloud.hpp"
#include "stereo/matching.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

struct SegmentOptions {
  double gamma = 1.5;             ///< y = (x + esp)^gamma on the excess-green value in [0, 1]
  double esp = 0.0;               ///< offset added before the gamma
  int bilateral_diameter = 9;     ///< px; 0 = no bilateral filter
  double bilateral_sigma_color = 0.1;  ///< in excess-green units ([0, 1])
  double bilateral_sigma_space = 5.0;  ///< px
  bool largest_component = true;  ///< keep only the largest region
  bool fill_holes = true;         ///< fill holes inside it
  int erode_px = 5;               ///< drop this many silhouette pixels (least reliable disparity);
                                  ///< also applied to a user mask
  void Check() const;
};

/// The paper's hedge mask: ExG = 2G - R - B, bilateral filter, gamma, Otsu; CV_8U 0/255.
cv::Mat SegmentHedge(const cv::Mat& bgr, const SegmentOptions& options);

/// Fills the holes of a mask: background regions not connected to the image border.
cv::Mat FillHoles(const cv::Mat& mask);

/// Segmentation by depth, for images without colour: inside `box` (rectified left image),
/// the region of disparities within `tolerance_px` of the median over the box's middle
/// third, connected and holes filled, then eroded by `erode_px`. Throws hedgefit::Error
/// ("no hedge found: ...") when the middle of the box has no disparity.
cv::Mat SegmentByDepth(const cv::Mat& disparity, const cv::Rect& box, double tolerance_px, int erode_px);

/// The bounding box, in the rectified left image, of a box drawn on the original left image.
cv::Rect RectifiedBox(const StereoRig& rig, const cv::Rect& box);

/// Drops `px` pixels from a mask's outline (elliptical structuring element); 0 = as is.
/// The outermost ring of a silhouette mixes hedge and background in both views, and the
/// sub-pixel refinement's windows must not reach it.
cv::Mat ErodeMask(const cv::Mat& mask, int px);

/// Undistorts and rectifies a pair with the rig's R1/P1 and R2/P2 (bilinear; the maps are
/// cached per rig).
void RectifyPair(const StereoRig& rig, const cv::Mat& left, const cv::Mat& right, cv::Mat* left_rect,
                 cv::Mat* right_rect);

/// Re-renders `roi` of already rectified images with cubic B-spline resampling, whose
/// sub-pixel phase error is far below bilinear's (see bspline.hpp).
void RectifyRegionPrecisely(const StereoRig& rig, const cv::Mat& left, const cv::Mat& right, const cv::Rect& roi,
                            cv::Mat* left_rect, cv::Mat* right_rect);

struct ReprojectOptions {
  bool organized = false;          ///< keep the image grid (NaN where no point)
  bool extra_fields = true;        ///< add "disparity" and "sigma_z" fields per point
  double sigma_disparity_px = 0.2; ///< disparity noise for sigma_z = Z^2 sigma_d / (f b) where the
                                   ///< refinement gave no per-pixel estimate
  bool keep_filled = false;        ///< also reproject hole-filled (unmeasured) disparities
};

/// Disparity (rectified left, CV_32F, NaN = none) to points in the unrectified left camera
/// frame (mm, R1 transposed applied), coloured from `left_rect`, only where `mask` is set.
/// `disparity_sigma` (optional, CV_32F px, NaN = unknown): each pixel's own disparity
/// standard deviation (from the refinement) for its `sigma_z`.
cloud::PointCloud Reproject(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& left_rect,
                            const StereoRig& rig, const ReprojectOptions& options,
                            const cv::Mat& disparity_sigma = cv::Mat());

struct ConvertOptions {
  SegmentOptions segment;
  SgbmOptions sgbm;                ///< min/num disparities are set from the working range
  ReprojectOptions reproject;
  double min_z_mm = 1500;          ///< working range: sets the disparity search
  double max_z_mm = 3500;
  bool region_only = true;         ///< match only the mask's bounding box (plus margin)
  int margin_px = 24;              ///< around the mask's bounding box
  bool precise_resampling = true;  ///< B-spline rectification of the matched region
  std::string mask_path;           ///< a user-supplied mask (left image) instead of segmentation
  cv::Rect box;                    ///< non-empty: segment by depth inside this box (original left
                                   ///< image, px) instead of by colour; for grey images
  double depth_tolerance_px = 1.0; ///< with `box`: disparity band around the box's middle
  void Check() const;
};

struct ConvertResult {
  cloud::PointCloud cloud;
  cv::Mat left_rect, right_rect, mask, disparity;  ///< for debug images
  cv::Mat filled;                  ///< CV_8U, 255 where the disparity was filled, not measured
  cv::Mat disparity_sigma;         ///< CV_32F px, the refinement's standard deviation; NaN = none
  cv::Rect matched_region;         ///< in the rectified left image
  double matched_fraction = 1.0;   ///< matched area / full image area
  double wall_ms = 0;
  struct {
    double rectify = 0;    ///< bilinear full frame + B-spline matched region
    double segment = 0;
    double match = 0;      ///< SGBM, right matcher, left-right check, refinement, filling
    double reproject = 0;
  } stage_ms;
};

/// The whole capture-to-cloud path. Throws hedgefit::Error (e.g. "no hedge found").
ConvertResult ConvertCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig,
                             const ConvertOptions& options);

/// The region SGBM needs for the mask's pixels: its bounding box plus `margin_px`, widened
/// to the left by the disparity reach so every masked pixel gets a full search.
cv::Rect MatchRegion(const cv::Mat& mask, const SgbmOptions& sgbm, int margin_px);

/// Colourised disparity and mask overlay, for debug PNGs.
cv::Mat ColorizeDisparity(const cv::Mat& disparity);
cv::Mat MaskOverlay(const cv::Mat& bgr, const cv::Mat& mask);

}  // namespace hedgefit::stereo
