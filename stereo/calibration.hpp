#pragma once
/// Stereo calibration from chessboard pairs: Zhang's method per camera, then a joint
/// stereo calibration, optional rejection of outlier pairs, then Bouguet rectification.

#include <opencv2/core.hpp>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

#include "stereo/rig.hpp"

namespace hedgefit::stereo {

enum class DistortionModel {
  kK1K2P1P2,    ///< k1 k2 p1 p2
  kK1K2P1P2K3,  ///< k1 k2 p1 p2 k3 (OpenCV's default)
  kRational,    ///< k1..k6 p1 p2 (wide-angle lenses)
};

enum class BoardType {
  kChessboard,  ///< a plain chessboard: found whole or not at all
  kCharuco,     ///< a ChArUco board (OpenCV aruco): every corner is identified, so part of a board counts
};

struct BoardSpec {
  cv::Size inner_corners{9, 6};  ///< inner corners per row x per column (ChArUco: squares - 1 each way)
  double square_mm = 1.0;        ///< square edge (mm, or any unit the rig should use)
  BoardType type = BoardType::kChessboard;
  double marker_mm = 0;          ///< ChArUco: marker side (0 = 0.75 square)
  std::string dictionary = "5x5_100";  ///< ChArUco: the ArUco dictionary, "4x4_50" .. "7x7_1000"
};

/// ChArUco boards: the dictionary's OpenCV id for a name such as "5x5_100"; throws
/// hedgefit::Error listing the names.
int CharucoDictionary(const std::string& name);

/// The image of a ChArUco board's squares (as cv::aruco::CharucoBoard::draw makes it), grey,
/// `px_per_square` pixels a square: for printing, and for the simulator's boards.
cv::Mat CharucoImage(const BoardSpec& board, int px_per_square);

struct CalibrationOptions {
  BoardSpec board;
  DistortionModel model = DistortionModel::kK1K2P1P2K3;
  bool fix_principal_point = false;  ///< keep cx, cy at the image centre
  bool fix_aspect_ratio = false;     ///< fx = fy
  /// stereoRectify free scaling: 0 crops to valid pixels, 1 keeps all, -1 is OpenCV's
  /// default. 0 by default: it makes the rectified focal length differ from the cameras',
  /// so the resampling phase varies over a hedge instead of being one constant sub-pixel
  /// shift per view (lab test: mean |AER| 0.45 mm at 0, 0.81 mm at -1).
  double alpha = 0;
  /// Reject pairs whose reprojection RMS exceeds this many times the median, then
  /// recalibrate (0 = keep every pair).
  double reject_factor = 3.0;
  int min_pairs = 3;                 ///< fewer usable pairs is an error
  /// Refine both cameras' intrinsics in the stereo step (false: keep the per-camera ones,
  /// OpenCV's stereoCalibrate default).
  bool refine_intrinsics = true;
  void Check() const;  ///< throws hedgefit::Error naming the field
};

/// Corners of one pair, as found in the images (or made by a simulator).
struct PairCorners {
  std::string left, right;                 ///< names for reports
  std::vector<cv::Point2f> left_px, right_px;  ///< empty when the board was not found
  /// ChArUco: the ids (row-major index into BoardCorners) of the corners seen in both images,
  /// one per entry of left_px and right_px; empty for a chessboard, which is found whole.
  std::vector<int> ids;
  std::string status;                      ///< empty, or why the pair cannot be used
};

/// Finds the board in every pair (sub-pixel), pairs in parallel (`threads`, 0 = all cores):
/// searched on an image reduced to at most 1024 px a side, refined on the full one. Unreadable
/// images, size mismatches and boards not found are recorded in `status`, not thrown.
/// `image_size` gets the size of the first readable pair. With `progress`, one line per pair
/// as it finishes.
std::vector<PairCorners> DetectBoards(const std::vector<std::pair<std::string, std::string>>& pairs,
                                      const BoardSpec& board, cv::Size* image_size, std::ostream* progress = nullptr,
                                      int threads = 0);

/// Calibrates from detected corners. Throws hedgefit::Error if fewer than min_pairs remain.
StereoRig CalibrateFromCorners(const std::vector<PairCorners>& pairs, cv::Size image_size,
                               const CalibrationOptions& options);

/// Where the corners of the used pairs fell: each camera's image (left, then right, side by side,
/// scaled to at most 800 px wide each) with every board's outline shaded, so overlaps are darker,
/// and its corners dotted; the cells of an 8 x 8 grid that hold no corner are hatched red.
/// `share` (optional) gets the fraction of the 64 cells holding a corner, left and right.
cv::Mat CoveragePicture(const std::vector<PairCorners>& pairs, const std::vector<PairReport>& reports,
                        cv::Size image_size, std::pair<double, double>* share = nullptr);

/// The joint least-squares problem cv::stereoCalibrate solves (both cameras, the rig, every
/// board pose; the options' model and fixed parameters), refined by Ceres from `rig`'s K, D, R,
/// T, which it replaces; sets `rig->covariance` from the Jacobian scaled by the residual
/// variance. Returns the residual standard deviation per image coordinate, px.
double RefineStereoBundle(const std::vector<std::vector<cv::Point2f>>& left_px,
                          const std::vector<std::vector<cv::Point2f>>& right_px,
                          const std::vector<std::vector<cv::Point3f>>& object, const CalibrationOptions& options,
                          StereoRig* rig);

/// The board's inner corners in its own frame (z = 0), row-major as OpenCV orders them.
std::vector<cv::Point3f> BoardCorners(const BoardSpec& board);

}  // namespace hedgefit::stereo
