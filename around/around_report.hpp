#pragma once
/// What `measure --manifest` prints: one JSON object per fused hedge, then one per capture (its
/// pose's correction, or why it was left out), as JSON Lines; or a table of both.

#include <ostream>
#include <string>
#include <vector>

#include "around/fusion.hpp"

namespace hedgefit::around {

/// One JSON object per hedge ({"hedge": id, "method": "envelope", "captures", centre_mm,
/// radius_mm, std_error_mm, surface_radius_mm, coverage, ...}), then one per capture ({"capture":
/// name, "used", "correction_mm", ...}); `pretty` indents them.
std::vector<std::string> FuseJsonLines(const FuseResult& result, bool pretty);

/// The same as two tables.
void PrintFuseTable(std::ostream& out, const FuseResult& result);

}  // namespace hedgefit::around
