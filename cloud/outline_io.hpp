#pragma once
/// A capture cloud's outline rays beside it: `convert` writes CLOUD.outline.json next to the
/// cloud it writes, and `compare` (and the readers) read it back, so the envelope fitted to a
/// saved cloud is the one `measure` fits to the capture (issue "one answer whichever path").
/// JSON: {"format": "hedgefit-outline", "version": 1, "cloud_points": N, "hedges": [{"hedge_id":
/// 1, "rays": [[ox, oy, oz, dx, dy, dz, focal_px, view], ...]}, ...]}, in the cloud's frame, mm.
/// cloud_points is the number of points of the cloud it was written beside: a cloud written again
/// without it (a run killed between the two files, another tool) no longer matches its count.

#include <cstddef>
#include <optional>
#include <string>

#include "cloud/outline_rays.hpp"

namespace hedgefit::cloud {

/// CLOUD.outline.json for a cloud at `cloud_path`.
std::string OutlineSidecarPath(const std::string& cloud_path);

/// Writes `outlines` to `path` atomically (temporary file, then rename), for a cloud of
/// `cloud_points` points.
void WriteOutlines(const std::string& path, const HedgeOutlines& outlines, std::size_t cloud_points);

struct OutlineFile {
  HedgeOutlines outlines;
  std::size_t cloud_points = 0;  ///< the cloud's points it was written for
};

/// Reads an outline file; throws hedgefit::InputError naming the file and the fix when it is not
/// one (another format or version, a ray that is not 8 numbers, a non-unit direction).
OutlineFile ReadOutlines(const std::string& path);

/// The outline beside the cloud at `cloud_path` (OutlineSidecarPath), or nullopt when there is
/// none; a damaged one throws as ReadOutlines does, and so does one written for a cloud of
/// another number of points than `cloud_points` (the cloud's as read).
std::optional<HedgeOutlines> ReadOutlineSidecar(const std::string& cloud_path, std::size_t cloud_points);

}  // namespace hedgefit::cloud
