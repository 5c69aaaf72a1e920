// hedgefit stream: a warm process that measures every hedge of every frame of a stereo source
// (two cameras or videos, one side-by-side camera or video, or a directory that captures keep
// arriving in) and prints one JSON line per hedge and frame. The pipeline, its stages (and so
// the rectification maps) are built once; a grabber thread reads the next frame while the
// current one is measured; a live source drops frames rather than falling behind, and says so.

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "apps/capture_flags.hpp"
#include "apps/commands.hpp"
#include "apps/measure_lines.hpp"
#include "apps/video.hpp"
#include "cloud/pipeline.hpp"
#include "cloud/registry.hpp"
#include "fitting/methods.hpp"
#include "stereo/capture.hpp"
#include "stereo/rig.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::apps {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

struct Frame {
  cv::Mat left, right;
  std::string name;  ///< a watched capture's name; empty for video
  double time_s = 0; ///< when it was grabbed, seconds since the epoch
  std::string error; ///< a watched capture that stayed unreadable: why (left and right are empty)
};

double Now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A frame source: Next() blocks for the next pair; false at its end.
class Source {
 public:
  virtual ~Source() = default;
  virtual bool Next(Frame* f) = 0;
  /// Frames arrive whether or not they are read (a camera, a directory filling up): when the
  /// measurement falls behind, older frames are dropped.
  virtual bool Live() const = 0;
};

bool IsDevice(const std::string& s) { return !s.empty() && std::all_of(s.begin(), s.end(), ::isdigit); }

std::unique_ptr<Video> Open(const std::string& what, const std::string& flag) {
  std::unique_ptr<Video> cap;
  if (IsDevice(what)) {
    cap = OpenVideo("", std::stoi(what));
  } else {
    std::error_code ec;
    if (!fs::is_regular_file(what, ec)) throw Error(flag + " " + what + ": no such video file or camera number");
    cap = OpenVideo(what, -1);
  }
  if (!cap) {
    throw Error(flag + " " + what + ": OpenCV cannot open it as a video or camera (give a video file OpenCV reads, or a "
                "camera number such as 0)");
  }
  return cap;
}

class VideoPair : public Source {
 public:
  VideoPair(const std::string& l, const std::string& r)
      : left_(Open(l, "--left")), right_(Open(r, "--right")), live_(IsDevice(l)) {}
  bool Next(Frame* f) override {
    if (!left_->Grab() || !right_->Grab()) return false;  // grab both first: the closest pair in time
    f->time_s = Now();
    return left_->Retrieve(&f->left) && right_->Retrieve(&f->right) && !f->left.empty() && !f->right.empty();
  }
  bool Live() const override { return live_; }

 private:
  std::unique_ptr<Video> left_, right_;
  bool live_;
};

class SideBySide : public Source {
 public:
  explicit SideBySide(const std::string& s) : cap_(Open(s, "--side-by-side")), live_(IsDevice(s)) {}
  bool Next(Frame* f) override {
    cv::Mat both;
    if (!cap_->Read(&both) || both.empty()) return false;
    if (both.cols % 2) throw Error("--side-by-side: a frame " + std::to_string(both.cols) + " px wide cannot be split into two views");
    f->time_s = Now();
    f->left = both.colRange(0, both.cols / 2).clone();
    f->right = both.colRange(both.cols / 2, both.cols).clone();
    return true;
  }
  bool Live() const override { return live_; }

 private:
  std::unique_ptr<Video> cap_;
  bool live_;
};

// NAME_left.* / NAME_right.* pairs arriving in a directory, taken in name order; a pair is
// taken once both files read as images. One that does not (a file still being written, or cut
// short) is retried until both files have stayed unchanged for kSettleS, or the stream stops; it
// is then given up and returned with its error, so a damaged capture is reported, not skipped
// in silence.
class WatchDir : public Source {
 public:
  WatchDir(std::string dir, double idle_s) : dir_(std::move(dir)), idle_s_(idle_s) {
    std::error_code ec;
    if (!fs::is_directory(dir_, ec)) throw Error("--watch " + dir_ + ": no such directory");
  }
  bool Next(Frame* f) override {
    const auto start = std::chrono::steady_clock::now();
    for (;;) {
      std::map<std::string, std::pair<std::string, std::string>> pairs;
      std::error_code ec;
      for (const auto& e : fs::directory_iterator(dir_, ec)) {
        const std::string file = e.path().filename().string();
        for (const char* side : {"_left.", "_right."}) {
          const auto pos = file.rfind(side);
          if (pos == std::string::npos || file[0] == '.') continue;
          auto& p = pairs[file.substr(0, pos)];
          (side[1] == 'l' ? p.first : p.second) = e.path().string();
        }
      }
      for (const auto& [name, p] : pairs) {
        if (done_.count(name) || p.first.empty() || p.second.empty()) continue;
        try {
          f->left = stereo::ReadCaptureImage(p.first);
          f->right = stereo::ReadCaptureImage(p.second);
        } catch (const Error& e) {
          // Not complete yet, or damaged: retried while either file still changes.
          const auto stamp = Stamp(p.first) + "|" + Stamp(p.second);
          auto it = pending_.find(name);
          const auto now = std::chrono::steady_clock::now();
          if (it == pending_.end() || it->second.stamp != stamp) {
            pending_[name] = Pending{stamp, now, e.what()};
            continue;
          }
          it->second.why = e.what();
          if (std::chrono::duration<double>(now - it->second.since).count() < kSettleS) continue;
          return GiveUp(name, f);
        }
        pending_.erase(name);
        done_.insert(name);
        f->name = name;
        f->time_s = Now();
        f->error.clear();
        return true;
      }
      if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > idle_s_) {
        // Stopping: what is still unreadable is reported before the end.
        return !pending_.empty() && GiveUp(pending_.begin()->first, f);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  bool Live() const override { return true; }

 private:
  static constexpr double kSettleS = 2.0;
  struct Pending {
    std::string stamp;                              // both files' sizes and modification times
    std::chrono::steady_clock::time_point since;    // when they last changed
    std::string why;                                // the last read's error
  };
  static std::string Stamp(const std::string& path) {
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    const auto time = fs::last_write_time(path, ec);
    return std::to_string(size) + "@" + std::to_string(time.time_since_epoch().count());
  }
  bool GiveUp(const std::string& name, Frame* f) {
    f->left.release();
    f->right.release();
    f->name = name;
    f->time_s = Now();
    f->error = pending_.at(name).why;
    pending_.erase(name);
    done_.insert(name);
    return true;
  }
  std::string dir_;
  double idle_s_;
  std::set<std::string> done_;
  std::map<std::string, Pending> pending_;
};

// Reads frames on its own thread into a one-frame slot. A live source overwrites a frame not
// yet taken (counted as dropped); a file source waits until it is taken.
class Grabber {
 public:
  Grabber(std::unique_ptr<Source> src, bool drop) : src_(std::move(src)), drop_(drop), thread_([this] { Loop(); }) {}
  ~Grabber() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  /// The next frame; false at the source's end. `dropped` counts frames overwritten unread.
  bool Take(Frame* f, long* dropped) {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return full_ || ended_; });
    if (!error_.empty()) throw Error(error_);
    if (!full_) return false;
    *f = std::move(slot_);
    full_ = false;
    *dropped = dropped_;
    dropped_ = 0;
    cv_.notify_all();
    return true;
  }

 private:
  void Loop() {
    const bool live = drop_ && src_->Live();
    for (;;) {
      Frame f;
      bool ok = false;
      std::string error;
      try {
        ok = src_->Next(&f);
      } catch (const std::exception& e) {
        error = e.what();
      }
      std::unique_lock<std::mutex> lock(m_);
      if (!ok || !error.empty()) {
        ended_ = true;
        error_ = error;
        cv_.notify_all();
        return;
      }
      if (!live) cv_.wait(lock, [&] { return !full_ || stop_; });
      if (stop_) return;
      if (full_) ++dropped_;
      slot_ = std::move(f);
      full_ = true;
      cv_.notify_all();
    }
  }
  std::unique_ptr<Source> src_;
  bool drop_;
  std::mutex m_;
  std::condition_variable cv_;
  Frame slot_;
  bool full_ = false, ended_ = false, stop_ = false;
  long dropped_ = 0;
  std::string error_;
  std::thread thread_;
};

struct StreamArgs {
  std::string rig, left, right, side_by_side, watch, methods = "ransac_ray";
  double idle_s = 10;
  long max_frames = 0;
  bool no_clean = false, no_drop = false;
  CaptureFlags capture;
};

}  // namespace

void AddStreamCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand(
      "stream", "Measure every frame of a stereo camera, two videos or a directory: one JSON line per hedge and frame");
  cmd->footer(
      "Examples:\n"
      "  hedgefit stream --rig rig.yaml --left left.avi --right right.avi\n"
      "  hedgefit stream --rig rig.yaml --left 0 --right 1 --garden          # two cameras (V4L2 devices 0 and 1)\n"
      "  hedgefit stream --rig rig.yaml --side-by-side 0                      # one camera giving left|right frames\n"
      "  hedgefit stream --rig rig.yaml --watch incoming/ --idle-timeout 60   # NAME_left/NAME_right pairs as they arrive\n"
      "Each line is `measure`'s object with the frame number, its time (s since 1970) and, for a directory,\n"
      "the capture's name. A frame without a hedge gives a line with \"hedges\": 0 and the reason. Cameras and a\n"
      "directory drop frames the measurement cannot keep up with (\"dropped\": frames skipped before this one);\n"
      "video files are measured frame by frame. A summary with the time per stage goes to stderr at the end.\n");
  auto a = std::make_shared<StreamArgs>();
  cmd->add_option("--rig", a->rig, "rig file from `hedgefit calibrate`")->required();
  cmd->add_option("--left", a->left, "left video file, or camera number");
  cmd->add_option("--right", a->right, "right video file, or camera number");
  cmd->add_option("--side-by-side", a->side_by_side, "one video file or camera whose frames hold left | right");
  cmd->add_option("--watch", a->watch, "directory that NAME_left.png / NAME_right.png captures arrive in");
  cmd->add_option("--idle-timeout", a->idle_s, "--watch: stop after this long without a new capture, s")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--max-frames", a->max_frames, "stop after this many frames (0 = at the source's end)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--method", a->methods, "fit method(s), comma-separated")->capture_default_str();
  cmd->add_flag("--no-clean", a->no_clean, "fit the raw cloud (no outlier removal: filters.hedge_outlier)");
  cmd->add_flag("--no-drop", a->no_drop, "measure every frame of a camera or directory, however far behind");
  a->capture.Add(cmd);
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      const cloud::Registry& registry = cloud::Registry::Global();
      const stereo::ConvertOptions o = a->capture.Resolve(registry);
      std::vector<std::string> fit_stages;
      for (const auto& name : fitting::ParseMethodList(a->methods, "--method")) {
        fit_stages.push_back(fitting::FindFitMethod(name, "--method").stage);
      }
      const int given = int(!a->left.empty() || !a->right.empty()) + int(!a->side_by_side.empty()) + int(!a->watch.empty());
      if (given != 1) throw Error("give one source: --left and --right, --side-by-side, or --watch");
      if (a->watch.empty() && a->side_by_side.empty() && (a->left.empty() || a->right.empty())) {
        throw Error("--left and --right: give both (video files or camera numbers)");
      }
      // Built once: the rig, the pipeline and its stages.
      const stereo::StereoRig rig = stereo::ReadRig(a->rig);
      cloud::Pipeline p = cloud::Pipeline::FromJson(stereo::MeasurePipelineJson(o, fit_stages, !a->no_clean), "stream",
                                                    registry, {}, {"left_image", "right_image", "rig"});
      std::unique_ptr<Source> src;
      if (!a->watch.empty()) {
        src = std::make_unique<WatchDir>(a->watch, a->idle_s);
      } else if (!a->side_by_side.empty()) {
        src = std::make_unique<SideBySide>(a->side_by_side);
      } else {
        src = std::make_unique<VideoPair>(a->left, a->right);
      }
      Grabber grabber(std::move(src), !a->no_drop);
      long frames = 0, dropped_total = 0;
      double total_ms = 0;
      std::map<std::string, double> stage_ms;
      Frame f;
      long dropped = 0;
      while ((a->max_frames == 0 || frames < a->max_frames) && grabber.Take(&f, &dropped)) {
        dropped_total += dropped;
        json head;
        head["frame"] = frames;
        head["time"] = Rounded(f.time_s);
        if (!f.name.empty()) head["name"] = f.name;
        if (dropped) head["dropped"] = dropped;
        cloud::Context ctx;
        ctx.quiet = true;
        const auto t0 = std::chrono::steady_clock::now();
        try {
          if (!f.error.empty()) throw Error(f.error);
          stereo::PutCapture(f.left, f.right, rig, &ctx);
          const cloud::RunReport report = p.Run(ctx);
          for (const auto& s : report.stages) stage_ms[s.type] += s.wall_ms;
          const MeasureLines m = CollectMeasureLines(ctx, report);
          const std::string hint = CaptureHint(ctx);
          for (const auto& line : m.lines) {
            json j = head;
            for (const auto& [k, v] : line.items()) j[k] = v;
            if (!hint.empty()) j["warning"] = hint;
            std::printf("%s\n", j.dump().c_str());
          }
        } catch (const Error& e) {
          json j = head;
          j["hedges"] = 0;
          j["message"] = e.what();
          std::printf("%s\n", j.dump().c_str());
        }
        std::fflush(stdout);
        total_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        ++frames;
      }
      if (frames == 0) {
        char idle[32];
        std::snprintf(idle, sizeof(idle), "%g", a->idle_s);
        const std::string source = !a->watch.empty() ? "--watch " + a->watch + ": no capture arrived within " + idle +
                                                           " s (--idle-timeout)"
                                 : !a->side_by_side.empty() ? "--side-by-side " + a->side_by_side + ": no frame could be read"
                                                            : "--left " + a->left + ": no frame pair could be read";
        throw ProcessingError(source);
      }
      std::string per_stage;
      for (const auto& [type, ms] : stage_ms) {
        char buf[96];
        std::snprintf(buf, sizeof(buf), "%s%s %.0f", per_stage.empty() ? "" : ", ", type.c_str(), ms / double(std::max(1L, frames)));
        per_stage += buf;
      }
      std::fprintf(stderr, "stream: %ld frames, %ld dropped, %.0f ms per frame (%s ms)\n", frames, dropped_total,
                   total_ms / double(std::max(1L, frames)), per_stage.c_str());
      return frames > 0 ? kExitOk : kExitProcessing;
    };
  });
}

}  // namespace hedgefit::apps
