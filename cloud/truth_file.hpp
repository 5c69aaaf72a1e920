#pragma once
/// The ground-truth file of a sphere, in one place: written by `simulate`, the lab renders and
/// the benches, read by `compare`, `render` and the benches.
///   {"center_mm": [x, y, z], "radius_mm": r, "frame": "unrectified left camera, ..."}

#include <Eigen/Core>

#include <string>

namespace hedgefit::cloud {

struct SphereTruth {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();  ///< mm, in `frame`
  double radius_mm = 0;                                  ///< mm
  std::string frame = "unrectified left camera, x right, y down, z forward";
};

/// Writes atomically; throws hedgefit::Error naming the file.
void WriteSphereTruth(const std::string& path, const SphereTruth& truth);

/// Reads and checks (finite centre, radius > 0); throws hedgefit::Error naming the file.
SphereTruth ReadSphereTruth(const std::string& path);

}  // namespace hedgefit::cloud
