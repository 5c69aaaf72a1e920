#pragma once
/// Several captures fused (around::Fuse), from above: every hedge point coloured by the capture
/// that saw it, each capture's camera drawn where it stood (a wedge pointing the way it looked,
/// numbered; grey when left out), each fused hedge's circle with its radius and coverage.

#include <string>

#include "around/fusion.hpp"

namespace hedgefit::around {

/// Draws `result` to a PNG of about `size` px on its longer side, looking down `result.up`; throws
/// hedgefit::Error naming `path` when it cannot be written.
void WriteAroundView(const FuseResult& result, const std::string& path, int size = 1200);

}  // namespace hedgefit::around
