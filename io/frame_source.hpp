#pragma once
/// Stereo frame sources for a warm process (`hedgefit stream`): two videos or cameras, one
/// side-by-side video or camera, or a directory that NAME_left / NAME_right captures arrive in;
/// and a grabber that reads the next frame on its own thread while the current one is measured.

#include <opencv2/core.hpp>

#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace hedgefit::io {

struct Frame {
  cv::Mat left, right;
  std::string name;   ///< a watched capture's name; empty for video
  double time_s = 0;  ///< when it was grabbed, seconds since the epoch
  std::string error;  ///< a watched capture that stayed unreadable: why (left and right are empty)
};

/// A frame source: Next() blocks for the next pair; false at its end.
class Source {
 public:
  virtual ~Source() = default;
  virtual bool Next(Frame* f) = 0;
  /// Frames arrive whether or not they are read (a camera, a directory filling up): when the
  /// measurement falls behind, older frames are dropped.
  virtual bool Live() const = 0;
};

/// Two video files or camera numbers ("0"), grabbed together. `left_label` and `right_label`
/// name them in errors (the flags they came from). Throws hedgefit::Error when one cannot be opened.
std::unique_ptr<Source> OpenVideoPair(const std::string& left, const std::string& right,
                                      const std::string& left_label = "--left",
                                      const std::string& right_label = "--right");

/// One video file or camera whose frames hold left | right.
std::unique_ptr<Source> OpenSideBySide(const std::string& video, const std::string& label = "--side-by-side");

/// NAME_left.* / NAME_right.* pairs arriving in `dir`, taken in name order, each once both files
/// read as images. One that does not (being written, or cut short) is retried until both files
/// have stayed unchanged for 2 s; it is then returned with its error, so a damaged capture is
/// reported, not skipped in silence. Ends after `idle_s` without a new capture.
std::unique_ptr<Source> WatchDirectory(const std::string& dir, double idle_s, const std::string& label = "--watch");

/// Reads frames on its own thread into a one-frame slot. A live source overwrites a frame not yet
/// taken (counted as dropped) when `drop` is set; a file source waits until it is taken.
class Grabber {
 public:
  Grabber(std::unique_ptr<Source> src, bool drop);
  ~Grabber();
  Grabber(const Grabber&) = delete;
  Grabber& operator=(const Grabber&) = delete;
  /// The next frame; false at the source's end. `dropped` counts frames overwritten unread.
  /// Throws hedgefit::Error with the source's error.
  bool Take(Frame* f, long* dropped);

 private:
  void Loop();
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

}  // namespace hedgefit::io
