#pragma once
/// The paper's lab rendered by an independent ray tracer, POV-Ray (Debian package `povray`),
/// so hedgefit's accuracy is not judged only on the renderer it was tuned on. The scenes are
/// the same (PaperLabBoards, PaperLabSpheres) but everything else is POV-Ray's own: its
/// camera, its adaptive anti-aliasing, its solid textures (granite foliage, a soil ground, a
/// brick wall), an area light with soft shadows and a fill light, so the boards are not evenly
/// lit. The images then go through a CameraModel (noise, gains, vignetting, Bayer).

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "sim/camera_model.hpp"
#include "sim/simulator.hpp"

namespace hedgefit::sim {

/// The POV-Ray rig: the paper's geometry (f = 933.3 px, the same R and T) with pinhole
/// cameras (POV-Ray has no lens distortion) whose principal points are offset by whole pixels
/// (rendered on a larger canvas and cropped). `scale` shrinks it like PaperRig.
SimRig PovrayRig(double scale = 1.0);

/// POV-Ray scene text of a board or a sphere scene seen by the left or right camera of `rig`,
/// for a canvas of `canvas` px (the camera's image plus the crop margin).
std::string PovrayBoardScene(const SimRig& rig, bool right, const BoardScene& board, cv::Size canvas);
std::string PovraySphereScene(const SimRig& rig, bool right, const SphereScene& scene, cv::Size canvas);

/// A garden (GardenScene: the same hedges, pot and camera pose as hedgefit's renderer) in
/// POV-Ray's own terms: each hedge ball is tens of thousands of leaf discs in a shell around a
/// dark body (a third clipped to the envelope, gaps one sees into), a lawn with mowing stripes,
/// a hedge row, a fence and trees, under a low parallel sun from the right (hard shadows).
std::string PovrayGardenScene(const SimRig& rig, bool right, const GardenScene& scene, cv::Size canvas);
/// The left camera's exact view of a POV-Ray garden: one ray per pixel (no anti-aliasing) through
/// the same scene with every texture its distance from the camera (16-bit, 0.12 mm a level, up to
/// 8 m), as points in the left camera frame (CV_32FC3, mm; NaN where nothing within 8 m is hit).
/// The per-pixel truth sim::RenderGardenSurface gives for hedgefit's renderer. Renders in
/// `work_dir`; throws hedgefit::Error without POV-Ray.
cv::Mat RenderPovrayGardenSurface(const SimRig& rig, const GardenScene& scene, const std::string& work_dir);

/// One view of a garden rendered by POV-Ray in `work_dir` (8-bit BGR, before any camera model).
/// Throws hedgefit::Error when POV-Ray is missing or fails.
cv::Mat RenderPovrayGarden(const SimRig& rig, bool right, const GardenScene& scene, const std::string& work_dir);

/// Whether `povray` is on PATH.
bool HavePovray();

/// Renders one view with POV-Ray in `work_dir` and returns the camera's 8-bit BGR image.
/// Throws hedgefit::Error when POV-Ray is missing or fails (naming its log).
cv::Mat RenderPovray(const SimRig& rig, bool right, const std::string& scene_kind_board_or_sphere,
                     const BoardScene& board, const SphereScene& sphere, const std::string& work_dir);

/// WritePaperLab's files (board_NN_*, sphere_ZZZZ_*, truths, rig_truth.json, and rig.yaml, the
/// exact rig) rendered by POV-Ray and recorded through `camera` (noise drawn from `seed`). With
/// `as_rendered_dir`, the spheres are also written there as POV-Ray drew them, before the camera
/// (the source of `bench lab --noise-draws`).
std::vector<std::string> WritePovrayLab(const std::string& dir, double scale, const CameraModel& camera,
                                        std::uint64_t seed = 1, const std::string& as_rendered_dir = "");

/// WriteGarden's files (garden_NAME_left/right.png, garden_NAME.truth.json with each hedge's
/// envelope and mean leaf-surface radius, rig_truth.json, rig.yaml: the exact rig) rendered by
/// POV-Ray on PovrayRig and recorded through `camera`.
std::vector<std::string> WritePovrayGarden(const std::string& dir, double scale, const CameraModel& camera,
                                           const std::vector<std::string>& presets, std::uint64_t seed = 1);

/// WideBoards() as board_17 .. board_28 (images and truths) in `dir`, beside the lab's 16, by
/// `renderer` ("hedgefit" with `options`, or "povray"), recorded through `camera` (noise drawn
/// from `seed`); rig_truth.json is (re)written for that renderer's rig. Returns the files written.
std::vector<std::string> WriteWideBoards(const std::string& dir, const std::string& renderer, double scale,
                                         const RenderOptions& options, const CameraModel& camera,
                                         std::uint64_t seed = 1);

}  // namespace hedgefit::sim
