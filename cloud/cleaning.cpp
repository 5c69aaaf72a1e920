#include "cloud/cleaning.hpp"

#include <nlohmann/json.hpp>

#include <optional>

#include "cloud/cloud_stages.hpp"
#include "pipeline/pipeline.hpp"

namespace hedgefit::cloud {

using pipeline::Context;
using pipeline::Pipeline;
using pipeline::Registry;

std::string DefaultCleaningJson() {
  return R"([{"type": "filters.nonfinite"}, {"type": "filters.hedge_outlier"}])";
}

namespace {

// The filter stages of `stages_json` as a pipeline over a cloud put in the context; none for "[]".
std::optional<Pipeline> FilterStages(const std::string& stages_json, const std::string& source) {
  static const Registry registry = [] {
    Registry r;
    RegisterCloudStages(r);
    return r;
  }();
  nlohmann::json stages;
  try {
    stages = nlohmann::json::parse(stages_json);
  } catch (const nlohmann::json::exception&) {
    throw Error(source + ": invalid JSON; give an array of filter stages, e.g. [{\"type\": \"filters.nonfinite\"}]");
  }
  if (!stages.is_array()) throw Error(source + ": filter stages are a JSON array, e.g. [{\"type\": \"filters.nonfinite\"}]");
  for (const auto& s : stages) {
    const bool filter = s.is_object() && s.contains("type") && s["type"].is_string() &&
                        s["type"].get<std::string>().rfind("filters.", 0) == 0;
    if (!filter) throw Error(source + ": give filters.* stages only (" + s.dump() + " is not one)");
  }
  if (stages.empty()) return std::nullopt;
  return Pipeline::FromJson(stages.dump(), source, registry, {}, {"cloud"});
}

}  // namespace

void CheckFilterStages(const std::string& stages_json, const std::string& source) { FilterStages(stages_json, source); }

PointCloud RunFilterStages(const PointCloud& cloud, const std::string& stages_json, const std::string& source) {
  std::optional<Pipeline> p = FilterStages(stages_json, source);
  if (!p) return cloud;
  Context ctx;
  ctx.quiet = true;
  ctx.Put("cloud", cloud);
  p->Run(ctx);
  return std::move(ctx.Get<PointCloud>("cloud"));
}

}  // namespace hedgefit::cloud
