#pragma once
/// A ray-cast renderer of a calibrated stereo rig, for tests with exact truth and for
/// planning a rig. Each distorted pixel (supersampled) is mapped to its ray through the
/// OpenCV distortion model, then intersected with the scene. World frame = the left
/// camera's frame: x right, y down, z forward, mm.

#include <opencv2/core.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "stereo/rig.hpp"

namespace hedgefit::stereo {

struct SimCamera {
  cv::Size size{1920, 1200};         ///< px
  cv::Matx33d K;                     ///< intrinsics (px)
  cv::Vec<double, 5> dist{0, 0, 0, 0, 0};  ///< k1 k2 p1 p2 k3
};

struct SimRig {
  SimCamera left, right;
  cv::Matx33d R = cv::Matx33d::eye();  ///< right_from_left rotation
  cv::Vec3d T{-140, 0, 0};             ///< right_from_left translation (mm)
};

/// The paper's rig: 1920 x 1200, f = 933.3 px, baseline 140 mm, ~1 degree between the
/// cameras, mild barrel distortion. `scale` shrinks the images (and f, c) for fast tests.
SimRig PaperRig(double scale = 1.0);

/// A chessboard: squares.width x squares.height squares of square_mm, on the board's
/// z = 0 plane with its first inner corner at the origin (OpenCV's corner order), plus
/// a white margin. `world_from_board` places it.
struct BoardScene {
  cv::Size squares{13, 12};
  double square_mm = 30.0;
  double margin_mm = 30.0;
  cv::Matx33d rotation = cv::Matx33d::eye();  ///< world_from_board
  cv::Vec3d translation{0, 0, 1500};          ///< world_from_board (mm)
};

/// A foliage-textured sphere over a textured ground plane before a textured wall.
struct SphereScene {
  cv::Vec3d center{0, 0, 2300};  ///< mm, world (= left camera) frame
  double radius = 300.0;         ///< mm
  double ground_y = 0;           ///< ground plane y (down is +y); 0 = just under the sphere
  double wall_z = 0;             ///< background wall z; 0 = 2 m behind the sphere
  std::uint64_t texture_seed = 7;
};

struct RenderOptions {
  int supersample = 2;         ///< rays per pixel per axis (anti-aliasing)
  double blur_sigma_px = 0.0;  ///< Gaussian blur after rendering
  double noise_sigma = 0.0;    ///< additive sensor noise, grey levels
  std::uint64_t seed = 1;      ///< noise seed
  bool labels = false;         ///< render class labels instead of colour (see Label)
};

/// Label values when RenderOptions::labels is set: the truth for segmentation.
enum Label : std::uint8_t { kLabelNone = 0, kLabelSphere = 1, kLabelGround = 2, kLabelWall = 3, kLabelBoard = 4 };

/// Renders the left (right = false) or right view. Colour images are CV_8UC3 (BGR);
/// label images CV_8UC1.
cv::Mat RenderBoard(const SimRig& rig, bool right, const BoardScene& board, const RenderOptions& options = {});
cv::Mat RenderSphere(const SimRig& rig, bool right, const SphereScene& scene, const RenderOptions& options = {});

/// The board's inner corners in the world frame.
std::vector<cv::Point3d> BoardInnerCornersWorld(const BoardScene& board);

/// The sphere's truth file (cloud/truth_file.hpp), in the left camera frame.
void WriteSphereTruth(const std::string& path, const SphereScene& scene);

/// A board's truth: squares, square size, left_camera_from_board rotation (matrix and
/// Rodrigues vector) and translation (mm).
void WriteBoardTruth(const std::string& path, const BoardScene& board);

/// Writes the paper's laboratory test into `dir`: 16 board pairs (board_NN_left/right.png)
/// and the r = 300 mm sphere at Z = 2000, 2100, ..., 2600 mm (sphere_ZZZZ_left/right.png),
/// each with a truth JSON, plus rig_truth.json. Returns the files written.
std::vector<std::string> WritePaperLab(const std::string& dir, double scale, const RenderOptions& options);

/// The simulated rig as a calibrated one (exact intrinsics and extrinsics), rectified by
/// cv::stereoRectify: for tests and benchmarks that must not depend on calibration error.
StereoRig RigFromSimulation(const SimRig& sim);

/// The rig as JSON (K, distortion, R, T, image size) for truth files.
std::string RigJson(const SimRig& rig);

}  // namespace hedgefit::stereo
