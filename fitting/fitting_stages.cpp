// Thin adapters from declared options to the fitting free functions.

#include "fitting/fitting_stages.hpp"

#include "cloud/describe.hpp"
#include "pipeline/input_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pipeline/parallel.hpp"
#include "cloud/point_cloud.hpp"
#include "fitting/fit_fields.hpp"
#include "fitting/methods.hpp"
#include "fitting/trim.hpp"
#include "fitting/uncertainty.hpp"

namespace hedgefit::fitting {

namespace {

using pipeline::Context;
using pipeline::Options;

// Notes: the fit's fields; with several hedges, prefixed "hedgeN." so none overwrites another.
// The units policy (cloud/describe.hpp): points in metres are refused with the fix.
void RequireMillimetres(const cloud::PointCloud& c, const std::string& stage) {
  const std::string why = cloud::MetresReason(
      cloud::LargestExtent(c), "read it with scale 1000 (\"scale\": 1000 on the reader, --scale 1000 in compare, render and trim)");
  if (!why.empty()) throw InputError("stage '" + stage + "': " + why);
}

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

namespace {

using namespace hedgefit::cloud;
using namespace hedgefit::pipeline;

// fitters.*: one stage per row of the method table.
void AddFitters(pipeline::Registry& r) {
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
              RequireMillimetres(c, m.stage);
              const std::vector<HedgeGroup> groups = HedgeGroups(c);
              if (groups.empty()) throw Error("stage '" + m.stage + "': no point of the cloud belongs to a hedge (hedge_id >= 1)");
              // Every hedge is fitted on its own (in parallel: a row of hedges costs about what its
              // largest does on two cores), then recorded in id order, so notes, fits and the
              // first error reported do not depend on timing.
              const auto* earlier = ctx.Find<std::vector<SphereFitResult>>("fits");
              const auto* point_perturbation = ctx.Find<cloud::PointPerturbation>("point_perturbation");
              const auto* disparity_perturbation = ctx.Find<cloud::PointPerturbation>("disparity_perturbation");
              const auto* input_checks = ctx.Find<pipeline::InputChecks>("input_checks");
              const auto* outlines = ctx.Find<cloud::HedgeOutlines>("outlines");
              // A cloud shifted on reading (PointCloud::offset) is fitted in its own frame and its
              // fits are recorded in the file's, as every report gives them.
              const Eigen::Vector3d offset = c.offset;
              std::vector<Sphere> starts(groups.size());
              std::vector<SphereFitResult> results(groups.size());
              std::vector<std::vector<std::size_t>> inliers(groups.size());
              std::vector<std::string> errors(groups.size());
              const std::uint64_t seed = ctx.seed;
              ParallelFor(groups.size(), 0, 1, [&](std::size_t b, std::size_t e) {
                for (std::size_t k = b; k < e; ++k) {
                  const HedgeGroup& g = groups[k];
                  const std::vector<Eigen::Vector3d> pts = PointsAt(c, g.indices);
                  const std::vector<double> pixel_mm = FieldAt(c, kPixelSizeField, g.indices);
                  // A fused cloud says where each point was seen from.
                  std::vector<Eigen::Vector3d> views;
                  const std::vector<double> vx = FieldAt(c, "view_x_mm", g.indices), vy = FieldAt(c, "view_y_mm", g.indices),
                                            vz = FieldAt(c, "view_z_mm", g.indices);
                  if (vx.size() == pts.size() && vy.size() == pts.size() && vz.size() == pts.size()) {
                    for (std::size_t i = 0; i < pts.size(); ++i) views.emplace_back(vx[i], vy[i], vz[i]);
                  }
                  FitInputs in;
                  in.points_mm = &pts;
                  in.pixel_mm = &pixel_mm;
                  in.viewpoints = &views;
                  in.seed = seed;
                  in.inliers = m.has_inliers ? &inliers[k] : nullptr;
                  in.one_hedge = g.id >= 1;
                  if (outlines) {  // stereo.outline: this hedge's outline
                    const auto it = outlines->find(g.id);
                    if (it != outlines->end()) in.outline = &it->second;
                  }
                  // 'previous': the latest converged fit of this hedge.
                  if (earlier) {
                    for (auto it = earlier->rbegin(); it != earlier->rend(); ++it) {
                      if (it->hedge_id == g.id && it->converged) {
                        starts[k] = it->sphere;
                        starts[k].center_mm -= offset;
                        in.previous = &starts[k];
                        break;
                      }
                    }
                  }
                  try {
                    results[k] = fit(in);
                  } catch (const Error& ex) {
                    errors[k] = "stage '" + m.stage + "'" + (g.id ? ", hedge " + std::to_string(g.id) : "") + ", " + ex.what();
                    continue;
                  }
                  results[k].hedge_id = g.id;
                  // How far it can be trusted: the points' scatter, and the rig's calibration and
                  // the matcher's common offset when the capture stages left their perturbations.
                  AddUncertainty(pts, point_perturbation, &results[k], disparity_perturbation);
                  // What the capture's checks found about this hedge's inputs (stereo.rig_check).
                  if (const pipeline::InputCheck* check = input_checks ? pipeline::CheckFor(*input_checks, g.id) : nullptr) {
                    results[k].checks = check->fields;
                    if (!check->unusable.empty()) results[k].unusable = check->unusable;
                  }
                  results[k].sphere.center_mm += offset;  // last: the uncertainty is taken against the points
                }
              });
              for (const std::string& why : errors) {
                if (!why.empty()) throw Error(why);
              }
              std::vector<std::size_t> kept;
              bool any_converged = false;
              for (std::size_t k = 0; k < groups.size(); ++k) {
                if (m.has_inliers) ctx.Note("seed", static_cast<std::int64_t>(seed));
                if (groups.size() > 1) ctx.Note("hedges", static_cast<std::int64_t>(groups.size()));
                Record(ctx, results[k], groups.size() > 1);
                if (keep && results[k].converged) {
                  any_converged = true;
                  for (std::size_t i : inliers[k]) kept.push_back(groups[k].indices[i]);
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

// filters.trim_depth: the trim plan.
void AddTrimDepth(pipeline::Registry& r) {
  const std::string trim = "filters.trim_depth";
  r.Add(StageInfo{trim,
                  "Trim plan: each point's cut depth past a target sphere (field 'cut_depth', mm, + = cut), the share "
                  "of the surface to cut, depth percentiles and the volume to remove, per hedge",
                  {DoubleOption("radius", 0, "target radius; required", "mm").Range(0, 1e5),
                   ListOption("center", {}, 0,
                              "target centre [x, y, z]; empty = each hedge's latest converged fit", "mm"),
                   DoubleOption("tolerance", 5, "cut depths up to this count as on target", "mm").Min(0),
                   DoubleOption("bin_deg", 0, "angular size of a volume bin; 0 = about 20 points per bin", "deg")
                       .Range(0, 90),
                   IntOption("min_bin_points", 3, "a volume bin with fewer points is unseen").Min(1),
                   ListOption("axes", {}, 0,
                              "a clipped shape as the target: semi-axes [along the heading, across, vertical]; empty = "
                              "the sphere of 'radius' (then only the shape's volume radius is reported in 'radius')",
                              "mm"),
                   DoubleOption("heading", 0, "the shape's first semi-axis, counter-clockwise about 'up' from the x axis", "deg"),
                   StringOption("shape", "ellipsoid",
                                "what 'axes' are the semi-axes of: an ellipsoid, a cylinder (a drum: R, R, half-height), "
                                "a cuboid (a box: half-sides) or a cone (base radius twice, half-height), about the centre")
                       .Choices({"ellipsoid", "cylinder", "cuboid", "cone"}),
                   StringOption("up", "-y",
                                "the vertical the bins' rings are taken about: -y for a camera's cloud (y is down), "
                                "+z for most maps and scans; x, y, z, -x, -y or -z")
                       .Choices({"x", "y", "z", "-x", "-y", "-z"})},
                  {"cloud"},
                  {"cloud", "trim_plans"},
                  {}},
        [trim](const Options& o) -> std::unique_ptr<Stage> {
          const std::vector<double>& axes = o.GetList("axes");
          if (!axes.empty() && (axes.size() != 3 || !(std::min({axes[0], axes[1], axes[2]}) > 0))) {
            throw Error("stage '" + trim + "', option 'axes': give [a, b, c] semi-axes > 0 in mm (along the heading, across, vertical)");
          }
          if (axes.empty() && !(o.GetDouble("radius") > 0)) {
            throw Error("stage '" + trim + "', option 'radius': give the target radius (mm), or 'axes' for a clipped shape");
          }
          const std::vector<double>& center = o.GetList("center");
          if (!center.empty() && center.size() != 3) {
            throw Error("stage '" + trim + "', option 'center': give [x, y, z] in mm, or leave it out to use the fit");
          }
          TrimOptions to;
          to.tolerance_mm = o.GetDouble("tolerance");
          to.bin_deg = o.GetDouble("bin_deg");
          to.min_bin_points = int(o.GetInt("min_bin_points"));
          if (!axes.empty()) to.axes_mm = Eigen::Vector3d(axes[0], axes[1], axes[2]);
          to.heading_deg = o.GetDouble("heading");
          to.shape = o.GetString("shape");
          if ((to.shape == "cylinder" || to.shape == "cone") && !axes.empty() && axes[0] != axes[1]) {
            throw Error("stage '" + trim + "', option 'axes': a " + to.shape + "'s are [R, R, half-height]");
          }
          const std::string up_name = o.GetString("up");
          Eigen::Vector3d up = Eigen::Vector3d::Zero();
          up[up_name.back() - 'x'] = up_name[0] == '-' ? -1 : 1;
          return std::make_unique<LambdaStage>(o, [trim, to, center, up](const Options& opts, Context& ctx) {
            PointCloud& c = ctx.Get<PointCloud>("cloud");
            RequireMillimetres(c, trim);
            const std::vector<HedgeGroup> groups = HedgeGroups(c);
            if (groups.empty()) throw Error("stage '" + trim + "': no point of the cloud belongs to a hedge (hedge_id >= 1)");
            std::vector<float> depth(c.size(), std::numeric_limits<float>::quiet_NaN());
            std::vector<TrimPlan> plans;
            for (const HedgeGroup& g : groups) {
              const std::string hedge = g.id ? "hedge " + std::to_string(g.id) : "the cloud";
              Sphere target;
              TrimOptions hedge_to = to;
              target.radius_mm = to.axes_mm != Eigen::Vector3d::Zero() ? std::cbrt(to.axes_mm.prod()) : opts.GetDouble("radius");
              if (center.size() == 3) {
                target.center_mm = Eigen::Vector3d(center[0], center[1], center[2]) - c.offset;  // given in the file's frame
              } else {
                const SphereFitResult* fit = nullptr;
                const SphereFitResult* failed = nullptr;  // the last fit of this hedge that failed, for its reason
                if (const auto* fits = ctx.Find<std::vector<SphereFitResult>>("fits")) {
                  for (auto it = fits->rbegin(); it != fits->rend() && !fit; ++it) {
                    if (it->hedge_id != g.id) continue;
                    if (it->converged) {
                      fit = &*it;
                    } else if (!failed) {
                      failed = &*it;
                    }
                  }
                }
                if (!fit && failed) {
                  throw Error("stage '" + trim + "': " + hedge + " has no sphere to centre the target on: " +
                              failed->method + " failed (" + failed->message +
                              "); give a cloud of the hedge's surface, or 'center'");
                }
                if (!fit) {
                  throw Error("stage '" + trim + "': " + hedge +
                              " has no converged fit to centre the target on; put a fitters.* stage before it or give 'center'");
                }
                target.center_mm = fit->sphere.center_mm - c.offset;  // fits are in the file's frame
                // A leafy envelope's fit says what share of the leaves lie on it: each bin's
                // radius is then taken where they lie (TrimOptions::clipped_share).
                if (const auto w = fit->Extra("clipped_share")) hedge_to.clipped_share = std::clamp(*w, 0.05, 1.0);
              }
              const std::vector<Eigen::Vector3d> pts = PointsAt(c, g.indices);
              TrimPlan plan = PlanTrim(pts, target, hedge_to, up);
              plan.hedge_id = g.id;
              for (std::size_t k = 0; k < g.indices.size(); ++k) depth[g.indices[k]] = plan.depth_mm[k];
              const std::string prefix = groups.size() > 1 ? "hedge" + std::to_string(g.id) + "." : "";
              ctx.Note(prefix + "target_radius_mm", target.radius_mm);
              ctx.Note(prefix + "cut_share", plan.cut_share);
              ctx.Note(prefix + "cut_p50_mm", plan.cut_p50_mm);
              ctx.Note(prefix + "cut_p90_mm", plan.cut_p90_mm);
              ctx.Note(prefix + "cut_max_mm", plan.cut_max_mm);
              ctx.Note(prefix + "volume_seen_l", plan.volume_seen_l);
              ctx.Note(prefix + "seen_share", plan.seen_share);
              ctx.Note(prefix + "bin_deg", plan.bin_deg);
              plan.depth_mm.clear();  // the field holds them
              plans.push_back(std::move(plan));
            }
            c.fields["cut_depth"] = std::move(depth);
            ctx.Put("trim_plans", std::move(plans));
          });
        });
  r.SetOptionInputs(trim, [](const Options& o) -> std::vector<std::pair<std::string, std::string>> {
    if (o.GetList("center").empty()) return {{"fits", "no option 'center' (the target is centred on the fit)"}};
    return {};
  });
}

}  // namespace

void RegisterFittingStages(pipeline::Registry& r) {
  for (auto add : {&AddFitters, &AddTrimDepth}) add(r);
}

}  // namespace hedgefit::fitting
