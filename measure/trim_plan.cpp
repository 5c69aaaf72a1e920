#include "measure/trim_plan.hpp"

#include <nlohmann/json.hpp>

#include "cloud/cleaning.hpp"
#include "fitting/methods.hpp"
#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"

namespace hedgefit::measure {

std::string TrimRecipe(const TrimRequest& r) {
  using nlohmann::json;
  if (!(r.radius > 0) && r.axes.empty()) throw InputError("trim: give the target's --radius R (mm), or a clipped shape's --axes A,B,C");
  json reader = {{"filename", r.cloud}};  // the reader chosen by extension
  if (r.scale != 1) reader["scale"] = r.scale;
  json p = json::array({reader});
  if (r.clean) {
    for (const auto& stage : json::parse(cloud::DefaultCleaningJson())) p.push_back(stage);
  }
  if (r.center.empty()) p.push_back({{"type", fitting::FindFitMethod(r.method, "--method").stage}});
  json trim = {{"type", "filters.trim_depth"}, {"radius", r.radius}, {"tolerance", r.tolerance}, {"up", r.up}};
  if (!r.axes.empty()) trim["axes"] = r.axes, trim["heading"] = r.heading, trim["shape"] = r.shape;
  if (!r.center.empty()) trim["center"] = r.center;
  if (r.bin_deg > 0) trim["bin_deg"] = r.bin_deg;
  p.push_back(trim);
  if (!r.output.empty()) p.push_back({{"type", "writers.pcd"}, {"filename", r.output}, {"encoding", "binary_compressed"}});
  return p.dump(2);
}

TrimResult PlanTrim(const TrimRequest& request, const pipeline::Registry& registry) {
  pipeline::Pipeline p = pipeline::Pipeline::FromJson(TrimRecipe(request), "trim", registry);
  pipeline::Context ctx;
  ctx.quiet = true;
  p.Run(ctx);
  TrimResult out;
  out.plans = ctx.Get<std::vector<fitting::TrimPlan>>("trim_plans");
  out.cloud = ctx.Get<cloud::PointCloud>("cloud");
  return out;
}

}  // namespace hedgefit::measure
