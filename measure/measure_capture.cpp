#include "measure/measure_capture.hpp"

#include <cmath>

#include "fitting/fit_fields.hpp"
#include "fitting/methods.hpp"
#include "measure/capture_batch.hpp"
#include "measure/recipes.hpp"
#include "pipeline/error.hpp"
#include "pipeline/output_check.hpp"
#include "pipeline/registry.hpp"
#include "stereo/depth_segmentation.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::measure {

using json = nlohmann::ordered_json;

json Rounded(const json& v) {
  if (v.is_number_float()) return std::round(v.get<double>() * 1000) / 1000;
  if (v.is_array()) {
    json out = json::array();
    for (const auto& x : v) out.push_back(Rounded(x));
    return out;
  }
  return v;
}

std::string MeasureRecipe(const MeasureRequest& request, const pipeline::Registry& registry, const std::string& left,
                          const std::string& right, const std::string& rig) {
  std::vector<std::string> fit_stages;
  for (const std::string& name : request.methods) fit_stages.push_back(fitting::FindFitMethod(name, "--method").stage);
  nlohmann::json stages = nlohmann::json::parse(
      MeasurePipelineJson(request.capture, fit_stages, request.clean, left, right, rig, request.overlay));
  for (const auto& [name, value] : request.capture_options) {
    bool used = false;
    for (auto& s : stages) {
      const std::string type = s["type"].get<std::string>();
      if (type.rfind("stereo.", 0) != 0 || registry.Get(type, "").info.FindOption(name) == nullptr) continue;
      s[name] = std::visit([](const auto& x) { return nlohmann::json(x); }, value);
      used = true;
    }
    if (!used) throw InputError("measure: no capture stage has an option '" + name + "'; see `hedgefit measure --help`");
  }
  return stages.dump(2);
}

MeasureResult ReadMeasureResult(pipeline::Context& ctx, const pipeline::RunReport& report) {
  MeasureResult out;
  out.total_ms = report.total_ms;
  for (const auto& st : report.stages) out.stage_ms[st.type] += st.wall_ms;
  out.hint = CaptureHint(ctx);
  out.unusable = CaptureUnusable(ctx);
  out.unchecked = CaptureUnchecked(ctx);
  const auto* hedges = ctx.Find<std::vector<stereo::HedgeRegion>>("hedges");
  const auto* fits = ctx.Find<std::vector<fitting::SphereFitResult>>("fits");
  if (!fits) return out;
  out.fits = *fits;
  for (const auto& f : *fits) {
    json j;
    j["hedge"] = f.hedge_id ? f.hedge_id : 1;
    for (const auto& [key, value] : fitting::FitFields(f)) {
      if (key != "hedge_id") j[key] = Rounded(std::visit([](const auto& v) { return json(v); }, value));
    }
    if (hedges) {
      for (const auto& h : *hedges) {
        if (h.id != f.hedge_id) continue;
        j["image_box"] = {h.image_box.x, h.image_box.y, h.image_box.width, h.image_box.height};
        // The fit saw part of the ball: its centre is extrapolated, its errors larger.
        if (h.touches_border) j["cut_by_frame"] = true;
      }
    }
    j["capture_ms"] = Rounded(report.total_ms);
    const std::string who = "hedge " + std::to_string(j["hedge"].get<int>()) + ", " + f.method;
    if (f.converged && f.not_a_ball) out.not_balls.push_back(who + ": not a ball: " + *f.not_a_ball);
    if (f.converged) {
      ++out.converged;
    } else if (out.first_failure.empty()) {
      out.first_failure = who + ": " + f.message;
    }
    out.lines.push_back(std::move(j));
  }
  return out;
}

namespace {

// Runs `p` on `ctx`: an input error stays one (its message names the file); any other failure
// names `capture` (none given: as thrown), unless it names a file already; an overlay that could not be written after
// the fits leaves the measurements, with the reason in output_error.
MeasureResult RunRecipe(pipeline::Pipeline& p, pipeline::Context& ctx, const MeasureRequest& request,
                        const std::string& capture, const std::vector<std::string>& named) {
  ctx.quiet = true;
  pipeline::RunReport report;
  try {
    report = p.Run(ctx);
  } catch (const InputError&) {
    throw;
  } catch (const Error& e) {
    const std::string what = e.what();
    if (!request.overlay.empty() && what.find(request.overlay) != std::string::npos &&
        ctx.Find<std::vector<fitting::SphereFitResult>>("fits")) {
      MeasureResult r = ReadMeasureResult(ctx, report);
      r.output_error = what;
      return r;
    }
    if (capture.empty()) throw;
    for (const std::string& file : named) {
      if (!file.empty() && what.rfind(file + ":", 0) == 0) throw ProcessingError(what);
    }
    throw ProcessingError(capture + ": " + what);
  }
  return ReadMeasureResult(ctx, report);
}

}  // namespace

MeasureResult MeasureCapture(const std::string& left, const std::string& right, const std::string& rig,
                             const MeasureRequest& request, const pipeline::Registry& registry) {
  // The rig and the images are read once, by the recipe's readers.stereo: a file it cannot read is
  // an InputError naming it, before any other stage runs.
  if (!request.overlay.empty()) pipeline::CheckImageOutput("--overlay", request.overlay, {".png", ".jpg", ".jpeg"}, {left, right, rig});
  pipeline::Pipeline p = pipeline::Pipeline::FromJson(MeasureRecipe(request, registry, left, right, rig), "measure", registry);
  pipeline::Context ctx;
  return RunRecipe(p, ctx, request, left, {left, right});
}

MeasureResult MeasureCapture(const cv::Mat& left, const cv::Mat& right, const stereo::StereoRig& rig,
                             const MeasureRequest& request, const pipeline::Registry& registry) {
  pipeline::Pipeline p = pipeline::Pipeline::FromJson(MeasureRecipe(request, registry), "measure", registry, {},
                                                      {"left_image", "right_image", "rig"});
  pipeline::Context ctx;
  stereo::PutCapture(left, right, rig, &ctx);
  return RunRecipe(p, ctx, request, "", {});
}

}  // namespace hedgefit::measure
