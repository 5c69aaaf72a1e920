#pragma once
/// The paper's improved semi-global matching: OpenCV SGBM (8 paths by default), a
/// left-right consistency check that marks occluded or mismatched pixels, hole filling
/// from the background side (occluded pixels belong to the farther surface, i.e. the
/// smaller disparity), then an edge-preserving bilateral filter. Disparities are float px.

#include <opencv2/core.hpp>

#include "pipeline/option_table.hpp"

namespace hedgefit::stereo {

enum class SgbmMode { kSgbm5, kHh8, kSgbm3Way, kHh4 };

struct SgbmOptions {
  SgbmMode mode = SgbmMode::kHh8;  ///< 8 paths (MODE_HH) by default, as in the paper
  int min_disparity = 0;           ///< px
  int num_disparities = 64;        ///< px, rounded up to a multiple of 16
  int block_size = 5;              ///< px, odd
  int p1 = 0;                      ///< smoothness penalty; 0 = 8 * channels * block^2
  int p2 = 0;                      ///< 0 = 32 * channels * block^2
  int uniqueness_ratio = 10;       ///< %
  int disp12_max_diff = -1;        ///< OpenCV's own check, off: the LRC check below replaces it
  double lrc_tolerance_px = 1.0;   ///< |d_left(x) - d_right(x - d_left(x))| allowed; < 0 turns LRC off
  bool fill_holes = true;          ///< fill rejected pixels from the background side
  double bilateral_sigma_disp = 0.0;  ///< bilateral filter range sigma (px of disparity); 0 = off (see below)
  double bilateral_sigma_space = 3.0; ///< bilateral filter spatial sigma (px)
  int refine_radius = 2;           ///< sub-pixel refinement window half-size (px); 0 = off (see RefineSubpixel)
  /// A pixel the refine_radius window does not pin to refine_retry_sigma (too little texture
  /// for the noise) is tried again with this larger window; 0 or <= refine_radius = never.
  int refine_max_radius = 4;
  double refine_retry_sigma_px = 0.1;
  /// Gauss-Newton steps per pixel from SGBM's value. Two, not three: the third fits the window's
  /// noise with the slopes and gain, and on the real Middlebury pairs, the lab and the garden
  /// renders of both renderers, three steps did worse than two (README, bench_middlebury). One is
  /// worse on Motorcycle and the hedgefit lab's centre.
  int refine_iterations = 2;
  double refine_max_sigma_px = 0.2;  ///< a refined value less certain than this is not used
  /// Where the refinement fails or is less certain than refine_max_sigma: drop the pixel (it
  /// becomes a hole, filled in the dense map but left out of the cloud) instead of keeping
  /// SGBM's value, which on a convex surface is biased far (see RefineSubpixel).
  bool refine_drop_uncertain = true;
  /// After the refinement, remove what the disparity surface's curvature did to each affine
  /// window's estimate: a quadratic fitted to the refined disparities on a (2 n + 1)^2 grid about
  /// the pixel (every 2 px, or every stride-th when thinned) gives the curvature, the window's own
  /// response to it the correction (see RefineSubpixel). A dome's disparity is concave, so an
  /// affine window reads it too small (far), most near the outline: the lab sphere's radius read
  /// 0.2-0.5 mm small from that alone. 0 = off.
  int refine_curvature = 3;
  /// When the points are thinned to every s-th pixel and row with s at least this (a hedge more
  /// than (s - 1)^2 max_points pixels large), SGBM and the left-right check run on the pair at
  /// half resolution (a quarter of the pixels, half the disparities: an eighth of the cost) and
  /// the refinement, at full resolution on the pixels kept, starts from twice that disparity.
  /// From s = 3 full-resolution SGBM would match 9 or more pixels per pixel kept, and was 75 % of
  /// the capture of the paper's outdoor ball; at s = 2 the refinement dominates and half
  /// resolution cost hedgefit's garden row 0.24 mm of envelope radius. 0 = never.
  int half_res_from_stride = 3;
  /// Before the refinement, estimate the pair's residual vertical disparity (see
  /// EstimateVerticalDisparity) and refine against the right view resampled to remove it.
  bool correct_vertical = true;
  /// ... when it reaches this anywhere in the image: below, the rows agree to the refinement's
  /// own precision (its standard deviations are 0.05-0.2 px) and resampling would only perturb it.
  double correct_vertical_min_px = 0.05;
  void Check() const;  ///< throws hedgefit::Error naming the option
  /// The options a user sets (not the disparity range, which comes from the working range).
  static const pipeline::OptionTable<SgbmOptions>& Table();
};

/// The residual vertical disparity of a rectified pair: the left pixel (x, y) appears in the
/// right view at row y + At(x, y). Rectification from a calibration leaves some: a few tenths of
/// a pixel on real rigs (Middlebury 2014 Motorcycle, "perfectly" rectified: about -0.3 px). A
/// horizontal match across an edge at angle t to the rows then errs by At / tan(t), which the
/// sub-pixel refinement's one-dimensional search cannot absorb.
struct VerticalDisparity {
  double offset_px = 0;   ///< at the image centre
  double slope_x_px = 0;  ///< change from the image's left edge to its right edge
  double slope_y_px = 0;  ///< change from the top edge to the bottom edge
  int samples = 0;        ///< windows that settled; 0 = not estimated (too few)
  bool applied = false;   ///< the right view was resampled to remove it
  double At(double x, double y, cv::Size size) const {
    return offset_px + slope_x_px * (x - 0.5 * size.width) / size.width + slope_y_px * (y - 0.5 * size.height) / size.height;
  }
  double MaxAbs(cv::Size size) const;  ///< the largest |At| over the image (at a corner)
};

/// How one hedge matched: the share of its pixels the matcher measured (not filled), judged on the
/// pixels it kept (every stride-th of every stride-th row), and the rows' disagreement its own
/// refinement found and removed.
struct HedgeMatch {
  int id = 0;         ///< hedge id (0: the capture's one mask)
  int pixels = 0;     ///< the hedge's pixels in the mask
  int stride = 1;
  int measured = 0;   ///< pixels kept with a measured disparity (before DropLessCertain's cut)
  VerticalDisparity vertical;
  double vertical_max_px = 0;  ///< |vertical| at its largest over the matched region
  double Share() const { return pixels > 0 ? double(measured) * stride * stride / pixels : 0.0; }
};

struct DisparityMap {
  cv::Mat disparity;  ///< CV_32F, px; NaN where no disparity is known
  cv::Mat rejected;   ///< CV_8U, 255 where the LRC check (or SGBM) rejected the pixel
  cv::Mat sigma;      ///< CV_32F, px: the refinement's standard deviation; NaN where not refined
  int filled = 0;     ///< pixels filled from neighbours
  VerticalDisparity vertical;  ///< estimated and removed before the refinement (correct_vertical)
  double sgbm_ms = 0;    ///< SGBM, its right matcher and the left-right check (wall clock)
  double refine_ms = 0;  ///< the sub-pixel refinement, the vertical disparity's estimate included
};

/// Matches a rectified pair (8-bit grey or BGR). `left` and `right` have the same size.
/// `mask` (optional, CV_8U, left view) limits the sub-pixel refinement's windows to the
/// object, so silhouette pixels are not pulled towards the background.
/// `stride` > 1 keeps (and refines) only every stride-th pixel of every stride-th row, the
/// others NaN: the refinement's cost and the cloud's size fall by stride^2, each kept pixel
/// exactly as accurate.
/// SGBM leaves the left view's first min_disparity + num_disparities columns unmatched (their
/// search would leave the right image), and the left-right check's right matcher the right
/// view's last ones, which fails the left pixels that match there. `left_pad_px` and
/// `right_pad_px` widen both views on that side by that many columns (edges repeated) before
/// matching, and the result is cropped: a pixel near either edge is matched wherever both cameras
/// see it. A match that reads the left padding is dropped.
DisparityMap ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const SgbmOptions& options,
                              const cv::Mat& mask = cv::Mat(), int stride = 1, int left_pad_px = 0,
                              int right_pad_px = 0);

/// Sub-pixel refinement of an SGBM disparity map. SGM's path costs favour constant
/// disparity, so on a convex surface (every path arrives from the farther rim) the map is
/// biased towards smaller disparities, and its parabola interpolation pixel-locks. This
/// re-estimates each known, non-`skip` pixel by Gauss-Newton on the windowed photometric
/// error L(x + i, y + j) = (1 + a) R(x + i - d - sx i - sy j, y + j) + b (disparity, its
/// slopes, gain, offset), with cubic B-spline interpolation along the right image's rows,
/// using only window pixels inside `mask` (all when empty). A pixel keeps its SGBM value
/// when its window is textureless or mostly outside the mask, when the estimate moves more
/// than 1 px, or when its standard deviation (residuals and the inverse Hessian) exceeds
/// `max_sigma_px`. Returns the number of pixels refined; `sigma` (optional, CV_32F, same
/// size) receives each refined pixel's standard deviation (px), NaN elsewhere. With `dropped`
/// (CV_8U, same size), a pixel that would keep its SGBM value is instead set to NaN and
/// marked 255 there. With `max_radius` > `radius`, a pixel whose first window does not pin it
/// to `retry_sigma_px` is tried again with the larger window, whose estimate wins if it settles.
/// With `curvature_radius` > 0 each refined value is then corrected for the curvature of the
/// disparity surface, which the affine window cannot represent: a quadratic is fitted to the
/// refined values on a (2 curvature_radius + 1)^2 grid of `curvature_step_px` about the pixel
/// (neighbours more than 3 px of disparity away are another surface), and the estimate moves back
/// by the window's linearised response to that quadratic, at most 0.2 px.
int RefineSubpixel(const cv::Mat& left, const cv::Mat& right, const cv::Mat& mask, const cv::Mat& skip,
                   int radius, int iterations, cv::Mat* disparity, double max_sigma_px = 0.2,
                   cv::Mat* sigma = nullptr, cv::Mat* dropped = nullptr, int max_radius = 0,
                   double retry_sigma_px = 0.0, int curvature_radius = 0, int curvature_step_px = 2);

/// For tests and benchmarks: with `portable`, RefineSubpixel sums each window 4 samples at a time
/// on every CPU; without, 16 at a time where the CPU has AVX-512 (the default). The two sum in
/// different orders, so their estimates differ by single precision's rounding.
void ForcePortableRefinement(bool portable);

/// Estimates the pair's residual vertical disparity from `disparity` (CV_32F, NaN = unknown, left
/// view): on a grid of 9 x 9 windows inside `mask` (all when empty), each window's disparity,
/// its slopes, a vertical shift, gain and offset by Gauss-Newton against the right view's 2-D
/// cubic B-spline; the shifts that settle to 0.1 px are fitted with a plane in (x, y), trimmed
/// at 3 MADs. At least 30 windows must settle, else `samples` is 0.
VerticalDisparity EstimateVerticalDisparity(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity,
                                            const cv::Mat& mask = cv::Mat());

/// The grey levels of an 8-bit grey or BGR image as CV_32F, as the refinement reads them.
cv::Mat GreyLevels(const cv::Mat& image);

/// One left pixel's match in the right view, in two dimensions: Gauss-Newton on a 9 x 9 window for
/// the disparity, its slopes, the vertical shift, gain and offset (EstimateVerticalDisparity's
/// window), started at (`disparity_px`, `dy_px`). `left_grey` is GreyLevels of the left view,
/// `right_coeffs` BSplineCoefficients2D of the right view's. True, with the vertical shift (right
/// row - left row) and its standard deviation, px, when it settles within 1 px of the disparity
/// and 2 px of the shift it started from.
bool RefineMatch2D(const cv::Mat& left_grey, const cv::Mat& right_coeffs, int x, int y, double disparity_px,
                   double dy_px, double* dy_out, double* sigma_out);

/// Fills NaN pixels row by row with the smaller (farther) of the nearest valid disparities
/// to the left and right; returns how many pixels were filled.
int FillHolesFromBackground(cv::Mat* disparity);

/// The default working range, mm. Nearest: the paper's outdoor hedges (r 880-960 mm, centres about
/// 2 m away) have their front leaves about 1.1 m from the cameras. Farthest: a row's last ball.
inline constexpr double kDefaultMinZmm = 1000, kDefaultMaxZmm = 3500;

/// Throws Error, before any matching, when the nearest depth `min_z_mm` needs a disparity (f b / Z)
/// that an image `width_px` wide cannot hold: "min_z 10 mm (--min-z) needs a disparity of 13066 px;
/// the nearest this rig can match in a 1920 px wide image is 69 mm". A search that wide would
/// otherwise abort inside OpenCV.
void CheckNearestDepth(double focal_px, double baseline_mm, double min_z_mm, int width_px);

/// Throws Error naming option 'min_z' or 'max_z' unless 0 < min_z_mm < max_z_mm, with the unit and,
/// for a depth under 100, the value in mm it likely meant ("3.5 ... (3500 for 3.5 m)").
void CheckDepthRange(double min_z_mm, double max_z_mm);

/// Disparity search range [min, min + num) for depths [min_z, max_z] mm: d = f b / Z.
void DisparityRangeForDepth(double focal_px, double baseline_mm, double min_z_mm, double max_z_mm, int* min_disparity,
                            int* num_disparities);

}  // namespace hedgefit::stereo
