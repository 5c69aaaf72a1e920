#pragma once
/// fitters.* pipeline stages: each reads the 'cloud' artifact and appends its
/// SphereFitResult to the 'fits' artifact (std::vector<SphereFitResult>).

#include "pipeline/registry.hpp"

namespace hedgefit::fitting {

/// Adds one stage per row of the method table (fitting/methods.hpp) to `registry`.
void RegisterFittingStages(pipeline::Registry& registry);

}  // namespace hedgefit::fitting
