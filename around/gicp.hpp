#pragma once
/// Refinement of registered poses by PCL's generalized ICP (fusion.cpp's "centres+gicp").

#include <Eigen/Geometry>

#include <vector>

#include "around/fusion.hpp"

namespace hedgefit::around {

/// Generalized ICP of each used capture's hedge points against all the other used captures',
/// from `poses` (the anchor stays); a capture's correction is kept when GICP converged and it
/// moved under 50 mm and 2 degrees (a refinement, not a jump). `rms` gets each one's fitness.
void RefineByGicp(const std::vector<View>& views, const std::vector<bool>& used, int anchor, const FuseOptions& o,
                  std::vector<Eigen::Isometry3d>* poses, std::vector<double>* rms);

}  // namespace hedgefit::around
