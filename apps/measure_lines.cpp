#include "apps/measure_lines.hpp"

#include <cmath>
#include <cstdio>

#include "fitting/evaluation.hpp"
#include "fitting/sphere_fit.hpp"
#include "stereo/garden.hpp"

namespace hedgefit::apps {

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

MeasureLines CollectMeasureLines(cloud::Context& ctx, const cloud::RunReport& report) {
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

std::string CaptureHint(cloud::Context& ctx) {
  std::string hint;
  char buf[256];
  const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
  if (!ctx.Find<std::vector<stereo::HedgeRegion>>("hedges") && mask && !mask->empty()) {
    const double share = double(cv::countNonZero(*mask)) / double(mask->total());
    if (share > 0.5) {
      std::snprintf(buf, sizeof(buf),
                    "the colour mask covers %.0f%% of the frame (a lawn, a hedge row or trees are green too); in a "
                    "garden, --garden finds every hedge by depth",
                    100 * share);
      hint = buf;
      // The default searched by depth and found nothing: say so and why (a pair swapped left for
      // right, or a wrong rig, matches nothing in the working range).
      if (const auto* why = ctx.Find<std::string>("depth_segmentation_failed")) {
        std::snprintf(buf, sizeof(buf),
                      "the colour mask covers %.0f%% of the frame (a lawn, a hedge row or trees are green too) and the "
                      "search by depth found no hedge; check --min-z/--max-z and that left and right are not swapped",
                      100 * share);
        hint = std::string(buf) + " (" + *why + ")";
      }
    }
  }
  if (const double* rows = ctx.Find<double>("vertical_disparity_px"); rows && *rows > 0.5) {
    std::snprintf(buf, sizeof(buf),
                  "the rectified rows disagree by up to %.2f px: the rig file is not these cameras', or they moved "
                  "since calibration; recalibrate (hedgefit calibrate)",
                  *rows);
    hint += (hint.empty() ? "" : "; ") + std::string(buf);
  }
  return hint;
}

}  // namespace hedgefit::apps
