#pragma once
/// A Monte-Carlo model of a systematic error source, passed between stages as the artifact
/// "point_perturbation": the stereo stages make one from the rig's calibration covariance, and
/// the fitting stages refit each perturbed copy of a hedge's points to learn how far the rig's
/// uncertainty moves the fit.

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

namespace hedgefit::cloud {

struct PointPerturbation {
  std::string source;  ///< what is perturbed, for reports ("rig covariance")
  int samples = 0;     ///< how many draws `apply` can make (0..samples-1)
  /// Writes `in` as it would have been measured under draw `sample` into `out` (same size;
  /// NaN where a point cannot be measured under that draw).
  /// Called from several threads at once (the fits refit the draws in parallel): must not mutate.
  std::function<void(int sample, const std::vector<Eigen::Vector3d>& in, std::vector<Eigen::Vector3d>* out)> apply;
};

}  // namespace hedgefit::cloud
