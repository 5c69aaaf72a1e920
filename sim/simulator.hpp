#pragma once
/// A ray-cast renderer of a calibrated stereo rig, for tests with exact truth and for
/// planning a rig. Each distorted pixel (supersampled) is mapped to its ray through the
/// OpenCV distortion model, then intersected with the scene. World frame = the left
/// camera's frame: x right, y down, z forward, mm.

#include <opencv2/core.hpp>
#include <cstdint>
#include <functional>
#include <optional>
#include <utility>
#include <string>
#include <vector>

#include "stereo/rig.hpp"

namespace hedgefit::sim {

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
  /// Empty: black and white squares. Otherwise a grey image of the squares' area (e.g. a
  /// ChArUco board from CharucoImage), stretched over it and sampled bilinearly.
  cv::Mat texture;
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

/// Label values when RenderOptions::labels is set: the truth for segmentation. In a garden,
/// hedge i (0-based) is labelled kLabelHedge + i; the lawn kLabelGround, anything else kLabelWall.
enum Label : std::uint8_t {
  kLabelNone = 0, kLabelSphere = 1, kLabelGround = 2, kLabelWall = 3, kLabelBoard = 4, kLabelHedge = 10
};

/// A clipped boxwood ball on a lawn: leaves fill a shell between radius - leaf_depth and radius
/// (radial depth from a 3-D noise field, so there are gaps one sees into), sitting on the ground.
/// Placed in the level frame: x right, z forward along the ground from the camera's foot.
/// What a hedge's leaves are like. The defaults are the boxwood every garden preset had before
/// the leaf presets (GardenLeafPresetNames): round flat leaves 12-20 mm across, 3.5 layers.
/// POV-Ray builds each leaf from it (a disc; elongated, an elliptic disc; cupped, a folded lozenge);
/// hedgefit's renderer has no leaves, only a noise-shaded shell whose relief it scales by size_mm.
struct LeafShape {
  double size_mm = 16;          ///< mean leaf length (12-20 mm about it)
  double width_ratio = 1;       ///< width over length: 1 round, 0.2 a needle
  double cup = 0;               ///< how far the rim rises above the leaf's middle, over its length
  double layers = 3.5;          ///< leaves over the sphere's area in units of one leaf's: dense 4, gappy 2
  double clipped_share = 1.0 / 3;  ///< leaves cut flush with the envelope by the shears
};

struct GardenHedge {
  double x_mm = 0;
  double z_mm = 2300;
  double radius_mm = 500;      ///< outer envelope: where the leaves end (what a tape measure gives)
  double leaf_depth_mm = 30;   ///< depth of the leaf shell below the envelope
  LeafShape leaf;
  double sink_share = 0.05;    ///< how far the ball sinks into the lawn, over its radius (a dome: 0.3-0.5)
  /// A bulge (a shoot the shears missed): a ball of the same leaves, bulge_radius_mm across, whose
  /// envelope reaches bulge_mm past the hedge's, towards bulge_heading_deg (about the vertical in the
  /// garden's level frame, from +z towards +x) at the hedge's equator. 0 = none. It is part of the
  /// hedge (its label) but not of its sphere (the truth files' centre and radius).
  double bulge_mm = 0, bulge_radius_mm = 0, bulge_heading_deg = 0;
};

/// The bulge of `ball` (GardenHedge::bulge_mm) as a ball of its own, centred in the level frame
/// given the hedge's centre `center`; nullopt when it has none.
std::optional<std::pair<cv::Vec3d, double>> GardenBulge(const GardenHedge& ball, const cv::Vec3d& center);

/// A garden: hedge balls on a mown lawn, a terracotta pot, a clipped hedge row at 5.2 m, a fence
/// at 6.6 m, two round-crowned trees, sky, and a low sun casting hard shadows. The camera stands
/// `camera_height_mm` above the lawn, pitched down by `pitch_deg`.
struct GardenScene {
  std::vector<GardenHedge> hedges;
  double camera_height_mm = 1100;
  double pitch_deg = 8;
  bool pot = true;                     ///< a pot (r 180 mm, 380 mm high) among the hedges
  double pot_x_mm = -700, pot_z_mm = 1900;
  bool background = true;              ///< hedge row, fence, trees
  std::uint64_t texture_seed = 11;
  /// Other shrubs: leafy lobes (each a ball of leaves like a hedge's, of another, bluer green)
  /// that overlap into irregular bushes. Not hedges: labelled kLabelWall, not in the truth.
  std::vector<GardenHedge> shrub_lobes;
  bool overcast = false;               ///< no sun: soft light from the whole sky, no shadows
  /// Where the camera stands: its foot's x and z in the garden's level frame (mm) and its heading
  /// about the vertical (degrees, from +z towards +x). All 0 (every preset): at the garden's origin
  /// looking along +z. A ring of captures about a hedge moves the camera through one garden: the
  /// leaves, lawn, light and background stay where they are.
  double view_x_mm = 0, view_z_mm = 0, view_heading_deg = 0;
};

/// The left camera's pose in the garden's level frame (x right, y down along gravity, z forward
/// from the origin's view; mm): p_level = R p_camera + t, as a 4 x 4 matrix.
cv::Matx44d GardenLevelFromCameraPose(const GardenScene& scene);

/// A leafy ball's (a hedge's or a shrub lobe's) centre in the garden's level frame (mm): it sits
/// on the lawn.
cv::Vec3d GardenLevelCenter(const GardenScene& scene, const GardenHedge& ball);

/// Hedge `i`'s centre in the left camera frame (mm).
cv::Vec3d GardenHedgeCenter(const GardenScene& scene, std::size_t i);

/// The rotation from the left camera frame to the camera's own level frame (x right, y down along
/// gravity, z forward along the ground, heading as the camera; the origin stays at the left
/// camera): p_level = M p_cam. With a view pose, GardenLevelFromCameraPose is the garden's.
cv::Matx33d GardenLevelFromCamera(const GardenScene& scene);

/// Hedge `i`'s mean leaf-surface radius: the envelope minus the mean radial leaf depth over the
/// sphere (sampled; mm).
double GardenHedgeSurfaceRadius(const GardenScene& scene, std::size_t i);

/// Renders the left (right = false) or right view. Colour images are CV_8UC3 (BGR);
/// label images CV_8UC1.
cv::Mat RenderBoard(const SimRig& rig, bool right, const BoardScene& board, const RenderOptions& options = {});
cv::Mat RenderSphere(const SimRig& rig, bool right, const SphereScene& scene, const RenderOptions& options = {});
cv::Mat RenderGarden(const SimRig& rig, bool right, const GardenScene& scene, const RenderOptions& options = {});
/// The left camera's exact view of a garden: each pixel's first hit, one ray through the pixel's
/// centre, as a point in the left camera frame (CV_32FC3, mm; NaN where the ray meets only sky).
/// The truth a matcher's cloud is scored against, pixel by pixel (RenderGarden's labels say whose).
cv::Mat RenderGardenSurface(const SimRig& rig, const GardenScene& scene);

/// The garden presets: "row" (three balls, r 450-600 mm, 2.1-2.7 m, pot in front), "single"
/// (one r 520 mm ball at 2.4 m), "outdoor" (the paper's outdoor case: one r 920 mm ball about
/// 2 m away, its front leaves 1.1 m from the cameras); the hard ones below; "random<seed>"
/// (e.g. "random7"): a garden drawn from the seed, one to three balls of the range (r
/// 420-600 mm, centres 2.0-2.7 m away) side by side, a camera 0.9-1.4 m up pitched 4-14 degrees,
/// sometimes a two-lobed shrub beside them; "paper<seed>": the paper's outdoor size drawn from
/// the seed, one or two balls of r 880-960 mm, the nearest 2.0-2.4 m away, in one of the four
/// leaf presets (seed mod 4), sun or overcast. Throws hedgefit::Error for another name.
GardenScene GardenPreset(const std::string& name);
std::vector<std::string> GardenPresetNames();
/// Harder gardens for segmentation, each a case that once failed or a corner of the issue's
/// range: "pair" (two balls, the hedge row between them), "low_camera" (0.8 m up: the lawn by
/// the pot seen edge-on), "high_camera" (1.5 m up, 15 degrees down), "small_far" (r 420 mm at
/// 2.6 m), "big_near" (r 600 mm at 2.0 m), "off_centre" (near the image's right edge),
/// "touching" (three r 450 mm balls in a row, touching, at 2.5 m), "left_edge" (near the image's
/// left edge), "cut_by_frame" (half out of the image on the right), "shrubs" (a ball with a
/// four-lobed shrub against it and a two-lobed one apart).
std::vector<std::string> GardenHardPresetNames();
/// Gardens across leaves, named after the hedges they imitate, two gardens each: NAME (sun; a
/// small ball near and a larger one far) and NAME_dome (overcast; a dome sunk into the lawn and
/// a small ball near). boxwood: leaves 14 x 9 mm, flat, 20 mm shell, dense and clipped; yew:
/// needles 20 x 4 mm, 50 mm shell; privet: leaves 30 x 14 mm, cupped, 45 mm shell; holly:
/// leaves 55 x 30 mm, strongly cupped, 80 mm shell, gappy. Balls of r 300-1000 mm, centres
/// 1.5-3 m from the camera.
std::vector<std::string> GardenLeafPresetNames();

/// Creates `dir` (throwing hedgefit::Error when it cannot) and writes rig_truth.json and
/// rig.yaml, the exact rig, for `rig`. Returns their paths.
std::vector<std::string> StartSimulationDir(const std::string& dir, const SimRig& rig);

/// Garden captures by any renderer into `dir`: StartSimulationDir, then for each preset
/// garden_NAME_left/right.png from `render(scene, right)` and garden_NAME.truth.json, each hedge's
/// envelope and mean leaf-surface radius `surface(scene, i)`. Returns the files written.
std::vector<std::string> WriteGardenWith(const std::string& dir, const SimRig& rig,
                                         const std::vector<std::string>& presets,
                                         const std::function<cv::Mat(const GardenScene&, bool right)>& render,
                                         const std::function<double(const GardenScene&, std::size_t)>& surface);

/// Writes garden captures into `dir`: for each preset, NAME_left.png / NAME_right.png and
/// NAME.truth.json listing every hedge, plus rig_truth.json and rig.yaml (the exact rig: a garden
/// has no boards to calibrate from). Returns the files written.
std::vector<std::string> WriteGarden(const std::string& dir, double scale, const RenderOptions& options,
                                     const std::vector<std::string>& presets = GardenPresetNames());

/// The board's inner corners in the world frame.
std::vector<cv::Point3d> BoardInnerCornersWorld(const BoardScene& board);

/// The sphere's truth file (eval/truth_file.hpp), in the left camera frame.
void WriteSphereTruth(const std::string& path, const SphereScene& scene);

/// A board's truth: squares, square size, left_camera_from_board rotation (matrix and
/// Rodrigues vector) and translation (mm).
void WriteBoardTruth(const std::string& path, const BoardScene& board);

/// The paper's lab scenes: 16 board poses (1.0-1.6 m away, tilted up to 30 degrees, spread
/// over the view) and a r = 300 mm sphere at Z = 2000, 2100, ... 2600 mm. Every renderer of
/// the lab (WritePaperLab, WritePovrayLab) draws these.
std::vector<BoardScene> PaperLabBoards();

/// 12 more board poses (the same board) for calibration, where the lab's leave gaps: near the
/// image's edges and corners, 0.85-1.05 m away, tilted 30 degrees about the vertical axis and
/// 20 about the horizontal one, so the principal point and the distortion are pinned down.
/// `simulate --preset wide-boards` writes them as board_17 .. board_28.
std::vector<BoardScene> WideBoards();
std::vector<SphereScene> PaperLabSpheres();

/// Writes the paper's laboratory test into `dir`: 16 board pairs (board_NN_left/right.png)
/// and the r = 300 mm sphere at Z = 2000, 2100, ..., 2600 mm (sphere_ZZZZ_left/right.png),
/// each with a truth JSON, plus rig_truth.json. Returns the files written.
std::vector<std::string> WritePaperLab(const std::string& dir, double scale, const RenderOptions& options);

/// The simulated rig as a calibrated one (exact intrinsics and extrinsics), rectified by
/// cv::stereoRectify: for tests and benchmarks that must not depend on calibration error.
stereo::StereoRig RigFromSimulation(const SimRig& sim);

/// The rig as JSON (K, distortion, R, T, image size) for truth files.
std::string RigJson(const SimRig& rig);

}  // namespace hedgefit::sim
