#pragma once
/// Does the rig still fit the cameras that took this capture? Every capture answers for itself,
/// from its own rectified pair: corners spread over the whole frame are tracked from the left
/// view into the right one in two dimensions (pyramidal Lucas-Kanade, forward and back), so rows
/// that disagree by a tenth of a pixel or by twenty are both measured, where the matcher's
/// one-dimensional search sees only a fraction of a pixel and simply fails beyond.
///
/// Cost per 1920 x 1200 pair on this project's 2-core machine: about 70 ms with every cell (1200
/// corners) and about 20 ms for a warm pipeline's rolling check (RigCheckOptions::rolling) after
/// its first frame, while the twin test went through OpenCV's DFT (about half of it); the rolling
/// check 13-17 ms since it is summed directly (internal::CorrCoeffNormed).

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "pipeline/input_check.hpp"
#include "pipeline/option_table.hpp"
#include "stereo/rig.hpp"
#include "stereo/matching.hpp"

namespace hedgefit::stereo {

/// One corner of the left rectified view and where the right view shows it.
struct RowSample {
  float x = 0, y = 0;    ///< left rectified pixel
  float dx = 0, dy = 0;  ///< right - left: dx = -disparity, dy = the rows' disagreement there
};

/// The frame is judged in kCellsX x kCellsY cells; a cell speaks when it holds kMinCellSamples.
constexpr int kCellsX = 8, kCellsY = 6;
constexpr int kMinCellSamples = 6;

struct RowAgreement {
  std::vector<RowSample> samples;  ///< corners tracked both ways within `kRoundTripPx`
  cv::Size size;                   ///< the rectified frame's
  /// A plane through the samples' dy (3-MAD trimmed), in VerticalDisparity's terms: a roll, a
  /// pitch, one camera's focal length. A calibration's error at the frame's corners, where its
  /// boards never were, is trimmed away rather than tilting it.
  VerticalDisparity plane;
  /// |plane| at its largest where it was measured (`spoken`): a plane through a band of lawn
  /// says little about the frame's far corners, and extrapolated there it doubts a rig that fits.
  double plane_max_px = 0;
  cv::Rect spoken;  ///< the cells that speak, as one rectangle of the frame
  /// Each cell's median dy and, where it speaks, its difference from the plane (NaN where not),
  /// each less twice its standard error (towards 0): what the cell's samples pin down.
  cv::Mat_<double> cell_dy, cell_off_plane;
  /// The largest |median dy| of a cell: where the rows disagree most, plane or not.
  double max_abs_px = 0;
  /// The largest |cell - plane|: what a plane cannot say (a lens model that does not fit: lost
  /// distortion, another camera's intrinsics).
  double off_plane_px = 0;
  int cells = 0;  ///< cells that speak
  cv::Rect CellRect(int cx, int cy) const {
    return {cx * size.width / kCellsX, cy * size.height / kCellsY, size.width / kCellsX, size.height / kCellsY};
  }
  /// The largest |median dy| of the cells that meet `box` grown by its own size on every side (a
  /// hedge's surroundings); 0 when no cell there speaks.
  double Around(const cv::Rect& box) const;
  /// The largest |plane| over `spoken` and `box` together (a hedge's box): where the plane is
  /// known, and where it is used.
  double PlaneMaxOver(const cv::Rect& box) const;
};

/// The round trip (left -> right -> left) a tracked corner must close within, px at half size:
/// tracking only has to land within the full-size refinement's reach, which sets the precision.
constexpr double kRoundTripPx = 0.5;

/// Tracks corners of `left_rect` into `right_rect` (8-bit grey or BGR, the same size). The right
/// view is searched from `expected_disparity_px` to the left of each corner (the working range's
/// middle); pyramidal tracking reaches about 100 px either side of it. A corner must move left
/// (a disparity in [0, max_disparity_px]). `valid` (optional, CV_8U) limits the corners (the
/// rectified frame's valid area).
RowAgreement MeasureRowsSparse(const cv::Mat& left_rect, const cv::Mat& right_rect, double expected_disparity_px,
                               double max_disparity_px, const cv::Mat& valid = cv::Mat(), int max_corners = 600);

/// The rows measured over a warm pipeline's last frames (RigCheckOptions::rolling): each phase
/// holds the samples of the cells whose index is the phase modulo the period.
struct RowPool {
  std::vector<std::vector<RowSample>> by_phase;
  cv::Size size;
  int next = 0;  ///< the phase the next frame measures
};

/// MeasureRowsSparse over a stream: the first frame (or one of another size) measures every cell;
/// each later frame measures the cells of the pool's next phase (1/period of them) and replaces
/// that phase's samples. The rows are judged on every phase's samples together: a rig knocked
/// out of line shows in the cells measured since, all of them within `period` frames.
RowAgreement MeasureRowsRolling(const cv::Mat& left_rect, const cv::Mat& right_rect, double expected_disparity_px,
                                double max_disparity_px, int max_corners, int period, RowPool* pool);

/// The horizontal disparity error the measured rows imply, px, when the rig's error is read as
/// what would make them: a roll about the optical axis moves rows by roll (u - cx) and columns by
/// roll (v - cy); one camera's focal length (a scale s) moves rows by s (v - cy) and columns by
/// s (u - cx) in the left view or s (u - d - cx) in the right (taken half way, the other half
/// added as an offset); a pitch moves rows by f pitch and columns, to second order, by
/// pitch (u - cx)(v - cy) / f. What the plane cannot describe (a lens model that does not fit)
/// is read as an error of the same size and pattern in the columns: the cells' off-plane
/// differences, interpolated.
struct DisparityErrorField {
  double roll = 0;   ///< px of disparity per px of (v - cy)
  double scale = 0;  ///< px per px of (u - cx)
  double cross = 0;  ///< px per px^2 of (u - cx)(v - cy)
  cv::Point2d centre;   ///< (cx, cy) of the rectified frame
  cv::Mat_<double> off_plane;  ///< per cell (kCellsX x kCellsY), 0 where no cell spoke
  cv::Size size;
  /// The planar part at left pixel (u, v) with disparity d.
  double Planar(double u, double v, double d) const {
    return roll * (v - centre.y) + scale * (u - 0.5 * d - centre.x) + cross * (u - centre.x) * (v - centre.y);
  }
  /// The offset that stands for the unknown camera of the scale: |scale| d / 2.
  double ScaleOffset(double d) const { return std::abs(scale) * 0.5 * d; }
  /// The off-plane part at (u, v), bilinear between cell centres.
  double OffPlane(double u, double v) const;
  /// Mean |Planar| + |ScaleOffset| + |OffPlane| over `box` at disparity `d`: the bias it can put
  /// on a hedge there, for reports.
  double MeanAbsOver(const cv::Rect& box, double d) const;
};
DisparityErrorField DisparityErrorFromRows(const RowAgreement& rows, double focal_px);

/// stereo.rig_check: the policy that turns the capture's rows into each hedge's verdict.
struct RigCheckOptions {
  /// Rows that disagree by more than this around a hedge, or in the plane through the whole
  /// frame, mean the rig has drifted: the hedge's interval widens by what the horizontal error
  /// such a drift brings can cost there (DisparityErrorFromRows), and a warning says to
  /// recalibrate. Below it the refinement's own correction of the rows and the matcher's common
  /// offset (rig_uncertainty.hpp) cover it.
  double tolerance_px = 0.5;
  /// Rows more than this apart anywhere in the frame (or around a hedge): the rig file does not
  /// fit these cameras (another rig's file, the cameras swapped, distortion lost, a knock), and
  /// every result is unusable. The refinement corrects up to about 2 px of the rows'
  /// disagreement over a hedge; beyond, SGBM's own one-dimensional matching breaks down. A
  /// calibration extrapolates its distortion to the corners its boards never reached: the demo's,
  /// from 16 boards covering 39 % of the frame, leaves up to 1.2 px there (and 0.05 px over the
  /// hedges), inside this.
  double unusable_px = 2.0;
  /// A hedge whose matcher measured less than this share of its pixels rests on too little:
  /// unusable. A hedge of a fitting rig keeps most (0.8-1.0 on hedgefit's and POV-Ray's lab and
  /// garden captures); rows a few pixels apart, or a pair that is not one, leave a tenth or less.
  double min_matched_share = 0.4;
  int corners = 1200;  ///< corners tracked over the frame (48 cells, about 25 each)
  /// A warm pipeline's frames after the first track the corners of 1/rolling of the cells in
  /// turn (MeasureRowsRolling); 1 = every cell every frame. One-shot runs measure every cell.
  int rolling = 4;
  void Check() const;
  static const pipeline::OptionTable<RigCheckOptions>& Table();
};

/// What one capture's rig check found.
struct CaptureRigCheck {
  RowAgreement rows;
  /// The capture's worst: "ok", "widened", "unusable", or "unchecked" (neither the frame nor a
  /// hedge's own rows could be measured).
  std::string verdict;
  DisparityErrorField field;  ///< when widened: the horizontal error the rows imply
  pipeline::InputChecks checks;  ///< per hedge: the fields, the warning, why unusable
};

/// The rig check of a capture: rows measured over the rectified pair (MeasureRowsSparse), each
/// hedge (`hedges` from the matcher; empty for a plugin matcher) judged on the frame's rows, its
/// own rows (its refinement's estimate) and its matched share; `labels` (CV_32S hedge ids) or
/// `mask` give each hedge's box for the cost of a widened interval.
/// `expected_disparity_px`: where to start the search (the hedges' median disparity). `pool`:
/// a warm pipeline's rows so far (MeasureRowsRolling, when options.rolling > 1); none for one
/// capture alone.
CaptureRigCheck CheckCaptureRig(const cv::Mat& left_rect, const cv::Mat& right_rect, const StereoRig& rig,
                                const std::vector<HedgeMatch>& hedges, const cv::Mat& labels, const cv::Mat& mask,
                                double expected_disparity_px, const RigCheckOptions& options, RowPool* pool = nullptr);

namespace internal {
/// cv::matchTemplate(strip, tpl, result, cv::TM_CCOEFF_NORMED) for 8-bit single-channel images, with
/// its normalisation and its guards (a flat template gives 1, a flat window 0), but exact: the
/// cross-correlation is summed directly (in floats, exact for templates up to 258 pixels), where OpenCV's DFT is off by up to a few thousandths on small strips, and five times as
/// fast there. The rig check's twin test (a periodic texture) calls it once or twice per corner.
cv::Mat CorrCoeffNormed(const cv::Mat& strip, const cv::Mat& tpl);
}  // namespace internal

}  // namespace hedgefit::stereo
