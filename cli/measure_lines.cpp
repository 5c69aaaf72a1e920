#include "cli/measure_lines.hpp"

#include <cmath>
#include <cstdio>

#include "eval/evaluation.hpp"
#include "fitting/fit_fields.hpp"
#include "fitting/sphere_fit.hpp"
#include "stereo/depth_segmentation.hpp"

namespace hedgefit::cli {

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

MeasureLines CollectMeasureLines(pipeline::Context& ctx, const pipeline::RunReport& report) {
  MeasureLines out;
  const auto* hedges = ctx.Find<std::vector<stereo::HedgeRegion>>("hedges");
  const auto* fits = ctx.Find<std::vector<fitting::SphereFitResult>>("fits");
  if (!fits) return out;
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
    if (f.converged && f.not_a_ball) {
      out.not_balls.push_back("hedge " + std::to_string(j["hedge"].get<int>()) + ", " + f.method + ": not a ball: " +
                              *f.not_a_ball);
    }
    if (f.converged) {
      ++out.converged;
    } else if (out.first_failure.empty()) {
      out.first_failure = "hedge " + std::to_string(j["hedge"].get<int>()) + ", " + f.method + ": " + f.message;
    }
    out.lines.push_back(std::move(j));
  }
  return out;
}

}  // namespace hedgefit::cli
