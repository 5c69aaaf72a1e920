#pragma once
/// Captures with poses: where each capture's left camera stood in a common frame, so several
/// captures of a hedge can be fused (fusion.hpp). Two ways in:
///  - a manifest (JSON): per capture its `left` and `right` images and `world_from_camera`, a 4 x 4
///    matrix in mm, row-major (p_world = M p_camera, the camera frame OpenCV's: x right, y down,
///    z forward), optionally a `name`, a `time` (s) and a `rig`; a top-level `rig` for all. Paths
///    are relative to the manifest's folder.
///  - a TUM trajectory (`time tx ty tz qx qy qz qw` per line, metres, '#' comments), the usual
///    output of odometry and SLAM, the pose of the left camera's optical frame; each line's capture
///    is the pair TIME_left.png / TIME_right.png (or .jpg) in a folder, TIME read as a number and
///    matched to within a millisecond.

#include <Eigen/Geometry>

#include <optional>
#include <string>
#include <vector>

namespace hedgefit::around {

struct PosedCapture {
  std::string name;   ///< the capture's name (the manifest's, or its time as written)
  std::string left, right;
  std::string rig;    ///< its rig file ("": the one given for all)
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  ///< mm
  std::optional<double> time_s;
};

/// Reads a manifest. Throws hedgefit::InputError naming the file and the entry for a malformed
/// one (a matrix that is not 16 numbers, not rigid to 1e-3, or without left/right).
std::vector<PosedCapture> ReadManifest(const std::string& path);

/// Reads a TUM trajectory and pairs each line with TIME_left / TIME_right in `captures_dir`.
/// Throws hedgefit::InputError naming the file and line for a malformed line, a quaternion far
/// from unit length, or a time no capture has.
std::vector<PosedCapture> ReadTumCaptures(const std::string& trajectory, const std::string& captures_dir);

/// Writes a manifest (paths as given, normally relative to its folder) / a TUM trajectory.
void WriteManifest(const std::string& path, const std::vector<PosedCapture>& captures, const std::string& rig = "");
void WriteTum(const std::string& path, const std::vector<PosedCapture>& captures);

/// The rotation angle of `delta` (degrees) and its translation's length (mm).
double RotationDeg(const Eigen::Isometry3d& delta);

}  // namespace hedgefit::around
