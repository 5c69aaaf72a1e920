#pragma once
/// What a stage found about the inputs of each hedge's measurement, for the fits to carry into
/// their results: the rig checked against the capture's own images (stereo.rig_check), and what
/// later checks add. Passed between stages as the artifact "input_checks".

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/stage.hpp"

namespace hedgefit::pipeline {

struct InputCheck {
  /// Written into each fit's output as they are, in this order ("rig_check": "widened",
  /// "rig_rows_px": 1.6, ...).
  std::vector<std::pair<std::string, OptionValue>> fields;
  /// Why a result resting on these inputs cannot be acted on; empty = it can.
  std::string unusable;
  /// A warning for the user even when the result stays usable (an interval widened); empty = none.
  std::string warning;
};

/// By hedge id (the cloud's hedge_id); id 0 holds what applies to every hedge of the capture.
using InputChecks = std::map<int, InputCheck>;

/// The check that applies to hedge `id`: its own, else the capture's (id 0); nullptr when none.
inline const InputCheck* CheckFor(const InputChecks& checks, int id) {
  auto it = checks.find(id);
  if (it == checks.end()) it = checks.find(0);
  return it == checks.end() ? nullptr : &it->second;
}

}  // namespace hedgefit::pipeline
