#pragma once
// The JSON objects `measure` and `stream` print, one per hedge and fit of a capture pipeline's
// run: the hedge id, the fit's fields (as `compare --format json`), the hedge's image box when
// the garden segmentation found it, and the capture's time. Keys keep this order.

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "cloud/pipeline.hpp"

namespace hedgefit::apps {

struct MeasureLines {
  std::vector<nlohmann::ordered_json> lines;  ///< one per fit, in the pipeline's order
  int converged = 0;
  std::string first_failure;  ///< "hedge N, METHOD: why" of the first fit that did not converge
  /// "hedge N, METHOD: why" of each fit whose points are not a ball's (SphereFitResult::not_a_ball)
  std::vector<std::string> not_balls;
};

/// Millimetres and milliseconds to the micrometre / microsecond (more digits are noise).
nlohmann::ordered_json Rounded(const nlohmann::ordered_json& value);

MeasureLines CollectMeasureLines(cloud::Context& ctx, const cloud::RunReport& report);

/// What a run saw that its user should act on, in one line ("" when nothing):
/// - The paper's colour mask covers most of a garden (lawn, hedge rows and trees are green too)
///   and a fit may then find one ball of a row, or the lawn. When a run's colour mask covers
///   more than half the frame: use --garden. Half the frame: the paper's largest hedge (r 960
///   mm) from 1 m away covers about a quarter.
/// - The rectified rows disagree by more than 0.5 px (stereo.sgbm's estimate): the rig file is
///   not these cameras', or they moved since calibration. The refinement removes it, SGBM's
///   integer search does not (Middlebury Motorcycle, rows already 0.31 px apart: another 0.25 px
///   raises its bad-0.5 from 18.6 to 23.9 %).
std::string CaptureHint(cloud::Context& ctx);

}  // namespace hedgefit::apps
