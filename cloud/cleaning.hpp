#pragma once
/// The default cleaning of a cloud, as filter stages run outside any user pipeline.

#include <string>

#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud {

/// The cleaning `compare`, `measure`, `stream`, `trim`, `bench garden` (and the Python module)
/// apply unless told otherwise, as a JSON array of stages: NaN removal, then filters.hedge_outlier
/// (HedgeOutlierRemoval). On a stereo capture's cloud of one hedge (a pixel_mm field, no hedge_id)
/// that is the local outlier factor and the spacing ratio, which between them drop mismatches
/// floating off the surface, alone or among others, and keep the sphere's sparse outline; on any
/// other cloud the statistical filter (30 neighbours, 1 sigma), as before. (That filter trims
/// wherever a cloud is sparse: the outline of every stereo sphere, and 55 % of the far wall of
/// PCL's real stereo table scene.)
std::string DefaultCleaningJson();

/// Runs `stages_json` (a JSON array of filters.* stages, e.g. DefaultCleaningJson()) on `cloud`
/// with hedgefit's built-in stages and returns what they keep. `source` names the stages in
/// errors; a reader, writer or fitter among them is refused.
PointCloud RunFilterStages(const PointCloud& cloud, const std::string& stages_json, const std::string& source);

/// Throws what RunFilterStages would for `stages_json` (bad JSON, a stage that is not a filter,
/// an unknown stage or option) without running it: check before the expensive part of a run.
void CheckFilterStages(const std::string& stages_json, const std::string& source);

}  // namespace hedgefit::cloud
