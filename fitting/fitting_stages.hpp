#pragma once
/// fitters.* pipeline stages: each reads the 'cloud' artifact and appends its
/// SphereFitResult to the 'fits' artifact (std::vector<SphereFitResult>).

#include "cloud/registry.hpp"

namespace hedgefit::fitting {

/// Adds fitters.algebraic, fitters.pratt, fitters.taubin, fitters.hyper, fitters.ransac
/// and fitters.geometric to `registry`.
void RegisterFittingStages(cloud::Registry& registry);

}  // namespace hedgefit::fitting
