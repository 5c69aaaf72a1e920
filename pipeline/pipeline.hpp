#pragma once
/// Pipelines in JSON, PDAL-style: an array of stages (or {"pipeline": [...]}).
/// A bare filename is a reader, or a writer when it follows a non-reader stage or
/// ends a pipeline of several; the extension picks which; an object has "type", an optional "tag", and options.
/// Everything is validated when the pipeline is built, before anything runs.

#include <memory>
#include <string>
#include <vector>

#include "pipeline/registry.hpp"

namespace hedgefit::pipeline {

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
  /// Runs stages [first, end) only: a caller that overlaps frames runs a pipeline's head for the
  /// next frame while this frame's tail runs (stereo::OverlappedRunner). Outputs staged by these
  /// stages are renamed into place when they have all succeeded.
  RunReport Run(Context& ctx, std::size_t first, std::size_t end);

  const std::vector<PlannedStage>& stages() const { return stages_; }

  /// The metadata JSON of a run: resolved pipeline, versions, seed, per-stage times and counts.
  std::string MetadataJson(const RunReport& report, const Context& ctx) const;

 private:
  std::vector<PlannedStage> stages_;
};

/// Versions of hedgefit and the libraries it was built with, as "name": "version".
std::map<std::string, std::string> LibraryVersions();

}  // namespace hedgefit::pipeline
