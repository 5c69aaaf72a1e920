#pragma once
/// A capture cloud's outline rays beside it: `convert` writes CLOUD.outline.json next to the
/// cloud it writes, and `compare` (and the readers) read it back, so the envelope fitted to a
/// saved cloud is the one `measure` fits to the capture (issue "one answer whichever path").
/// JSON: {"format": "hedgefit-outline", "version": 1, "hedges": [{"hedge_id": 1, "rays":
/// [[ox, oy, oz, dx, dy, dz, focal_px, view], ...]}, ...]}, in the cloud's frame, mm.

#include <optional>
#include <string>

#include "cloud/outline.hpp"

namespace hedgefit::cloud {

/// CLOUD.outline.json for a cloud at `cloud_path`.
std::string OutlineSidecarPath(const std::string& cloud_path);

/// Writes `outlines` to `path` atomically (temporary file, then rename).
void WriteOutlines(const std::string& path, const HedgeOutlines& outlines);

/// Reads an outline file; throws hedgefit::InputError naming the file and the fix when it is not
/// one (another format or version, a ray that is not 8 numbers, a non-unit direction).
HedgeOutlines ReadOutlines(const std::string& path);

/// The outline beside the cloud at `cloud_path` (OutlineSidecarPath), or nullopt when there is
/// none; a damaged one throws as ReadOutlines does.
std::optional<HedgeOutlines> ReadOutlineSidecar(const std::string& cloud_path);

}  // namespace hedgefit::cloud
