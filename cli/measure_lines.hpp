#pragma once
// The JSON objects `measure` and `stream` print, one per hedge and fit of a capture pipeline's
// run: the hedge id, the fit's fields (as `compare --format json`), the hedge's image box when
// the garden segmentation found it, and the capture's time. Keys keep this order.

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "pipeline/pipeline.hpp"

namespace hedgefit::cli {

struct MeasureLines {
  std::vector<nlohmann::ordered_json> lines;  ///< one per fit, in the pipeline's order
  int converged = 0;
  std::string first_failure;  ///< "hedge N, METHOD: why" of the first fit that did not converge
  /// "hedge N, METHOD: why" of each fit whose points are not a ball's (SphereFitResult::not_a_ball)
  std::vector<std::string> not_balls;
};

/// Millimetres and milliseconds to the micrometre / microsecond (more digits are noise).
nlohmann::ordered_json Rounded(const nlohmann::ordered_json& value);

MeasureLines CollectMeasureLines(pipeline::Context& ctx, const pipeline::RunReport& report);

}  // namespace hedgefit::cli
