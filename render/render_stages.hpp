#pragma once
/// writers.png: a pipeline can end in a render of its cloud and fits.

#include "pipeline/registry.hpp"

namespace hedgefit::render {

/// Adds writers.png to `registry`.
void RegisterRenderStages(pipeline::Registry& registry);

}  // namespace hedgefit::render
