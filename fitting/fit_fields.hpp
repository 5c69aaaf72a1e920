#pragma once
/// A fit's fields by name: the one list JSON, CSV and pipeline metadata are written from.

#include <string>
#include <utility>
#include <vector>

#include "fitting/sphere_fit.hpp"
#include "pipeline/stage.hpp"

namespace hedgefit::fitting {

/// A fit as named values, the one description of a SphereFitResult that JSON, CSV and pipeline
/// metadata are written from: method, converged, points_used, inliers, iterations, wall_ms,
/// message, and when converged center_mm, radius_mm, rms_mm; std_error_mm where the method has
/// it; surface_radius_mm, leaf_depth_mm and top_bias_mm for the envelope fit.
std::vector<std::pair<std::string, pipeline::OptionValue>> FitFields(const SphereFitResult& fit);

}  // namespace hedgefit::fitting
