#pragma once
/// From a stereo capture to a point cloud, as the paper does it: rectify, segment the hedge,
/// match with the improved SGBM over the hedge's region only, and reproject to 3-D in the
/// unrectified left camera frame (mm). Each step is a stage (stereo_stages.hpp) around the
/// functions here and in rectification.hpp, segmentation.hpp and reprojection.hpp;
/// ConvertCapture runs those very stages, so `hedgefit convert` and a pipeline are one path.

#include <opencv2/core.hpp>

#include <optional>
#include <string>

#include "pipeline/option_table.hpp"
#include "cloud/cleaning.hpp"
#include "cloud/point_cloud.hpp"
#include "stereo/depth_segmentation.hpp"
#include "stereo/matching.hpp"
#include "stereo/row_check.hpp"
#include "stereo/rectification.hpp"
#include "stereo/reprojection.hpp"
#include "stereo/rig.hpp"
#include "stereo/segmentation.hpp"

namespace hedgefit::stereo {

struct MatchOptions {
  SgbmOptions sgbm;                ///< min/num disparities are set from the working range
  double min_z_mm = kDefaultMinZmm;  ///< working range, nearest: sets the disparity search
  double max_z_mm = kDefaultMaxZmm;  ///< working range, farthest
  bool region_only = true;         ///< match only the mask's bounding box (plus margin)
  int margin_px = 24;              ///< around the mask's bounding box
  bool precise_resampling = true;  ///< B-spline rectification of the matched region
  /// At most this many points per hedge: a larger region keeps every s-th pixel of every s-th
  /// row (s the smallest stride that fits), so time and cloud size stay bounded for hedges
  /// that fill the view. 0 = every pixel.
  int max_points = 60000;
  /// With max_points > 0, a hedge keeps every min_stride-th pixel and row or fewer, where that
  /// leaves it 2,500 points (smaller ones keep every pixel). Neighbours 1 px apart share
  /// 80 % of the refinement's 5 x 5 window, so their disparities carry little that every second
  /// one's do not: on the lab's renders (both renderers, ideal and real cameras, 7 noise draws)
  /// every 2nd pixel and row moved mean |AER| and LD by at most 0.03 mm, and took a warm lab frame
  /// from 206 to 116 ms (docs/speed.md). 1 = every pixel.
  int min_stride = 2;
  /// A hedge whose segmentation gave no depth range (the colour mask, a drawn mask) is first
  /// matched at a quarter of the resolution over the whole working range, and the fine match
  /// searches only the disparities its masked pixels took there (1st to 99th percentile, widened
  /// by 8 px and 5 %), as the garden path's hedges do with theirs: the working range from 1 m is 96
  /// disparities at the paper's rig where the lab sphere takes about 25.
  bool coarse_range = true;
  /// For hedges found by depth (the garden segmentation: a leafy shell), the refinement's retry
  /// window in place of sgbm.refine_max_radius; 2 (= the refine_radius window) is no retry. On a
  /// leafy hedge a 9 x 9 window (23 mm at 2.4 m) spans leaves at different depths and reads the
  /// outermost ones too deep: without it the envelope's error fell on all six garden sets of
  /// both renderers (README, `bench garden`).
  int garden_refine_max_radius = 2;
  /// For hedges found by depth: the curvature correction's grid (sgbm.refine_curvature) in its
  /// place; 0 = off. Within its +-6 px a leafy shell's disparity is leaf relief more than the
  /// dome's curvature, and the envelope fit's allowance for the outermost leaves' reading (half a
  /// pixel's footprint) was measured without the correction: with it (3) the envelope's radius
  /// error rose on all four garden sets tried, of both renderers (0.85 -> 0.93, 0.90 -> 1.08,
  /// 0.90 -> 0.96 and 1.02 -> 1.08 mm; README, `bench garden`), and the row of three took ~40 ms
  /// more per frame.
  int garden_refine_curvature = 0;
  /// For hedges found by depth: a refined pixel whose disparity standard deviation exceeds this
  /// multiple of the median over its garden_sigma_tile square (its own hedge's pixels) is left out
  /// of the cloud; 0 = keep all. On a leafy shell the refinement's window fits worst where it
  /// straddles leaves at different depths or looks into a dim gap between them, and reads those
  /// pixels towards the window's average depth: the outer leaves too deep, the deep ones too
  /// shallow. Keeping each tile's better-pinned half cut the envelope radius's error on all six
  /// garden sets of both renderers (README, `bench garden`). A median, not a fixed threshold, so
  /// the cut follows the camera's noise and the light (the sunlit and the shaded side of a ball).
  double garden_sigma_ratio = 1.0;
  /// ... the square's side, px: several leaves at the garden's distances (32 px is ~80 mm at 2.4 m
  /// on the paper's rig), small against the light's change across a ball.
  int garden_sigma_tile_px = 32;
  void Check() const;
  static const pipeline::OptionTable<MatchOptions>& Table();  ///< the options, declared once
};

struct MatchResult {
  cv::Mat disparity;        ///< CV_32F px, full rectified size, NaN = none
  cv::Mat filled;           ///< CV_8U, 255 where the disparity was filled, not measured
  cv::Mat disparity_sigma;  ///< CV_32F px, the refinement's standard deviation; NaN = none
  cv::Rect matched_region;  ///< in the rectified left image (several hedges: the union's box)
  int matched_area = 0;     ///< px matched (several hedges: the sum of their regions)
  int filled_count = 0;
  int stride = 1;           ///< every stride-th pixel and row kept (MatchOptions::max_points)
  int min_disparity = 0, num_disparities = 0;  ///< the search range used
  /// The residual vertical disparity the refinement removed (several hedges: the one reaching
  /// furthest), and the largest |value| it reaches over the matched region, px (0 = none).
  VerticalDisparity vertical;
  double vertical_max_px = 0;
  int less_certain_dropped = 0;  ///< measured pixels left out by garden_sigma_ratio
  std::vector<HedgeMatch> hedges;  ///< per hedge (one, id 0, for a single mask)
  /// Where the time went, ms (several hedges: summed): the matched regions' B-spline
  /// rectification from the raw images (precise_resampling), SGBM with its right matcher and the
  /// left-right check, the sub-pixel refinement; the rest of the stage is hole filling, merging and
  /// the cuts. `stereo.sgbm` notes them (`rectify_region_ms`, `sgbm_ms`, `refine_ms`), so a report
  /// and `bench_capture` show what a frame's matching is made of.
  double rectify_region_ms = 0, sgbm_ms = 0, refine_ms = 0;
};

/// Leaves out of `disparity` (sets NaN) each measured pixel of `mask` (not `filled`, finite
/// `sigma`) whose `sigma` exceeds `ratio` times the median of the measured pixels of `mask` in
/// its `tile_px` square of the image (squares from the origin); squares with fewer than 8 such
/// pixels are left alone. Returns how many were left out. See MatchOptions::garden_sigma_ratio.
int DropLessCertain(const cv::Mat& mask, const cv::Mat& sigma, const cv::Mat& filled, double ratio, int tile_px,
                    cv::Mat* disparity);

/// MatchHedge for each hedge of `hedge_labels` (CV_32S, id per pixel) over its own region and,
/// when `hedges` gives one, its own depth range, the results merged: a row of hedges costs the
/// sum of their regions, not the row's bounding box.
MatchResult MatchHedges(const StereoRig& rig, const cv::Mat* raw_left, const cv::Mat* raw_right, cv::Mat* left_rect,
                        cv::Mat* right_rect, const cv::Mat& hedge_labels, const MatchOptions& options,
                        const std::vector<HedgeRegion>& hedges = {});

/// Whether a rig still fits a pair (unrectified, as captured): the pair is rectified with the rig,
/// matched over the whole frame at half resolution (SGBM and the left-right check, the working
/// range's disparities), and the rows' residual vertical disparity is estimated at full resolution
/// (EstimateVerticalDisparity). A rig from these cameras, still mounted as calibrated, leaves a few
/// hundredths of a pixel; a rig from other cameras, or cameras that moved, leaves more. Throws
/// hedgefit::Error when the images are not the rig's size.
VerticalDisparity MeasureRowAgreement(const StereoRig& rig, const cv::Mat& left_bgr, const cv::Mat& right_bgr,
                                      double min_z_mm, double max_z_mm);

/// Matches the hedge: the mask's region (or the whole frame) of the rectified pair, over the
/// working range's disparities. With `raw_left`/`raw_right` (the unrectified images) and
/// options.precise_resampling, that region of `left_rect`/`right_rect` is first re-rendered
/// with B-splines (matching to hundredths of a pixel needs resampling that does not shift
/// the texture).
MatchResult MatchHedge(const StereoRig& rig, const cv::Mat* raw_left, const cv::Mat* raw_right, cv::Mat* left_rect,
                       cv::Mat* right_rect, const cv::Mat& mask, const MatchOptions& options);

/// The region SGBM needs for the mask's pixels: its bounding box plus `margin_px`, widened
/// to the left by the disparity reach so every masked pixel gets a full search, and to the
/// right by the number of disparities so the left-right check's right matcher sees them too.
cv::Rect MatchRegion(const cv::Mat& mask, const SgbmOptions& sgbm, int margin_px);

/// How the hedge is found.
enum class SegmentMode { kAuto, kColour, kMask, kDepth, kGarden };

struct ConvertOptions {
  /// kAuto (stereo.segment_auto): the colour mask in a lab, every hedge by depth in a garden.
  SegmentMode mode = SegmentMode::kAuto;
  double garden_above = AutoSegmentOptions().garden_above;  ///< kAuto's switch to depth
  SegmentOptions segment;     ///< kColour
  MaskOptions mask;           ///< kMask
  DepthSegmentOptions depth;  ///< kDepth
  GardenSegmentOptions garden;  ///< kGarden: every hedge, by depth
  MatchOptions match;         ///< for the built-in matcher, stereo.sgbm
  /// The matching slot: stereo.sgbm, or any registered stage (a plugin's) that turns the
  /// rectified pair into 'disparity' (and optionally 'filled', 'disparity_sigma'); it runs
  /// with its default options.
  std::string matcher = "stereo.sgbm";
  RigCheckOptions rig_check;  ///< stereo.rig_check, after the matcher
  ReprojectOptions reproject;
  /// measure::MeasurePipelineJson's cleaning searches every point's neighbours in 3-D, as 0.7.0 did
  /// (ReferenceOptions), not on the image grid.
  bool reference_cleaning = false;
  void Check() const;
};

/// The options that restore hedgefit 0.7.0's capture path, before the speed work of 0.8.0
/// (`bench_capture` times both): the same results within the accuracy tables' 0.05 mm, slower.
ConvertOptions ReferenceOptions();

/// The capture path, images to cloud, as a pipeline (JSON array of stages): readers.stereo
/// with these files when `left` is not empty, then stereo.rectify, the segmentation stage, the
/// matcher, stereo.rig_check and stereo.reproject. The measuring layer's recipes
/// (measure/recipes.hpp) add the writers, the cleaning and the fits.
std::string CapturePipelineJson(const ConvertOptions& options, const std::string& left = "",
                                const std::string& right = "", const std::string& rig = "");

struct ConvertResult {
  cloud::PointCloud cloud;
  cv::Mat left_rect, right_rect, mask, disparity;  ///< for debug images
  cv::Mat filled;                  ///< CV_8U, 255 where the disparity was filled, not measured
  cv::Mat disparity_sigma;         ///< CV_32F px, the refinement's standard deviation; NaN = none
  cv::Rect matched_region;         ///< in the rectified left image
  std::vector<HedgeRegion> hedges; ///< kGarden: every hedge found (the cloud's "hedge_id" field)
  cv::Mat hedge_labels;            ///< kGarden: CV_32S hedge ids in the rectified left image (0 none)
  std::optional<cv::Vec4d> ground; ///< kGarden: the ground plane found, unrectified left frame (n.p + d = 0)
  double matched_fraction = 1.0;   ///< matched area / full image area
  double wall_ms = 0;
  struct {
    double rectify = 0;    ///< bilinear full frame (the B-spline region is in match)
    double segment = 0;
    double match = 0;      ///< B-spline region, SGBM, right matcher, left-right check, refinement, filling
    double reproject = 0;
  } stage_ms;
};

/// The whole capture-to-cloud path: runs the stages of CapturePipelineJson(options) on images
/// in memory. Throws hedgefit::Error (e.g. "no hedge found").
ConvertResult ConvertCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig,
                             const ConvertOptions& options);

/// Colourised disparity, for debug PNGs.
cv::Mat ColorizeDisparity(const cv::Mat& disparity);

}  // namespace hedgefit::stereo
