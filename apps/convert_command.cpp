// hedgefit convert: stereo captures -> PCD files (rectify, segment, match, reproject). Around
// each capture's pipeline: stereo/capture_batch.hpp.

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <mutex>

#include "apps/capture_flags.hpp"
#include "apps/commands.hpp"
#include "stereo/stereo_stages.hpp"
#include "cloud/cloud_io.hpp"
#include "apps/parse.hpp"
#include "pipeline/parallel.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "stereo/capture.hpp"
#include "stereo/capture_batch.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::apps {

namespace {

namespace fs = std::filesystem;

struct ConvertArgs {
  std::string left, right, input, rig, output, output_dir = "clouds", shard;
  int threads = 0;
  bool debug = false, quiet = false, print_pipeline = false;
  CaptureFlags capture;
};

// Converts the captures in parallel, printing a line per capture; a failure in a batch is
// reported and skipped, in a single capture it is the run's error.
class Converter {
 public:
  Converter(const ConvertArgs& a, const stereo::ConvertOptions& o, std::vector<stereo::CaptureFiles> captures)
      : a_(a), o_(o), captures_(std::move(captures)), single_(!a.left.empty()) {}

  int Run() {
    const auto t0 = std::chrono::steady_clock::now();
    pipeline::ParallelFor(captures_.size(), a_.threads, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t k = b; k < e; ++k) One(captures_[k]);
    });
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (single_ && failed_) {
      if (first_error_is_input_) throw InputError(first_error_);
      throw ProcessingError(first_error_);
    }
    if (!a_.quiet) {
      std::printf("converted %zu of %zu captures in %.1f s (%.2f s per capture)%s\n", captures_.size() - failed_,
                  captures_.size(), s, s / double(captures_.size()),
                  failed_ ? "; the skipped ones are listed on stderr" : "");
    }
    if (failed_) return kExitProcessing;
    return unusable_ ? kExitUnusable : kExitOk;
  }

 private:
  void One(const stereo::CaptureFiles& c) {
    const std::string out = stereo::PerHedgePath(
        single_ ? a_.output : (fs::path(a_.output_dir) / (c.name + ".pcd")).string(), a_.capture.garden());
    std::string line;
    try {
      // The very pipeline `--print-pipeline` shows.
      pipeline::Pipeline p = pipeline::Pipeline::FromJson(stereo::CapturePipelineJson(o_, c.left, c.right, a_.rig, out),
                                                          "convert", pipeline::Registry::Global());
      pipeline::Context ctx;
      ctx.quiet = true;
      const pipeline::RunReport report = p.Run(ctx);
      if (a_.debug) {
        stereo::WriteDebugPictures((fs::path(out).parent_path() / stereo::StemWithoutHedgeMark(out)).string(), ctx);
      }
      line = stereo::CaptureSummary(c.name, out, ctx, report);
      if (const std::string hint = stereo::CaptureHint(ctx); !hint.empty()) {
        std::lock_guard<std::mutex> lock(io_);
        std::fprintf(stderr, "hedgefit: warning: %s: %s\n", c.name.c_str(), hint.c_str());
      }
      if (stereo::CaptureUnusable(ctx)) ++unusable_;
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(io_);
      ++failed_;
      ++done_;
      if (single_) {
        first_error_ = c.name + ": " + e.what();
        first_error_is_input_ = dynamic_cast<const InputError*>(&e) != nullptr;
      } else {
        // Failures go to stderr even with --quiet: quiet hides progress, not problems.
        std::fprintf(stderr, "[%zu/%zu] %s: skipped: %s\n", done_, captures_.size(), c.name.c_str(), e.what());
      }
      return;
    }
    std::lock_guard<std::mutex> lock(io_);
    ++done_;
    if (!a_.quiet) {
      std::printf("[%zu/%zu] %s\n", done_, captures_.size(), line.c_str());
      std::fflush(stdout);
    }
  }

  const ConvertArgs& a_;
  const stereo::ConvertOptions& o_;
  const std::vector<stereo::CaptureFiles> captures_;
  const bool single_;
  std::mutex io_;
  std::string first_error_;
  bool first_error_is_input_ = false;  // a damaged image: bad input (exit 1), not a failure
  std::size_t done_ = 0;
  std::size_t failed_ = 0;
  std::atomic<std::size_t> unusable_{0};  ///< captures whose rig check found the rig unfit
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
    const std::string shown = stereo::PerHedgePath(single ? a.output : "OUTPUT.pcd", a.capture.garden());
    std::printf("%s\n", stereo::CapturePipelineJson(o, single ? a.left : "LEFT.png", single ? a.right : "RIGHT.png",
                                                    a.rig, shown).c_str());
    return kExitOk;
  }
  if (single) cloud::CheckCloudOutput("-o", a.output);
  stereo::ReadRig(a.rig);  // a bad rig fails once, before any capture
  std::vector<stereo::CaptureFiles> captures;
  if (single) {
    stereo::CheckCaptureImages(a.left, a.right);  // a missing or unreadable image: exit 1, before any work
    captures.push_back({stereo::StemWithoutHedgeMark(a.output), a.left, a.right});
  } else {
    captures = stereo::ListCaptures(a.input);
    fs::create_directories(a.output_dir);
  }
  if (!a.shard.empty()) captures = stereo::Shard(captures, a.shard);
  return Converter(a, o, std::move(captures)).Run();
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
