#include "io/frame_source.hpp"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <set>

#include "io/video.hpp"
#include "pipeline/error.hpp"
#include "stereo/image_io.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::io {

namespace {

namespace fs = std::filesystem;

double Now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

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
  VideoPair(const std::string& l, const std::string& r, const std::string& l_label, const std::string& r_label)
      : left_(Open(l, l_label)), right_(Open(r, r_label)), live_(IsDevice(l)) {}
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
  SideBySide(const std::string& s, std::string label) : cap_(Open(s, label)), label_(std::move(label)), live_(IsDevice(s)) {}
  bool Next(Frame* f) override {
    cv::Mat both;
    if (!cap_->Read(&both) || both.empty()) return false;
    if (both.cols % 2) throw Error(label_ + ": a frame " + std::to_string(both.cols) + " px wide cannot be split into two views");
    f->time_s = Now();
    f->left = both.colRange(0, both.cols / 2).clone();
    f->right = both.colRange(both.cols / 2, both.cols).clone();
    return true;
  }
  bool Live() const override { return live_; }

 private:
  std::unique_ptr<Video> cap_;
  std::string label_;
  bool live_;
};

// NAME_left.* / NAME_right.* pairs arriving in a directory, taken in name order; a pair is
// taken once both files read as images. One that does not (a file still being written, or cut
// short) is retried until both files have stayed unchanged for kSettleS, or the stream stops; it
// is then given up and returned with its error, so a damaged capture is reported, not skipped
// in silence.
class WatchDir : public Source {
 public:
  WatchDir(std::string dir, double idle_s, const std::string& label) : dir_(std::move(dir)), idle_s_(idle_s) {
    std::error_code ec;
    if (!fs::is_directory(dir_, ec)) throw Error(label + " " + dir_ + ": no such directory");
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

}  // namespace

std::unique_ptr<Source> OpenVideoPair(const std::string& left, const std::string& right, const std::string& left_label,
                                      const std::string& right_label) {
  return std::make_unique<VideoPair>(left, right, left_label, right_label);
}

std::unique_ptr<Source> OpenSideBySide(const std::string& video, const std::string& label) {
  return std::make_unique<SideBySide>(video, label);
}

std::unique_ptr<Source> WatchDirectory(const std::string& dir, double idle_s, const std::string& label) {
  return std::make_unique<WatchDir>(dir, idle_s, label);
}

Grabber::Grabber(std::unique_ptr<Source> src, bool drop)
    : src_(std::move(src)), drop_(drop), thread_([this] { Loop(); }) {}

Grabber::~Grabber() {
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

bool Grabber::Take(Frame* f, long* dropped) {
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

void Grabber::Loop() {
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

}  // namespace hedgefit::io
