#pragma once
/// A hedge's outline as seen by a camera: rays from the camera's centre that graze the hedge's
/// envelope (the outermost leaves make the outline). stereo::MeasureOutlines finds them in both
/// rectified views; fitting::FitEnvelope fits the envelope to them together with the front
/// surface's points. In the cloud's frame (the unrectified left camera), mm.

#include <Eigen/Core>

#include <map>
#include <vector>

namespace hedgefit::cloud {

struct TangentRay {
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();      ///< the camera's centre
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();      ///< unit, through the outline point
  double focal_px = 1;  ///< the camera's focal length: an angle of 1 / focal_px radians is one pixel
  int view = 0;         ///< 0 left, 1 right
};

/// Per hedge id (0 for a capture of one hedge): its outline's tangent rays.
using HedgeOutlines = std::map<int, std::vector<TangentRay>>;

}  // namespace hedgefit::cloud
