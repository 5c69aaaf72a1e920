#pragma once
/// cloud/'s built-in stages: readers.*, writers.* and filters.*.

#include "pipeline/registry.hpp"

namespace hedgefit::cloud {

/// Adds readers.*, writers.* and filters.* to `registry`.
void RegisterCloudStages(pipeline::Registry& registry);

}  // namespace hedgefit::cloud
