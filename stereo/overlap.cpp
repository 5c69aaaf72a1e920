#include "stereo/overlap.hpp"

#include <future>
#include <utility>

#include "pipeline/error.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::stereo {

OverlappedRunner::OverlappedRunner(const std::string& pipeline_json, const std::string& source,
                                   const pipeline::Registry& registry)
    : pipeline_(pipeline::Pipeline::FromJson(pipeline_json, source, registry, {}, {"left_image", "right_image", "rig"})) {
  // The head: the leading stages that read only the frame's own images and rig (a reader, the
  // rectification, the segmentation), up to the matcher. They touch nothing shared, so the next
  // frame's can run beside this frame's rest.
  const auto& stages = pipeline_.stages();
  auto ahead = [](const std::string& type) {
    return type.rfind("readers.", 0) == 0 || type == "stereo.rectify" || type.rfind("stereo.segment", 0) == 0 ||
           type == "stereo.mask";
  };
  bool rectified = false;
  for (std::size_t i = 0; i < stages.size() && ahead(stages[i].type); ++i) {
    rectified = rectified || stages[i].type == "stereo.rectify";
    head_ = i + 1;
  }
  if (!rectified) head_ = 0;  // a pipeline of its own making: nothing is overlapped
}

namespace {

struct Frame {
  pipeline::Context ctx;
  pipeline::RunReport report;
  std::string error;
};

}  // namespace

long OverlappedRunner::Run(const StereoRig& rig, const NextFrame& next, const FrameDone& done) {
  // Reads a frame and runs the head on it; false when `next` has no more.
  auto start = [&](Frame* f) {
    cv::Mat left, right;
    *f = Frame();
    f->ctx.quiet = true;
    if (!next(&left, &right, &f->ctx, &f->error)) return false;
    if (!f->error.empty()) return true;
    try {
      PutCapture(left, right, rig, &f->ctx);
      f->report = pipeline_.Run(f->ctx, 0, head_);
    } catch (const Error& e) {
      f->error = e.what();
    }
    return true;
  };
  Frame current, ahead;
  if (!start(&current)) return 0;
  long frames = 0;
  for (;;) {
    // The next frame's head on the second core while this frame's tail runs here. The two runs
    // touch different stages of the pipeline and different contexts.
    std::future<bool> more = std::async(std::launch::async, [&] { return start(&ahead); });
    if (current.error.empty()) {
      try {
        const pipeline::RunReport tail = pipeline_.Run(current.ctx, head_, pipeline_.stages().size());
        current.report.stages.insert(current.report.stages.end(), tail.stages.begin(), tail.stages.end());
        current.report.total_ms += tail.total_ms;
      } catch (const Error& e) {
        current.error = e.what();
      }
    }
    try {
      done(current.ctx, current.report, current.error);
    } catch (...) {
      more.wait();  // `ahead` is still being written
      throw;
    }
    ++frames;
    if (!more.get()) break;
    std::swap(current, ahead);
  }
  return frames;
}

}  // namespace hedgefit::stereo
