#pragma once
/// The drifted-rig suite: captures measured with their rig file changed the way real rigs drift
/// (sim::DriftSuite), each scored against its truth. For every capture, drift and hedge: how far
/// the rig file leaves the rows apart, the error, the stated 95 % interval, and whether the output
/// said so (a widened interval, an unusable result, a refusal). A silent miss is a result
/// outside its interval with nothing said.

#include <string>
#include <vector>

#include "sim/rig_drift.hpp"

namespace hedgefit::bench {

struct DriftOptions {
  std::vector<std::string> lefts;  ///< NAME_left.png of each capture; truth NAME.truth.json beside it
  std::string rig;                 ///< the rig the captures fit
  std::string method = "ransac_ray";
  std::vector<sim::RigDrift> drifts = sim::DriftSuite();
};

struct DriftRow {
  std::string capture, drift;
  bool judgeable = true;       ///< sim::RigDrift::judgeable
  double rows_px = 0;          ///< how far the drift moves the rows apart (sim::RowsApart)
  double check_rows_px = 0;    ///< what the capture's rig check measured around the hedge
  std::string verdict;         ///< ok, widened, unusable, refused
  std::string message;         ///< the refusal's or warning's text
  int hedge = 0;
  double centre_error_mm = 0;  ///< |measured - true centre|
  double radius_error_mm = 0;  ///< measured - true radius
  double ci_centre_mm = 0;     ///< the 95 % interval's half-width along the error's direction
  double ci_radius_mm = 0;
  bool inside = false;         ///< both errors within their intervals
  bool said = false;           ///< widened, unusable or refused
};

std::vector<DriftRow> RunRigDrift(const DriftOptions& options);

/// The table, and a summary: judged (rows > 0.5 px) cases, silent misses, warnings on the
/// calibrated rig.
void PrintRigDrift(const std::vector<DriftRow>& rows);

}  // namespace hedgefit::bench
