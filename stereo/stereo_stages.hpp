#pragma once
/// stereo.* pipeline stages: readers.stereo, stereo.rectify, stereo.segment, stereo.sgbm and
/// stereo.reproject, so capture-to-cloud steps join the same pipelines as filters and fitters.

#include "cloud/registry.hpp"

namespace hedgefit::stereo {

/// Adds the stereo stages to `registry`.
void RegisterStereoStages(cloud::Registry& registry);

}  // namespace hedgefit::stereo
