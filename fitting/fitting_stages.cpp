// Thin adapters from declared options to the fitting free functions.

#include "fitting/fitting_stages.hpp"

#include <algorithm>
#include <cmath>

#include "cloud/point_cloud.hpp"
#include "fitting/evaluation.hpp"
#include "fitting/methods.hpp"

namespace hedgefit::fitting {

namespace {

using cloud::Context;
using cloud::Options;

// Notes: the fit's fields; with several hedges, prefixed "hedgeN." so none overwrites another.
void Record(Context& ctx, const SphereFitResult& r, bool per_hedge) {
  const std::string prefix = per_hedge ? "hedge" + std::to_string(r.hedge_id) + "." : "";
  for (auto& [key, value] : FitFields(r)) {
    if (key != "method" && key != "hedge_id" && !(key == "message" && r.message.empty())) ctx.Note(prefix + key, value);
  }
  if (auto* fits = ctx.Find<std::vector<SphereFitResult>>("fits")) {
    fits->push_back(r);
  } else {
    ctx.Put("fits", std::vector<SphereFitResult>{r});
  }
}

}  // namespace

void RegisterFittingStages(cloud::Registry& r) {
  using namespace hedgefit::cloud;
  // One stage per row of the method table.
  for (const FitMethod& m : FitMethods()) {
    std::vector<OptionSpec> options = m.options;
    if (m.has_inliers) options.push_back(BoolOption("keep_inliers", false, "replace 'cloud' by the inliers, for later stages"));
    StageInfo info{m.stage, m.description, options, {"cloud"}, {"fits"}, {}};
    r.Add(info, [m](const Options& o) -> std::unique_ptr<Stage> {
            BoundFit fit;
            try {
              fit = m.bind(o);
            } catch (const Error& e) {
              throw Error("stage '" + m.stage + "', " + e.what());
            }
            const bool keep = m.has_inliers && o.GetBool("keep_inliers");
            return std::make_unique<LambdaStage>(o, [m, fit, keep](const Options&, Context& ctx) {
              PointCloud& c = ctx.Get<PointCloud>("cloud");
              // A capture with several hedges (a hedge_id field): one fit per hedge.
              const std::vector<HedgeGroup> groups = HedgeGroups(c);
              if (groups.empty()) throw Error("stage '" + m.stage + "': no point of the cloud belongs to a hedge (hedge_id >= 1)");
              std::vector<std::size_t> kept;
              bool any_converged = false;
              for (const HedgeGroup& g : groups) {
                std::vector<Eigen::Vector3d> pts;
                pts.reserve(g.indices.size());
                for (std::size_t i : g.indices) pts.push_back(c.points_mm[i].cast<double>());
                std::vector<std::size_t> inliers;
                FitInputs in;
                in.points_mm = &pts;
                in.seed = ctx.seed;
                in.inliers = m.has_inliers ? &inliers : nullptr;
                // 'previous': the latest converged fit of this hedge.
                if (const auto* fits = ctx.Find<std::vector<SphereFitResult>>("fits")) {
                  for (auto it = fits->rbegin(); it != fits->rend(); ++it) {
                    if (it->hedge_id == g.id && it->converged) {
                      in.previous = &it->sphere;
                      break;
                    }
                  }
                }
                SphereFitResult res;
                try {
                  res = fit(in);
                } catch (const Error& e) {
                  throw Error("stage '" + m.stage + "'" + (g.id ? ", hedge " + std::to_string(g.id) : "") + ", " + e.what());
                }
                res.hedge_id = g.id;
                if (m.has_inliers) ctx.Note("seed", static_cast<std::int64_t>(in.seed));
                if (groups.size() > 1) ctx.Note("hedges", static_cast<std::int64_t>(groups.size()));
                Record(ctx, res, groups.size() > 1);
                if (keep && res.converged) {
                  any_converged = true;
                  for (std::size_t i : inliers) kept.push_back(g.indices[i]);
                }
              }
              if (keep && any_converged) {
                std::sort(kept.begin(), kept.end());
                c = Select(c, kept);
              }
            });
          });
  }
  for (const char* stage : {"fitters.geometric", "fitters.envelope"}) {
    r.SetOptionInputs(stage, [](const Options& o) -> std::vector<std::pair<std::string, std::string>> {
      if (o.GetString("initial") == "previous") return {{"fits", "option 'initial' = previous (start from an earlier fit)"}};
      return {};
    });
  }
}

}  // namespace hedgefit::fitting
