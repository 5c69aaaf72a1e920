#pragma once
/// Each posed capture measured alone, the way `measure --garden --method envelope` measures it
/// (every hedge by depth, the default cleaning, each hedge's outline, the envelope fit), kept in
/// its camera frame for fusion.hpp.

#include <string>
#include <vector>

#include "around/fusion.hpp"
#include "around/poses.hpp"
#include "stereo/capture.hpp"

namespace hedgefit::around {

/// The captures a JSON manifest names, or a TUM trajectory with the folder of its captures (give
/// one of `manifest`, `trajectory`), each checked before anything is measured: a rig (its own,
/// else `rig`) that reads, and images that do. `inputs` gets the files read (for an output's
/// check that it overwrites none).
std::vector<PosedCapture> ReadPosedCaptures(const std::string& manifest, const std::string& trajectory,
                                            const std::string& captures_dir, const std::string& rig,
                                            std::vector<std::string>* inputs);

/// Measures `capture` with `rig` (the capture's own when it names one). A capture that cannot be
/// measured (no hedge found, an unreadable image) comes back with `failed` set; the caller decides.
View MeasureView(const PosedCapture& capture, const std::string& rig, const stereo::ConvertOptions& options);

/// MeasureView for each capture, in order (one after another: each capture's own stages use both cores).
std::vector<View> MeasureViews(const std::vector<PosedCapture>& captures, const std::string& rig,
                               const stereo::ConvertOptions& options);

}  // namespace hedgefit::around
