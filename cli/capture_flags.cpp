#include "cli/capture_flags.hpp"
#include "cloud/cleaning.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"
#include "stereo/image_io.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::cli {

void CaptureFlags::Add(CLI::App* cmd) {
  const std::string find = "Finding the hedge", match = "Matching (stereo.sgbm)",
                    garden = "Hedges by depth (stereo.segment_garden)", other = "Capture";
  cmd->add_option("--matcher", matcher_,
                  "the matching stage: stereo.sgbm, or a plugin's stage that makes 'disparity' (default options)")
      ->capture_default_str()
      ->group(match);
  cmd->add_option("--mask", mask_, "segment with this mask image (drawn on the left view) instead of by colour")
      ->group(find);
  cmd->add_flag("--garden", garden_,
                "always find every hedge by depth (lawn, hedge rows, several hedges): stereo.segment_garden; by "
                "default the colour mask is used where it isolates the hedge and depth where it does not "
                "(--garden-above)")
      ->group(find);
  // The stages' own options, declared once in their tables.
  flags_.Add(cmd, stereo::DepthSegmentOptions::Table().Specs(), {"box", "depth_tolerance"}, find);
  flags_.Add(cmd, stereo::AutoSegmentOptions::Table().Specs(), {"garden_above"}, find);
  flags_.Add(cmd, stereo::MatchOptions::Table().Specs(), {}, match);
  flags_.Add(cmd, stereo::GardenSegmentOptions::Table().Specs(), {}, garden);
  flags_.Add(cmd, stereo::SegmentOptions::Table().Specs(), {}, find);
  flags_.Add(cmd, stereo::ReprojectOptions::Table().Specs(), {}, other);
  cmd->add_flag("--full-frame", full_frame_, "match the whole image, not just the hedge's region (with --organized: every pixel, unless --max-points)")->group(match);
}

stereo::ConvertOptions CaptureFlags::Resolve(const pipeline::Registry& registry) const {
  const pipeline::StageDescriptor& matcher = registry.Get(matcher_, "--matcher: ");
  if (std::find(matcher.info.outputs.begin(), matcher.info.outputs.end(), "disparity") == matcher.info.outputs.end()) {
    throw Error("--matcher " + matcher_ + ": this stage makes no 'disparity'; give a matching stage such as stereo.sgbm");
  }
  // Options: each stage's declared options, as typed (messages name the flag).
  stereo::ConvertOptions o;
  const auto given = flags_.Given();
  auto bind = [&](const auto& table, auto* out, const char* stage) {
    const auto specs = table.Specs();
    std::map<std::string, pipeline::OptionValue> mine;
    for (const auto& spec : specs) {
      if (given.count(spec.name)) mine[spec.name] = given.at(spec.name);
    }
    pipeline::StageInfo info{stage, "", specs, {}, {}, {}};
    *out = table.FromOptions(pipeline::ResolveOptions(info, mine, stage));
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
  // A whole organised frame is a dense map: thinning it to every s-th pixel (max_points) without a
  // word defeated it. Unless --max-points says otherwise, it keeps every pixel.
  if (full_frame_ && o.reproject.organized && !given.count("max_points")) o.match.max_points = 0;
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

}  // namespace hedgefit::cli
