#pragma once
// The capture path's flags, shared by `convert` and `measure`: how the hedge is found
// (colour, --mask, --box, --garden), the matching stage, and every stereo.* stage option,
// generated from the stages' own declarations. One flag sets that option in every stage that
// has it (--min-z in the matcher and the depth segmenter).

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "cli/stage_flags.hpp"
#include "cloud/cleaning.hpp"
#include "pipeline/registry.hpp"
#include "stereo/capture.hpp"

namespace hedgefit::cli {

class CaptureFlags {
 public:
  /// Adds --matcher, --mask, --garden, --full-frame and the stage option flags to `cmd`.
  void Add(CLI::App* cmd);

  /// The capture options as typed, checked: the matcher is a registered stage that makes
  /// 'disparity', one way to find the hedge, every option in range. Throws hedgefit::Error
  /// naming the flag.
  stereo::ConvertOptions Resolve(const pipeline::Registry& registry) const;

  bool garden() const { return garden_; }

 private:
  std::string mask_, matcher_ = "stereo.sgbm";
  bool garden_ = false, full_frame_ = false;
  StageFlags flags_;
};

/// cloud::DefaultCleaningJson() as JSON: the cleaning `compare` and `trim` apply by default.
nlohmann::json DefaultCleaning();

}  // namespace hedgefit::cli
