#pragma once
/// One simulated capture written to a directory, as `hedgefit simulate --sphere` and `--board`
/// give it: the pair, its truth, the rig's truth and the exact rig as a rig file (so the capture
/// can be converted or measured without calibrating). And the camera model applied to written pairs.

#include <cstdint>
#include <string>
#include <vector>

#include "sim/camera_model.hpp"
#include "sim/simulator.hpp"

namespace hedgefit::sim {

/// Rewrites every NAME_left.png / NAME_right.png among `files` as `camera` records it, in place.
/// The two views of a pair share a seed (seed * 1000 + pair), which ApplyCameraModel splits per
/// camera; other files are left alone.
void RecordAsCamera(const std::vector<std::string>& files, const CameraModel& camera, std::uint64_t seed);

/// A board posed by a rotation vector (rad) and a translation (mm) in the left camera's frame;
/// `charuco_dictionary` (empty: a chessboard) makes it a ChArUco board. Throws hedgefit::Error
/// for a dictionary or marker size that calibrate could not read.
BoardScene PosedBoard(const std::vector<double>& rvec_tvec, cv::Size squares, double square_mm,
                      const std::string& charuco_dictionary = "", double marker_mm = 0);

/// Writes `dir`/sphere_left.png, sphere_right.png and sphere.truth.json (or board_* and
/// board.truth.json), then rig_truth.json and rig.yaml; the pair as `camera` records it when
/// `record`. Returns the files written.
std::vector<std::string> WriteSphereCapture(const std::string& dir, const SimRig& rig, const SphereScene& scene,
                                            const RenderOptions& options, const CameraModel& camera, bool record,
                                            std::uint64_t seed);
std::vector<std::string> WriteBoardCapture(const std::string& dir, const SimRig& rig, const BoardScene& board,
                                           const RenderOptions& options, const CameraModel& camera, bool record,
                                           std::uint64_t seed);

}  // namespace hedgefit::sim
