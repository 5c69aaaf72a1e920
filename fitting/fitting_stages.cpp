// Thin adapters from declared options to the fitting free functions.

#include "fitting/fitting_stages.hpp"

#include <cmath>

#include "cloud/point_cloud.hpp"
#include "fitting/evaluation.hpp"
#include "fitting/methods.hpp"

namespace hedgefit::fitting {

namespace {

using cloud::Context;
using cloud::Options;

void Record(Context& ctx, const SphereFitResult& r) {
  for (auto& [key, value] : FitFields(r)) {
    if (key != "method" && !(key == "message" && r.message.empty())) ctx.Note(key, value);
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
              std::vector<std::size_t> finite_index;
              std::vector<Eigen::Vector3d> pts;
              for (std::size_t i = 0; i < c.size(); ++i) {
                if (IsFinite(c.points_mm[i])) {
                  pts.push_back(c.points_mm[i].cast<double>());
                  finite_index.push_back(i);
                }
              }
              std::vector<std::size_t> inliers;
              FitInputs in;
              in.points_mm = &pts;
              in.seed = ctx.seed;
              in.inliers = m.has_inliers ? &inliers : nullptr;
              const auto* fits = ctx.Find<std::vector<SphereFitResult>>("fits");
              if (fits != nullptr && !fits->empty() && fits->back().converged) in.previous = &fits->back().sphere;
              SphereFitResult res;
              try {
                res = fit(in);
              } catch (const Error& e) {
                throw Error("stage '" + m.stage + "', " + e.what());
              }
              if (m.has_inliers) ctx.Note("seed", static_cast<std::int64_t>(in.seed));
              Record(ctx, res);
              if (keep && res.converged) {
                for (auto& i : inliers) i = finite_index[i];
                c = Select(c, inliers);
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
