// libhedgefit_video.so: OpenCV's VideoCapture behind io/video.hpp's Video (see there why this
// is a module of its own).

#include <opencv2/videoio.hpp>

#include "io/video.hpp"

namespace {

class OpenCvVideo : public hedgefit::io::Video {
 public:
  bool Open(const char* path, int device) { return device >= 0 ? cap_.open(device) : cap_.open(path); }
  bool Grab() override { return cap_.grab(); }
  bool Retrieve(cv::Mat* frame) override { return cap_.retrieve(*frame); }
  bool Read(cv::Mat* frame) override { return cap_.read(*frame); }

 private:
  cv::VideoCapture cap_;
};

}  // namespace

extern "C" __attribute__((visibility("default"))) hedgefit::io::Video* hedgefit_open_video(const char* path,
                                                                                             int device) {
  try {
    auto* v = new OpenCvVideo();
    if (v->Open(path, device)) return v;
    delete v;
  } catch (...) {  // OpenCV's backends may throw on a damaged file: "cannot open", not a crash
  }
  return nullptr;
}
