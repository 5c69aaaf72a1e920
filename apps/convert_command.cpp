// hedgefit convert: stereo captures -> PCD files (rectify, segment, match, reproject). Around
// each capture's pipeline: stereo/capture_batch.hpp.

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "cli/capture_flags.hpp"
#include "apps/commands.hpp"
#include "stereo/stereo_stages.hpp"
#include "cloud/cloud_io.hpp"
#include "cli/parse.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "stereo/capture.hpp"
#include "measure/capture_batch.hpp"
#include "stereo/rig.hpp"
#include "measure/recipes.hpp"

namespace hedgefit::apps {

namespace {

namespace fs = std::filesystem;

struct ConvertArgs {
  std::string left, right, input, rig, output, output_dir = "clouds", shard;
  int threads = 0;
  bool debug = false, quiet = false, print_pipeline = false;
  CaptureFlags capture;
};

int RunConvert(const ConvertArgs& a) {
  PrepareRegistry(true);  // a plugin may bring the matcher
  const stereo::ConvertOptions o = a.capture.Resolve(pipeline::Registry::Global());
  const bool single = !a.left.empty() || !a.right.empty();
  if (single && !a.input.empty()) throw Error("--input and --left/--right: give one capture or a batch, not both");
  if (single && (a.left.empty() || a.right.empty() || a.output.empty())) {
    throw Error("a single capture needs --left, --right and -o OUTPUT.pcd (or use --input for a batch)");
  }
  if (!single && a.input.empty()) throw Error("give --left/--right/-o for one capture, or --input DIR|MANIFEST");
  if (a.print_pipeline) {
    const std::string shown = measure::PerHedgePath(single ? a.output : "OUTPUT.pcd", a.capture.garden());
    std::printf("%s\n", measure::ConvertPipelineJson(o, single ? a.left : "LEFT.png", single ? a.right : "RIGHT.png",
                                                     a.rig, shown).c_str());
    return kExitOk;
  }
  if (single) cloud::CheckCloudOutput("-o", a.output);
  stereo::ReadRig(a.rig);  // a bad rig fails once, before any capture
  std::vector<measure::CaptureFiles> captures;
  if (single) {
    stereo::CheckCaptureImages(a.left, a.right);  // a missing or unreadable image: exit 1, before any work
    captures.push_back({measure::StemWithoutHedgeMark(a.output), a.left, a.right});
  } else {
    captures = measure::ListCaptures(a.input);
    fs::create_directories(a.output_dir);
  }
  if (!a.shard.empty()) captures = measure::Shard(captures, a.shard);
  // A line per capture; a failure in a batch is reported and skipped, in a single capture it is
  // the run's error. Failures go to stderr even with --quiet: quiet hides progress, not problems.
  std::size_t done = 0, failed = 0, unusable = 0;
  measure::CaptureOutcome first_failure;
  const auto output_of = [&](const measure::CaptureFiles& c) {
    return measure::PerHedgePath(single ? a.output : (fs::path(a.output_dir) / (c.name + ".pcd")).string(),
                                a.capture.garden());
  };
  const auto t0 = std::chrono::steady_clock::now();
  measure::ConvertCaptures(o, captures, a.rig, output_of, a.debug, a.threads, [&](const measure::CaptureOutcome& c) {
    const char* name = c.capture->name.c_str();
    ++done;
    if (!c.error.empty()) {
      ++failed;
      if (single) first_failure = c;
      else std::fprintf(stderr, "[%zu/%zu] %s: skipped: %s\n", done, captures.size(), name, c.error.c_str());
      return;
    }
    if (!c.hint.empty()) std::fprintf(stderr, "hedgefit: warning: %s: %s\n", name, c.hint.c_str());
    unusable += c.unusable;
    if (!a.quiet) std::printf("[%zu/%zu] %s\n", done, captures.size(), c.summary.c_str());
    std::fflush(stdout);
  });
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (single && failed) {
    const std::string message = first_failure.capture->name + ": " + first_failure.error;
    if (first_failure.input_error) throw InputError(message);
    throw ProcessingError(message);
  }
  if (!a.quiet) {
    std::printf("converted %zu of %zu captures in %.1f s (%.2f s per capture)%s\n", captures.size() - failed,
                captures.size(), s, s / double(captures.size()), failed ? "; the skipped ones are listed on stderr" : "");
  }
  return failed ? kExitProcessing : unusable ? kExitUnusable : kExitOk;
}

}  // namespace

void AddConvertCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("convert", "Stereo captures to PCD: rectify, segment the hedge, match (improved SGBM), reproject");
  cmd->footer(
      "Examples:\n"
      "  hedgefit convert --left build/lab/sphere_2300_left.png --right build/lab/sphere_2300_right.png \\\n"
      "      --rig build/lab/rig.yaml -o build/sphere_2300.pcd\n"
      "  hedgefit convert --input build/lab --rig build/lab/rig.yaml --output-dir build/clouds --debug\n"
      "  hedgefit convert --input captures.txt --rig rig.yaml --output-dir out --shard 3/8   # one of 8 machines\n"
      "  hedgefit convert --left L.png --right R.png --rig rig.yaml -o out.pcd --print-pipeline  # the same as JSON\n"
      "  hedgefit convert --garden --left build/garden/garden_row_left.png --right build/garden/garden_row_right.png \\\n"
      "      --rig build/garden/rig.yaml -o build/row_#.pcd    # every hedge on the lawn: row_1.pcd, row_2.pcd, ...\n"
      "A directory input takes NAME_left.* / NAME_right.* pairs; a manifest has 'LEFT RIGHT [NAME]' lines.\n"
      "Every stage option below is the stereo.* stage's own (see `hedgefit plugins`); one flag sets it in\n"
      "every stage that has it (--erode, --min-z, ...).\n"
      "--garden finds every hedge by depth and writes one PCD per hedge: '#' in -o (or _# added before the\n"
      "extension) becomes the hedge's id, 1, 2, ... left to right.\n");
  auto a = std::make_shared<ConvertArgs>();
  cmd->add_option("--left", a->left, "left image of one capture");
  cmd->add_option("--right", a->right, "right image of one capture");
  cmd->add_option("--input", a->input, "a directory of NAME_left/NAME_right images, or a manifest file");
  cmd->add_option("--rig", a->rig, "rig file from `hedgefit calibrate`")->required();
  cmd->add_option("-o,--output", a->output, "PCD for a single capture");
  cmd->add_option("--output-dir", a->output_dir, "directory for NAME.pcd (batch)")->capture_default_str();
  a->capture.Add(cmd);
  cmd->add_option("--shard", a->shard, "i/n: convert only every n-th capture starting at i (0-based)");
  cmd->add_option("--threads", a->threads, "captures converted in parallel (0 = all cores)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--debug", a->debug, "also write NAME_rectified.png, NAME_mask.png, NAME_disparity.png");
  cmd->add_flag("--print-pipeline", a->print_pipeline, "print the equivalent pipeline JSON and exit");
  cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary");
  GroupFlags(cmd, {{"Inputs", {"--left", "--right", "--input", "--rig"}}, {"Outputs", {"--output", "--output-dir", "--debug", "--print-pipeline", "--quiet"}}, {"Batch", {"--shard", "--threads"}}});
  cmd->callback([=]() { *run = [=]() { return RunConvert(*a); }; });
}

}  // namespace hedgefit::apps
