#pragma once
// The fitting methods hedgefit compare and hedgefit bench lab run, by name.

#include <string>
#include <vector>

#include "fitting/sphere_fit.hpp"

namespace hedgefit::apps {

inline const std::vector<std::string> kAllMethods = {"kasa",      "pratt",    "taubin",          "hyper",
                                                     "ransac",    "geometric", "ransac_geometric"};

struct FitMethodOptions {
  double ransac_threshold_mm = 10.0;
  double min_radius_mm = 50.0;
  double max_radius_mm = 5000.0;
  double sample_radius_mm = 0.0;
  std::uint64_t seed = 42;
};

/// Runs one named method (see kAllMethods); "ransac_geometric" is RANSAC's inliers refit
/// geometrically from RANSAC's sphere.
fitting::SphereFitResult RunFitMethod(const std::string& method, const std::vector<Eigen::Vector3d>& pts,
                                      const FitMethodOptions& options);

}  // namespace hedgefit::apps
