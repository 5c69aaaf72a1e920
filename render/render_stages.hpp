#pragma once
/// writers.png: a pipeline can end in a render of its cloud and fits.

#include "cloud/registry.hpp"

namespace hedgefit::render {

/// Adds writers.png to `registry`.
void RegisterRenderStages(cloud::Registry& registry);

}  // namespace hedgefit::render
