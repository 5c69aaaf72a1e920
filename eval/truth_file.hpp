#pragma once
/// The ground-truth file of a sphere, in one place: written by `simulate`, the lab renders and
/// the benches, read by `compare`, `render` and the benches.
///   {"center_mm": [x, y, z], "radius_mm": r, "frame": "unrectified left camera, ..."}
/// A capture with several hedges lists them, in the order hedgefit numbers them (left to right):
///   {"hedges": [{"center_mm": ..., "radius_mm": ..., "surface_radius_mm": ...}, ...], "frame": ...}
/// For a leafy hedge, radius_mm is the outer envelope (where the leaves end) and
/// surface_radius_mm, when given, the mean leaf-surface radius.

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace hedgefit::eval {

struct SphereTruth {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();  ///< mm, in `frame`
  double radius_mm = 0;                                  ///< mm; the envelope of a leafy hedge
  std::optional<double> surface_radius_mm;               ///< mean leaf-surface radius, mm
  std::optional<double> shell_mm;                        ///< depth of the leaf shell below the envelope, mm
  std::string frame = "unrectified left camera, x right, y down, z forward";
};

/// Writes atomically; throws hedgefit::Error naming the file.
void WriteSphereTruth(const std::string& path, const SphereTruth& truth);

/// Writes several hedges' truth ({"hedges": [...]}) atomically.
void WriteSphereTruths(const std::string& path, const std::vector<SphereTruth>& truths);

/// Reads and checks (finite centre, radius > 0); throws hedgefit::Error naming the file.
/// ReadSphereTruth needs a file with exactly one sphere; ReadSphereTruths reads either form.
SphereTruth ReadSphereTruth(const std::string& path);
std::vector<SphereTruth> ReadSphereTruths(const std::string& path);

}  // namespace hedgefit::eval
