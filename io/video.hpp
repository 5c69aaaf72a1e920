#pragma once
/// Video files and cameras for `hedgefit stream`, through OpenCV's videoio. videoio brings about
/// a hundred shared libraries (FFmpeg, GStreamer and theirs) whose loading and symbol lookup cost
/// every run of every command ~90 ms of start-up on this project's 2-core machine, so it lives in
/// a module, libhedgefit_video.so, that only `stream` loads, and only for a video or a camera.

#include <opencv2/core.hpp>

#include <memory>
#include <string>

namespace hedgefit::io {

/// One opened video file or camera: OpenCV's VideoCapture calls, nothing more.
class Video {
 public:
  virtual ~Video() = default;
  virtual bool Grab() = 0;                   ///< VideoCapture::grab
  virtual bool Retrieve(cv::Mat* frame) = 0; ///< VideoCapture::retrieve
  virtual bool Read(cv::Mat* frame) = 0;     ///< VideoCapture::read
};

/// Opens camera number `device` (>= 0), or else the video file `path`; nullptr when OpenCV cannot
/// open it. Throws hedgefit::Error naming the module when libhedgefit_video.so cannot be loaded.
std::unique_ptr<Video> OpenVideo(const std::string& path, int device);

}  // namespace hedgefit::io

/// The module's one entry point (C linkage, looked up by name): a new Video, or nullptr.
#define HEDGEFIT_VIDEO_ENTRY_SYMBOL "hedgefit_open_video"
extern "C" hedgefit::io::Video* hedgefit_open_video(const char* path, int device);
