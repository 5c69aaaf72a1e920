// hedgefit convert: stereo captures -> PCD files (rectify, segment, match, reproject).

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "apps/commands.hpp"
#include "apps/capture_flags.hpp"
#include "apps/measure_lines.hpp"
#include "apps/stage_flags.hpp"
#include "cloud/parallel.hpp"
#include "cloud/pipeline.hpp"
#include "cloud/registry.hpp"
#include "cloud/cloud_io.hpp"
#include "stereo/capture.hpp"
#include "stereo/stereo_stages.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::apps {

namespace {

struct Capture {
  std::string name, left, right;
};

// A directory holds NAME_left.png / NAME_right.png (or .jpg) pairs; a manifest has one
// "LEFT RIGHT [NAME]" line per capture.
std::vector<Capture> ListCaptures(const std::string& input) {
  namespace fs = std::filesystem;
  std::vector<Capture> out;
  std::error_code ec;
  if (fs::is_directory(input, ec)) {
    std::vector<std::string> lefts;
    for (const auto& e : fs::directory_iterator(input, ec)) {
      const std::string f = e.path().filename().string();
      const auto pos = f.rfind("_left.");
      if (pos != std::string::npos) lefts.push_back(e.path().string());
    }
    std::sort(lefts.begin(), lefts.end());
    for (const auto& l : lefts) {
      const std::string f = fs::path(l).filename().string();
      const auto pos = f.rfind("_left.");
      std::string r = (fs::path(l).parent_path() / (f.substr(0, pos) + "_right." + f.substr(pos + 6))).string();
      out.push_back({f.substr(0, pos), l, r});
    }
    if (out.empty()) throw Error(input + ": no NAME_left.png / NAME_right.png pairs in this directory");
    return out;
  }
  std::ifstream in(input);
  if (!in) throw Error(input + ": no such manifest or directory");
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    std::istringstream ss(line);
    Capture c;
    if (!(ss >> c.left) || c.left[0] == '#') continue;
    if (!(ss >> c.right)) throw Error(input + ":" + std::to_string(n) + ": expected 'LEFT RIGHT [NAME]'");
    if (!(ss >> c.name)) c.name = fs::path(c.left).stem().string();
    out.push_back(c);
  }
  if (out.empty()) throw Error(input + ": the manifest lists no captures");
  return out;
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
  struct Args {
    std::string left, right, input, rig, output, output_dir = "clouds", shard;
    int threads = 0;
    bool debug = false, quiet = false, print_pipeline = false;
    CaptureFlags capture;
  };
  auto a = std::make_shared<Args>();
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
  cmd->callback([=]() {
    *run = [=]() {
      namespace fs = std::filesystem;
      PrepareRegistry(true);  // a plugin may bring the matcher
      const cloud::Registry& registry = cloud::Registry::Global();
      const stereo::ConvertOptions o = a->capture.Resolve(registry);
      const bool garden = a->capture.garden();
      const bool single = !a->left.empty() || !a->right.empty();
      if (single && !a->input.empty()) throw Error("--input and --left/--right: give one capture or a batch, not both");
      if (single && (a->left.empty() || a->right.empty() || a->output.empty())) {
        throw Error("a single capture needs --left, --right and -o OUTPUT.pcd (or use --input for a batch)");
      }
      if (!single && a->input.empty()) throw Error("give --left/--right/-o for one capture, or --input DIR|MANIFEST");
      if (a->print_pipeline) {
        const std::string shown = single ? a->output : "OUTPUT.pcd";
        std::printf("%s\n", stereo::CapturePipelineJson(o, single ? a->left : "LEFT.png", single ? a->right : "RIGHT.png",
                                                        a->rig, garden && shown.find('#') == std::string::npos
                                                                    ? (fs::path(shown).parent_path() / (fs::path(shown).stem().string() + "_#.pcd")).string()
                                                                    : shown)
                                .c_str());
        return kExitOk;
      }
      if (single) CheckCloudOutput("-o", a->output);
      stereo::ReadRig(a->rig);  // a bad rig fails once, before any capture
      std::vector<Capture> captures;
      if (single) {
        CheckCaptureImages(a->left, a->right);  // a missing or unreadable image: exit 1, before any work
        std::string name = fs::path(a->output).stem().string();  // "row_#" -> "row"
        if (const auto hash = name.rfind('#'); hash != std::string::npos) {
          const bool sep = hash > 0 && (name[hash - 1] == '_' || name[hash - 1] == '-');
          name.erase(sep ? hash - 1 : hash, sep ? 2 : 1);
        }
        captures.push_back({name, a->left, a->right});
      } else {
        captures = ListCaptures(a->input);
        fs::create_directories(a->output_dir);
      }
      if (!a->shard.empty()) {
        int i = -1, n = 0;
        char slash = 0;
        std::istringstream ss(a->shard);
        if (!(ss >> i >> slash >> n) || slash != '/' || n < 1 || i < 0 || i >= n || !ss.eof()) {
          throw Error("--shard '" + a->shard + "': give i/n with 0 <= i < n, e.g. 0/4");
        }
        std::vector<Capture> mine;
        for (std::size_t k = 0; k < captures.size(); ++k) {
          if (int(k % std::size_t(n)) == i) mine.push_back(captures[k]);
        }
        captures = mine;
      }
      std::mutex io;
      std::string first_error;
      bool first_error_is_input = false;  // a damaged image: bad input (exit 1), not a failure
      std::size_t done = 0;
      int failed = 0;
      // Several hedges per capture: one file per hedge, '#' standing for its id.
      auto per_hedge = [&](const std::string& path) {
        if (!garden || path.find('#') != std::string::npos) return path;
        const fs::path p(path);
        return (p.parent_path() / (p.stem().string() + "_#" + p.extension().string())).string();
      };
      auto convert_one = [&](const Capture& c) {
        const std::string out = per_hedge(single ? a->output : (fs::path(a->output_dir) / (c.name + ".pcd")).string());
        std::string line;
        try {
          // The very pipeline `--print-pipeline` shows.
          cloud::Pipeline p = cloud::Pipeline::FromJson(stereo::CapturePipelineJson(o, c.left, c.right, a->rig, out),
                                                        "convert", registry);
          cloud::Context ctx;
          ctx.quiet = true;
          const cloud::RunReport report = p.Run(ctx);
          const cloud::PointCloud& cloud = ctx.Get<cloud::PointCloud>("cloud");
          const cv::Mat& left_rect = ctx.Get<cv::Mat>("left_image");
          if (a->debug) {
            std::string stem = fs::path(out).stem().string();  // "row_#" -> "row"
            if (const auto hash = stem.rfind('#'); hash != std::string::npos) {
              stem.erase(hash > 0 && (stem[hash - 1] == '_' || stem[hash - 1] == '-') ? hash - 1 : hash,
                         hash > 0 && (stem[hash - 1] == '_' || stem[hash - 1] == '-') ? 2 : 1);
            }
            const fs::path base = fs::path(out).parent_path() / stem;
            cv::Mat pair;
            cv::hconcat(left_rect, ctx.Get<cv::Mat>("right_image"), pair);
            stereo::WriteImageAtomic(base.string() + "_rectified.png", pair);
            stereo::WriteImageAtomic(base.string() + "_mask.png", stereo::MaskOverlay(left_rect, ctx.Get<cv::Mat>("mask")));
            stereo::WriteImageAtomic(base.string() + "_disparity.png",
                                   stereo::ColorizeDisparity(ctx.Get<cv::Mat>("disparity")));
          }
          const int* area = ctx.Find<int>("matched_area");
          const cv::Rect* region = ctx.Find<cv::Rect>("matched_region");
          const double matched =
              double(area ? *area : (region ? region->area() : int(left_rect.total()))) / double(left_rect.total());
          char buf[512];
          std::snprintf(buf, sizeof(buf), "%-24s %8zu points %7.0f ms  matched %.1f%% of the frame  -> %s", c.name.c_str(),
                        cloud.size() - cloud::CountNonFinite(cloud), report.total_ms, 100 * matched, out.c_str());
          line = buf;
          if (const std::string hint = CaptureHint(ctx); !hint.empty()) {
            std::lock_guard<std::mutex> lock(io);
            std::fprintf(stderr, "hedgefit: warning: %s: %s\n", c.name.c_str(), hint.c_str());
          }
          if (const auto* hedges = ctx.Find<std::vector<stereo::HedgeRegion>>("hedges")) {
            const auto groups = cloud::HedgeGroups(cloud);
            for (const auto& h : *hedges) {
              std::size_t n = 0;
              for (const auto& g : groups) n = g.id == h.id ? g.indices.size() : n;
              // Without a '#' (the default segmentation found hedges by depth) they share one file,
              // told apart by its hedge_id field.
              std::string file = out;
              if (const auto hash = file.rfind('#'); hash != std::string::npos) file.replace(hash, 1, std::to_string(h.id));
              std::snprintf(buf, sizeof(buf), "\n    hedge %d: box %d,%d,%d,%d px, about r %.0f mm at %.2f m%s, %zu points -> %s",
                            h.id, h.image_box.x, h.image_box.y, h.image_box.width, h.image_box.height,
                            h.approx_radius_mm, h.approx_center_mm[2] / 1000, h.touches_border ? " (cut by the frame)" : "",
                            n, file.c_str());
              line += buf;
            }
          }
        } catch (const std::exception& e) {
          std::lock_guard<std::mutex> lock(io);
          ++failed;
          ++done;
          if (single) {
            first_error = c.name + ": " + e.what();
            first_error_is_input = dynamic_cast<const InputError*>(&e) != nullptr;
          } else {
            // Failures go to stderr even with --quiet: quiet hides progress, not problems.
            std::fprintf(stderr, "[%zu/%zu] %s: skipped: %s\n", done, captures.size(), c.name.c_str(), e.what());
          }
          return;
        }
        std::lock_guard<std::mutex> lock(io);
        ++done;
        if (!a->quiet) {
          std::printf("[%zu/%zu] %s\n", done, captures.size(), line.c_str());
          std::fflush(stdout);
        }
      };
      const auto t0 = std::chrono::steady_clock::now();
      cloud::ParallelFor(captures.size(), a->threads, 1, [&](std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) convert_one(captures[k]);
      });
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (single && failed) {
        if (first_error_is_input) throw InputError(first_error);
        throw ProcessingError(first_error);
      }
      if (!a->quiet) {
        std::printf("converted %zu of %zu captures in %.1f s (%.2f s per capture)%s\n", captures.size() - failed,
                    captures.size(), s, s / double(captures.size()), failed ? "; the skipped ones are listed on stderr" : "");
      }
      return failed ? kExitProcessing : kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
