#include "apps/capture_flags.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>

#include "cloud/cloud_io.hpp"
#include "cloud/error.hpp"
#include "cloud/pipeline.hpp"
#include "stereo/image_io.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::apps {

void CaptureFlags::Add(CLI::App* cmd) {
  cmd->add_option("--matcher", matcher_,
                  "the matching stage: stereo.sgbm, or a plugin's stage that makes 'disparity' (default options)")
      ->capture_default_str();
  cmd->add_option("--mask", mask_, "segment with this mask image (drawn on the left view) instead of by colour");
  cmd->add_flag("--garden", garden_,
                "always find every hedge by depth (lawn, hedge rows, several hedges): stereo.segment_garden; by "
                "default the colour mask is used where it isolates the hedge and depth where it does not "
                "(--garden-above)");
  // The stages' own options, declared once in their tables.
  flags_.Add(cmd, stereo::DepthSegmentOptions::Table().Specs(), {"box", "depth_tolerance"});
  flags_.Add(cmd, stereo::MatchOptions::Table().Specs());
  flags_.Add(cmd, stereo::GardenSegmentOptions::Table().Specs());
  flags_.Add(cmd, stereo::SegmentOptions::Table().Specs());
  flags_.Add(cmd, stereo::ReprojectOptions::Table().Specs());
  flags_.Add(cmd, stereo::AutoSegmentOptions::Table().Specs(), {"garden_above"});
  cmd->add_flag("--full-frame", full_frame_, "match the whole image, not just the hedge's region");
}

stereo::ConvertOptions CaptureFlags::Resolve(const cloud::Registry& registry) const {
  const cloud::StageDescriptor& matcher = registry.Get(matcher_, "--matcher: ");
  if (std::find(matcher.info.outputs.begin(), matcher.info.outputs.end(), "disparity") == matcher.info.outputs.end()) {
    throw Error("--matcher " + matcher_ + ": this stage makes no 'disparity'; give a matching stage such as stereo.sgbm");
  }
  // Options: each stage's declared options, as typed (messages name the flag).
  stereo::ConvertOptions o;
  const auto given = flags_.Given();
  auto bind = [&](const auto& table, auto* out, const char* stage) {
    const auto specs = table.Specs();
    std::map<std::string, cloud::OptionValue> mine;
    for (const auto& spec : specs) {
      if (given.count(spec.name)) mine[spec.name] = given.at(spec.name);
    }
    cloud::StageInfo info{stage, "", specs, {}, {}, {}};
    *out = table.FromOptions(cloud::ResolveOptions(info, mine, stage));
  };
  bind(stereo::SegmentOptions::Table(), &o.segment, "stereo.segment");
  bind(stereo::MaskOptions::Table(), &o.mask, "stereo.mask");
  bind(stereo::DepthSegmentOptions::Table(), &o.depth, "stereo.segment_depth");
  bind(stereo::MatchOptions::Table(), &o.match, "stereo.sgbm");
  bind(stereo::GardenSegmentOptions::Table(), &o.garden, "stereo.segment_garden");
  bind(stereo::ReprojectOptions::Table(), &o.reproject, "stereo.reproject");
  {
    stereo::AutoSegmentOptions a;
    bind(stereo::AutoSegmentOptions::Table(), &a, "stereo.segment_auto");
    o.garden_above = a.garden_above;
  }
  if (full_frame_) o.match.region_only = false;
  o.matcher = matcher_;
  if (int(!mask_.empty()) + int(given.count("box")) + int(garden_) > 1) {
    throw Error("--mask, --box and --garden: give one way to find the hedge, not several");
  }
  if (garden_) {
    o.mode = stereo::SegmentMode::kGarden;
  } else if (!mask_.empty()) {
    o.mode = stereo::SegmentMode::kMask;
    o.mask.filename = mask_;
  } else if (given.count("box")) {
    o.mode = stereo::SegmentMode::kDepth;
  }
  try {
    o.Check();
  } catch (const Error& e) {
    throw Error(AsFlagMessage(e.what()));  // as typed on the command line
  }
  return o;
}

nlohmann::json DefaultCleaning() {
  return nlohmann::json::parse(cloud::DefaultCleaningJson());
}

void CheckCaptureImages(const std::string& left, const std::string& right) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const std::string& image : {left, right}) {
    if (fs::is_directory(image, ec)) throw Error(image + ": is a directory; give the image file in it");
    if (!fs::is_regular_file(image, ec)) throw Error(image + ": no such image file; check the path");
    unsigned char head[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    std::ifstream(image, std::ios::binary).read(reinterpret_cast<char*>(head), sizeof(head));
    stereo::RequireCaptureFormat(image, stereo::SniffImageFormat(head, sizeof(head)));
  }
}

void CheckOutputDirectory(const std::string& flag, const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!path.empty() && (path.back() == '/' || fs::is_directory(path, ec))) {
    throw Error(flag + " " + path + ": is a directory; give a file name in it");
  }
  const fs::path dir = fs::path(path).parent_path();
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    throw Error(flag + " " + path + ": directory '" + dir.string() + "' does not exist; create it first");
  }
}

void CheckCloudOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs) {
  CheckOutputDirectory(flag, path);
  try {
    cloud::FormatFromPath(path);
  } catch (const Error&) {
    throw Error(flag + " " + path + ": not a cloud file name; end it in " + cloud::CloudExtensionList());
  }
  CheckNotAnInput(flag, path, inputs);
}

void CheckImageOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& extensions,
                      const std::vector<std::string>& inputs) {
  CheckOutputDirectory(flag, path);
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
    std::string list;
    for (const std::string& e : extensions) list += (list.empty() ? "" : " or ") + e;
    throw Error(flag + " " + path + ": not an image file name this writes; end it in " + list);
  }
  CheckNotAnInput(flag, path, inputs);
}

void CheckNotAnInput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs) {
  std::error_code ec;
  for (const std::string& in : inputs) {
    if (!in.empty() && std::filesystem::equivalent(path, in, ec)) {
      throw Error(flag + " " + path + ": is the input " + in + "; write it to another file");
    }
  }
}

}  // namespace hedgefit::apps
