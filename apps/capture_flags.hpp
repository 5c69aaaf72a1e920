#pragma once
// The capture path's flags, shared by `convert` and `measure`: how the hedge is found
// (colour, --mask, --box, --garden), the matching stage, and every stereo.* stage option,
// generated from the stages' own declarations. One flag sets that option in every stage that
// has it (--min-z in the matcher and the depth segmenter).

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "apps/stage_flags.hpp"
#include "cloud/registry.hpp"
#include "stereo/capture.hpp"

namespace hedgefit::apps {

class CaptureFlags {
 public:
  /// Adds --matcher, --mask, --garden, --full-frame and the stage option flags to `cmd`.
  void Add(CLI::App* cmd);

  /// The capture options as typed, checked: the matcher is a registered stage that makes
  /// 'disparity', one way to find the hedge, every option in range. Throws hedgefit::Error
  /// naming the flag.
  stereo::ConvertOptions Resolve(const cloud::Registry& registry) const;

  bool garden() const { return garden_; }

 private:
  std::string mask_, matcher_ = "stereo.sgbm";
  bool garden_ = false, full_frame_ = false;
  StageFlags flags_;
};

/// cloud::DefaultCleaningJson() as JSON: the cleaning `compare` and `trim` apply by default.
nlohmann::json DefaultCleaning();

/// Checks the images of one capture before any work: each exists and OpenCV can read its
/// format (a missing or unreadable image is bad input, exit 1).
void CheckCaptureImages(const std::string& left, const std::string& right);

/// Checks that the directory `path` would be written into exists, before any work:
/// "`flag` PATH: directory 'D' does not exist; create it first".
/// A path that is a directory is refused the same way ("give a file name in it").
void CheckOutputDirectory(const std::string& flag, const std::string& path);

/// CheckOutputDirectory, and the name ends in a cloud format's extension (.pcd, .ply, .xyz...),
/// so a bad name fails before the work and names the flag, not the writer's temporary file;
/// and it names none of `inputs` (see CheckNotAnInput).
void CheckCloudOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs = {});

/// CheckOutputDirectory, and the name ends in one of `extensions` (".png", ".jpg": any case),
/// which is the format written; and it names none of `inputs`.
void CheckImageOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& extensions,
                      const std::vector<std::string>& inputs = {});

/// An output that is one of the command's own input files (the same file by any path) is
/// refused: an overlay written over the camera's image would lose the capture.
void CheckNotAnInput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs);

}  // namespace hedgefit::apps
