#pragma once
/// The measuring layer's stages, which need a fit (fitting/) and the images (stereo/) at once:
/// stereo.outline (each hedge's outline in both rectified views about its envelope fitted to the
/// cloud, for fitters.envelope) and writers.outline (the same, about the cloud as compare cleans
/// it, written beside a saved cloud so that compare's envelope on it is measure's). Their names
/// are the ones pipelines have always used.

#include "pipeline/registry.hpp"

namespace hedgefit::measure {

/// Adds stereo.outline and writers.outline to `registry`.
void RegisterMeasureStages(pipeline::Registry& registry);

}  // namespace hedgefit::measure
