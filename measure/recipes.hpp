#pragma once
/// The measuring layer's pipeline recipes: what `convert`, `measure`, `stream`, Python and the
/// benches run on a capture, as JSON arrays of stages (docs/pipelines.md). The capture path
/// itself, images to cloud, is stereo's (stereo::CapturePipelineJson); a recipe adds what is
/// done with the cloud.

#include <string>
#include <vector>

#include "stereo/capture.hpp"

namespace hedgefit::measure {

/// `hedgefit convert`'s pipeline: the capture path, then writers.pcd to `output` and
/// writers.outline beside it (cloud/outline_io.hpp: compare's envelope on the saved cloud is
/// measure's). `hedgefit convert --print-pipeline` prints it.
std::string ConvertPipelineJson(const stereo::ConvertOptions& options, const std::string& left,
                                const std::string& right, const std::string& rig, const std::string& output);

/// `hedgefit measure`'s pipeline: the capture path (without a writer), the default cleaning
/// when `clean` (cloud::DefaultCleaningJson), stereo.outline when a fit is fitters.envelope (the
/// outline about a first envelope fit to the cleaned points), one stage per entry of
/// `fit_stages` (e.g. "fitters.ransac_geometric"), and writers.overlay when `overlay` is not
/// empty.
std::string MeasurePipelineJson(const stereo::ConvertOptions& options, const std::vector<std::string>& fit_stages,
                                bool clean, const std::string& left = "", const std::string& right = "",
                                const std::string& rig = "", const std::string& overlay = "");

}  // namespace hedgefit::measure
