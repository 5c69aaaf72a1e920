// hedgefit convert: stereo captures -> PCD files (rectify, segment, match, reproject).

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

#include "apps/commands.hpp"
#include "cloud/cloud_io.hpp"
#include "stereo/capture.hpp"

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
      "A directory input takes NAME_left.* / NAME_right.* pairs; a manifest has 'LEFT RIGHT [NAME]' lines.\n");
  struct Args {
    std::string left, right, input, rig, output, output_dir = "clouds", shard, mask, box;
    double depth_tolerance = stereo::ConvertOptions{}.depth_tolerance_px;
    double min_z = 1500, max_z = 3500, gamma = 1.5;
    int erode = stereo::SegmentOptions{}.erode_px, block = 5, threads = 0,
        refine_radius = stereo::SgbmOptions{}.refine_radius;
    bool debug = false, organized = false, quiet = false, full_frame = false, keep_filled = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--left", a->left, "left image of one capture");
  cmd->add_option("--right", a->right, "right image of one capture");
  cmd->add_option("--input", a->input, "a directory of NAME_left/NAME_right images, or a manifest file");
  cmd->add_option("--rig", a->rig, "rig file from `hedgefit calibrate`")->required();
  cmd->add_option("-o,--output", a->output, "PCD for a single capture");
  cmd->add_option("--output-dir", a->output_dir, "directory for NAME.pcd (batch)")->capture_default_str();
  cmd->add_option("--min-z", a->min_z, "working range, nearest, mm")->capture_default_str();
  cmd->add_option("--max-z", a->max_z, "working range, farthest, mm")->capture_default_str();
  cmd->add_option("--gamma", a->gamma, "segmentation gamma")->capture_default_str();
  cmd->add_option("--erode", a->erode, "drop this many silhouette pixels from the mask")->capture_default_str();
  cmd->add_option("--block", a->block, "SGBM block size, px (odd)")->capture_default_str();
  cmd->add_option("--refine-radius", a->refine_radius, "sub-pixel refinement window half-size, px (0 = off)")
      ->capture_default_str();
  cmd->add_flag("--keep-filled", a->keep_filled, "also write hole-filled (unmeasured) pixels as points");
  cmd->add_option("--mask", a->mask, "use this mask image (left view) instead of segmentation (single capture)");
  cmd->add_option("--box", a->box,
                  "X,Y,W,H: segment by depth inside this box of the left image instead of by colour (grey images)");
  cmd->add_option("--depth-tolerance", a->depth_tolerance, "with --box: disparity band around the box's middle, px")
      ->capture_default_str();
  cmd->add_option("--shard", a->shard, "i/n: convert only every n-th capture starting at i (0-based)");
  cmd->add_option("--threads", a->threads, "captures converted in parallel (0 = all cores)")->capture_default_str();
  cmd->add_flag("--debug", a->debug, "also write NAME_rectified.png, NAME_mask.png, NAME_disparity.png");
  cmd->add_flag("--organized", a->organized, "keep the image grid in the PCD (NaN where no point)");
  cmd->add_flag("--full-frame", a->full_frame, "match the whole image, not just the hedge's region");
  cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary");
  cmd->callback([=]() {
    *run = [=]() {
      namespace fs = std::filesystem;
      stereo::ConvertOptions o;
      o.min_z_mm = a->min_z;
      o.max_z_mm = a->max_z;
      o.segment.gamma = a->gamma;
      o.segment.erode_px = a->erode;
      o.sgbm.block_size = a->block;
      o.sgbm.refine_radius = a->refine_radius;
      o.reproject.keep_filled = a->keep_filled;
      o.reproject.organized = a->organized;
      o.region_only = !a->full_frame;
      o.mask_path = a->mask;
      o.depth_tolerance_px = a->depth_tolerance;
      if (!a->box.empty()) {
        int bx = 0, by = 0, bw = 0, bh = 0;
        char c1 = 0, c2 = 0, c3 = 0;
        std::istringstream bs(a->box);
        if (!(bs >> bx >> c1 >> by >> c2 >> bw >> c3 >> bh) || c1 != ',' || c2 != ',' || c3 != ',') {
          throw Error("--box '" + a->box + "': give X,Y,W,H in px, e.g. 255,160,80,70");
        }
        o.box = cv::Rect(bx, by, bw, bh);
      }
      try {
        o.Check();
      } catch (const Error& e) {
        // "field: why" -> "--field: why", spelled as the command-line option.
        std::string msg = e.what();
        const auto colon = msg.find(':');
        for (std::size_t i = 0; i < colon && colon != std::string::npos; ++i) {
          if (msg[i] == '_') msg[i] = '-';
        }
        throw Error("--" + msg);
      }
      const stereo::StereoRig rig = stereo::ReadRig(a->rig);
      std::vector<Capture> captures;
      const bool single = !a->left.empty() || !a->right.empty();
      if (single) {
        if (a->left.empty() || a->right.empty() || a->output.empty()) {
          throw Error("a single capture needs --left, --right and -o OUTPUT.pcd (or use --input for a batch)");
        }
        captures.push_back({fs::path(a->output).stem().string(), a->left, a->right});
      } else {
        if (a->input.empty()) throw Error("give --left/--right/-o for one capture, or --input DIR|MANIFEST");
        captures = ListCaptures(a->input);
        fs::create_directories(a->output_dir);
      }
      if (!a->shard.empty()) {
        int i = -1, n = 0;
        char slash = 0;
        std::istringstream ss(a->shard);
        if (!(ss >> i >> slash >> n) || slash != '/' || n < 1 || i < 0 || i >= n) {
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
      std::atomic<std::size_t> next{0}, done{0};
      std::atomic<int> failed{0};
      auto work = [&]() {
        for (;;) {
          const std::size_t k = next.fetch_add(1);
          if (k >= captures.size()) break;
          const Capture& c = captures[k];
          const std::string out = single ? a->output : (fs::path(a->output_dir) / (c.name + ".pcd")).string();
          std::string line;
          try {
            const cv::Mat l = cv::imread(c.left), r = cv::imread(c.right);
            if (l.empty()) throw Error(c.left + ": cannot read the image");
            if (r.empty()) throw Error(c.right + ": cannot read the image");
            if (l.size() != r.size()) throw Error(c.name + ": left and right images differ in size");
            const stereo::ConvertResult res = stereo::ConvertCapture(l, r, rig, o);
            cloud::WriteOptions w;
            w.pcd_encoding = cloud::PcdEncoding::kBinaryCompressed;
            cloud::WriteCloud(out, res.cloud, w);
            if (a->debug) {
              const fs::path base = fs::path(out).parent_path() / fs::path(out).stem();
              cv::Mat pair;
              cv::hconcat(res.left_rect, res.right_rect, pair);
              cv::imwrite(base.string() + "_rectified.png", pair);
              cv::imwrite(base.string() + "_mask.png", stereo::MaskOverlay(res.left_rect, res.mask));
              cv::imwrite(base.string() + "_disparity.png", stereo::ColorizeDisparity(res.disparity));
            }
            char buf[512];
            std::snprintf(buf, sizeof(buf), "%-24s %8zu points %7.0f ms  matched %.1f%% of the frame  -> %s", c.name.c_str(),
                          res.cloud.size() - cloud::CountNonFinite(res.cloud), res.wall_ms, 100 * res.matched_fraction,
                          out.c_str());
            line = buf;
          } catch (const std::exception& e) {
            ++failed;
            const std::size_t n_done = ++done;
            std::lock_guard<std::mutex> lock(io);
            if (single) {
              first_error = c.name + ": " + e.what();
            } else {
              // Failures go to stderr even with --quiet: quiet hides progress, not problems.
              std::fprintf(stderr, "[%zu/%zu] %s: skipped: %s\n", n_done, captures.size(), c.name.c_str(), e.what());
            }
            continue;
          }
          const std::size_t n_done = ++done;
          if (!a->quiet) {
            std::lock_guard<std::mutex> lock(io);
            std::printf("[%zu/%zu] %s\n", n_done, captures.size(), line.c_str());
            std::fflush(stdout);
          }
        }
      };
      const auto t0 = std::chrono::steady_clock::now();
      const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
      const unsigned threads = std::min<unsigned>(a->threads > 0 ? unsigned(a->threads) : hw, unsigned(captures.size()));
      std::vector<std::thread> pool;
      for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
      work();
      for (auto& t : pool) t.join();
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (single && failed) throw ProcessingError(first_error);
      if (!a->quiet) {
        std::printf("converted %zu of %zu captures in %.1f s (%.2f s per capture)%s\n", captures.size() - failed,
                    captures.size(), s, s / double(captures.size()), failed ? "; the skipped ones are listed on stderr" : "");
      }
      return failed ? kExitProcessing : kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
