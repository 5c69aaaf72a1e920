#include "measure/recipes.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>

#include "cloud/cleaning.hpp"
#include "cloud/outline_io.hpp"

namespace hedgefit::measure {

std::string ConvertPipelineJson(const stereo::ConvertOptions& options, const std::string& left,
                                const std::string& right, const std::string& rig, const std::string& output) {
  using nlohmann::json;
  json p = json::parse(stereo::CapturePipelineJson(options, left, right, rig));
  p.push_back({{"type", "writers.pcd"}, {"filename", output}, {"encoding", "binary_compressed"}});
  // The outline beside the cloud (cloud/outline_io.hpp): compare's envelope on it is measure's.
  p.push_back({{"type", "writers.outline"}, {"filename", cloud::OutlineSidecarPath(output)}});
  return p.dump(2);
}

std::string MeasurePipelineJson(const stereo::ConvertOptions& options, const std::vector<std::string>& fit_stages,
                                bool clean, const std::string& left, const std::string& right, const std::string& rig,
                                const std::string& overlay) {
  using nlohmann::json;
  json p = json::parse(stereo::CapturePipelineJson(options, left, right, rig));
  if (clean) {
    for (auto stage : json::parse(cloud::DefaultCleaningJson())) {
      if (options.reference_cleaning && stage["type"] == "filters.hedge_outlier") stage["neighbours"] = "space";
      p.push_back(stage);
    }
  }
  // The envelope fit also fits each hedge's outline, measured about a first fit to the cleaned points.
  if (std::find(fit_stages.begin(), fit_stages.end(), "fitters.envelope") != fit_stages.end()) {
    p.push_back({{"type", "stereo.outline"}});
  }
  for (const std::string& type : fit_stages) p.push_back({{"type", type}});
  if (!overlay.empty()) p.push_back({{"type", "writers.overlay"}, {"filename", overlay}});
  return p.dump(2);
}

}  // namespace hedgefit::measure
