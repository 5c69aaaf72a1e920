#pragma once
/// Finding the hedge in the rectified left image. Three modes, each a stage:
///  - colour (stereo.segment): the paper's excess green, bilateral, gamma, Otsu;
///  - a user's mask (stereo.mask), drawn on the original left image;
///  - depth inside a box (stereo.segment_depth), for grey images or green backgrounds.

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "pipeline/option_table.hpp"
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
  /// Drop this many silhouette pixels (least reliable disparity): SGBM's 5 x 5 block straddles
  /// the outline by up to 2 px, plus a pixel for the mask's own edge. The pixels just inside
  /// that are the ones a sphere fit needs most (their radial error is small, and they separate
  /// the radius from the centre's depth): ransac_geometric on the lab, real camera, mean |AER| /
  /// LD calibrated, at 3 / 5 px: hedgefit's renderer 0.90 / 0.91 against 0.89 / 1.06 mm, POV-Ray's
  /// 0.53 / 1.73 against 0.61 / 1.79 mm (exact rig 0.90 / 1.04 against 0.93 / 1.13 and 0.63 / 0.79
  /// against 0.72 / 0.89 mm); 2 px and less let the outline's errors in, 7 px and more are worse
  /// on both. (hedgefit's ideal lab alone prefers 5: 0.24 / 0.27 against 0.31 / 0.30 mm.)
  int erode_px = 3;
  /// Pixels whose 2G - R - B is below this are never hedge, whatever Otsu decides: Otsu always
  /// splits the image in two, and with a small hedge before a grey wall and brown soil it can
  /// split soil from wall instead of hedge from the rest.
  double green_floor = 20.0;
  /// The hedge found at half size first (the bilateral filter on a quarter of the pixels, the
  /// split and the range from there), then the full-size pixels decided only in a box about it:
  /// the filter's values there are the full frame's, and only the split, from the half-size
  /// histogram, may differ by a level. On a 1920 x 1200 lab capture 55 against 12 ms.
  bool coarse = true;
  void Check() const;
  static const pipeline::OptionTable<SegmentOptions>& Table();  ///< the options, declared once
};

/// The paper's hedge mask: ExG = 2G - R - B, bilateral filter, gamma, Otsu; CV_8U 0/255.
/// Throws hedgefit::Error ("no hedge found: ...") when the selected region is empty, not green
/// (mean 2G - R - B under 5 levels) or more than 95 % of the frame.
cv::Mat SegmentHedge(const cv::Mat& bgr, const SegmentOptions& options);

struct MaskOptions {
  std::string filename;  ///< mask image (0 = background, > 127 = hedge), drawn on the original left image
  int erode_px = 3;      ///< drop this many silhouette pixels; as the colour mask's (SegmentOptions)
  void Check() const;
  static const pipeline::OptionTable<MaskOptions>& Table();  ///< the options, declared once
};

/// A user's mask: read, checked against the rig's image size, rectified and eroded.
cv::Mat SegmentFromMaskFile(const StereoRig& rig, const MaskOptions& options);

struct DepthSegmentOptions {
  std::vector<double> box;         ///< [X, Y, W, H] px in the original left image; required
  double tolerance_px = 1.0;       ///< disparity band around the box middle's median
  /// Drop this many silhouette pixels. 5, not the colour mask's 3: this mask is SGBM's own
  /// outline, which a depth edge fattens by up to half the coarse match's block (2 px), on top
  /// of what the colour mask's 3 allow for (the garden's depth mask adds that margin itself).
  int erode_px = 5;
  double min_z_mm = kDefaultMinZmm;  ///< working range, nearest: sets the coarse match's search
  double max_z_mm = kDefaultMaxZmm;  ///< working range, farthest
  int margin_px = 24;              ///< matched around the box
  int block_size = 5;              ///< the coarse match's block, px
  bool precise_resampling = true;  ///< B-spline rectification of the matched box
  void Check() const;
  static const pipeline::OptionTable<DepthSegmentOptions>& Table();  ///< the options, declared once
};

/// Segmentation by depth: matches the box's region coarsely (no refinement, no filling), then
/// keeps the connected region within `tolerance_px` of the median disparity of the box's
/// middle third, holes filled, eroded. `left_rect`/`right_rect` get the box's region
/// re-rendered with B-splines (as the fine match would), from `raw_left`/`raw_right`.
/// Throws hedgefit::Error ("no hedge found: ...") when the middle of the box has no disparity.
cv::Mat SegmentByDepthInBox(const StereoRig& rig, const cv::Mat& raw_left, const cv::Mat& raw_right, cv::Mat* left_rect,
                            cv::Mat* right_rect, const DepthSegmentOptions& options);

/// The region of `disparity` within `tolerance_px` of the median over `box`'s middle third,
/// the connected part with most pixels there, holes filled, eroded by `erode_px`.
cv::Mat SegmentByDepth(const cv::Mat& disparity, const cv::Rect& box, double tolerance_px, int erode_px);

/// Fills the holes of a mask: background regions not connected to the image border.
cv::Mat FillHoles(const cv::Mat& mask);

/// The largest 8-connected region of `mask` (255), nothing else; all zero when it is empty.
cv::Mat LargestComponent(const cv::Mat& mask);

/// Drops `px` pixels from a mask's outline (elliptical structuring element); 0 = as is.
/// The outermost ring of a silhouette mixes hedge and background in both views, and the
/// sub-pixel refinement's windows must not reach it.
/// On a 0/255 CV_8U mask the result is cv::erode's with that element, to the bit, several times
/// faster on large elements.
cv::Mat ErodeMask(const cv::Mat& mask, int px);

/// A mask opened (eroded, then dilated) with the elliptical element of radius `px`: what
/// cv::morphologyEx(MORPH_OPEN) gives with cv::getStructuringElement(MORPH_ELLIPSE, 2 px + 1), to
/// the bit; 0 = as is. It cuts bridges narrower than the element and keeps shapes wider.
cv::Mat OpenMask(const cv::Mat& mask, int px);

/// Mask overlay for debug PNGs: outside the mask tinted magenta.
cv::Mat MaskOverlay(const cv::Mat& bgr, const cv::Mat& mask);

}  // namespace hedgefit::stereo
