#pragma once
/// Pipelines in JSON, PDAL-style: an array of stages (or {"pipeline": [...]}).
/// A bare filename is a reader, or a writer when it follows a non-reader stage or
/// ends a pipeline of several; the extension picks which; an object has "type", an optional "tag", and options.
/// Everything is validated when the pipeline is built, before anything runs.

#include <memory>
#include <string>
#include <vector>

#include "cloud/point_cloud.hpp"
#include "cloud/registry.hpp"

namespace hedgefit::cloud {

struct PlannedStage {
  std::string label;  ///< tag if given, else type
  std::string type;
  Options options;    ///< every declared option, resolved
  std::unique_ptr<Stage> stage;
};

struct StageReport {
  std::string label;
  std::string type;
  double wall_ms = 0;
  std::int64_t points_in = -1;   ///< size of 'cloud' before the stage, -1 if none
  std::int64_t points_out = -1;  ///< after
  std::map<std::string, OptionValue> notes;
};

struct RunReport {
  std::vector<StageReport> stages;
  double total_ms = 0;
};

class Pipeline {
 public:
  /// Parses and validates `json_text`; `source` names it in errors. `overrides`
  /// are "label.option=value" strings (label = tag or type) applied on top.
  /// `provided` names artifacts the caller puts into the Context before Run (e.g. images
  /// already in memory), so stages that need them pass the check.
  static Pipeline FromJson(const std::string& json_text, const std::string& source, const Registry& registry,
                           const std::vector<std::string>& overrides = {},
                           const std::vector<std::string>& provided = {});
  static Pipeline FromFile(const std::string& path, const Registry& registry,
                           const std::vector<std::string>& overrides = {});

  /// Runs every stage in order. Throws Error (with the stage's name) on failure.
  RunReport Run(Context& ctx);

  const std::vector<PlannedStage>& stages() const { return stages_; }

  /// The metadata JSON of a run: resolved pipeline, versions, seed, per-stage times and counts.
  std::string MetadataJson(const RunReport& report, const Context& ctx) const;

 private:
  std::vector<PlannedStage> stages_;
};

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

/// Versions of hedgefit and the libraries it was built with, as "name": "version".
std::map<std::string, std::string> LibraryVersions();

}  // namespace hedgefit::cloud
