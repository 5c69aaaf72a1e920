#pragma once
/// Finding every hedge in a green world, by depth. A garden defeats the paper's excess-green
/// mask: the lawn, a hedge row and trees are as green as the hedge. What sets a hedge apart is
/// its shape in 3-D: a compact, roughly round object standing on the ground inside the working
/// range. So:
///  1. match the whole frame coarsely (1/downscale resolution, no refinement): cheap;
///  2. find the ground (RANSAC plane whose normal is near the camera's up axis) and drop every
///     point less than `ground_clearance` above it;
///  3. group the rest into blobs of pixels connected without a depth jump;
///  4. keep the blobs that are hedge-sized, about as wide as high, standing on the ground and,
///     in colour images, green (mean 2G - R - B); number them left to right.
/// The fine match then runs inside each hedge's region only (stereo.sgbm).

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/option_table.hpp"
#include "stereo/rig.hpp"
#include "stereo/segmentation.hpp"

namespace hedgefit::stereo {

struct GardenSegmentOptions {
  /// The coarse match runs at 1/downscale of the resolution; 0 = so that its focal length is
  /// about 230 px (4 for the paper's 1920 x 1200 rig): the depth resolution the ground and the
  /// depth jumps need (a coarse pixel of disparity ~ 50 mm at 1.5 m), whatever the camera.
  int downscale = 0;
  double min_z_mm = kDefaultMinZmm;  ///< working range, nearest
  double max_z_mm = kDefaultMaxZmm;  ///< working range, farthest
  int block_size = 5;                ///< the coarse match's block, coarse px
  double ground_clearance_mm = 100;  ///< points lower than this above the ground are lawn
  double depth_jump_mm = 100;        ///< neighbours further apart in depth are different objects
  double min_radius_mm = 150;        ///< smallest hedge
  double max_radius_mm = 1500;       ///< largest hedge
  double max_aspect = 2.0;           ///< width / height (and height / width) at most
  double min_excess_green = 5;       ///< colour images: a hedge's mean 2G - R - B; 0 = colour not used
  int max_hedges = 16;
  /// px at full resolution, beyond the coarse match's own margin; as the colour mask's (see
  /// SegmentOptions::erode_px). Envelope mean |AER| / LD at 3 / 5 px: POV-Ray's standard gardens
  /// 0.91 / 0.94 against 1.40 / 1.18 mm, hard 1.13 / 1.15 against 1.19 / 1.24 mm; hedgefit's
  /// 0.85 / 1.29 against 0.96 / 1.23 and 0.90 / 2.04 against 0.90 / 2.12 mm; all 24 random
  /// gardens 0.81 / 1.83 against 0.81 / 1.87 (hedgefit) and 0.58 / 1.80 against 0.61 / 1.71 mm
  /// (POV-Ray); every ball found either way.
  int erode_px = 3;
  void Check() const;
  static const pipeline::OptionTable<GardenSegmentOptions>& Table();  ///< the options, declared once
};

/// The default segmentation (stereo.segment_auto): the paper's colour mask where it isolates the
/// hedge (a lab, a hedge before a wall or soil), and every hedge by depth where it cannot: when
/// the colour mask covers more than `garden_above` of the frame (a lawn, a hedge row, trees are
/// green too) or finds nothing green. Should the depth search find no hedge either, the colour
/// mask stands (and `measure` says it covers too much). Both take the same `erode`.
struct AutoSegmentOptions {
  SegmentOptions colour;
  GardenSegmentOptions garden;  ///< its erode is the colour mask's
  /// A lab's hedge covers a few per cent of the frame (the paper's r 300 mm sphere at 2 m: 3 %;
  /// a r 920 mm hedge filling the view at 1.9 m: ~35 %); the excess-green mask of a garden 54-69 %.
  double garden_above = 0.4;
  void Check() const;
  static const pipeline::OptionTable<AutoSegmentOptions>& Table();  ///< the options, declared once
};

/// One hedge found in the capture.
struct HedgeRegion {
  int id = 0;                  ///< 1, 2, ... left to right
  cv::Rect box;                ///< in the rectified left image
  cv::Rect image_box;          ///< in the original left image
  int pixels = 0;              ///< of its full-resolution mask
  cv::Vec3d approx_center_mm;  ///< from the coarse points, rectified left camera frame
  double approx_radius_mm = 0; ///< half its larger extent
  double min_z_mm = 0, max_z_mm = 0;  ///< its depth range (coarse, with a margin): the fine match searches only this
  bool touches_border = false; ///< cut by the image's edge: the fit sees part of it
};

struct GardenSegmentation {
  cv::Mat labels;                   ///< CV_32S, full rectified size: hedge id, 0 = none
  std::vector<HedgeRegion> hedges;
  bool ground_found = false;
  cv::Vec4d ground;                 ///< n.p + d = 0, rectified left frame, n pointing up (mm)
  std::vector<std::string> rejected;  ///< why each sizeable blob was not taken for a hedge
  cv::Mat coarse_disparity;         ///< CV_32F, coarse px, NaN = none (for debug images)
};

/// Finds every hedge in a rectified pair. Throws hedgefit::Error ("no hedge found: ...") when
/// there is none, naming why the largest candidates were rejected.
GardenSegmentation FindHedges(const StereoRig& rig, const cv::Mat& left_rect, const cv::Mat& right_rect,
                              const GardenSegmentOptions& options);

namespace detail {
/// The indices of `values` whose `inside` is non-zero and whose value is finite, the highest value
/// first and equal values in index order: the watershed's order in FindHedges. The values are
/// floats' (a distance transform's, a depth map's).
std::vector<int> HighestFirst(const std::vector<double>& values, const std::vector<std::uint8_t>& inside);
}  // namespace detail

}  // namespace hedgefit::stereo
