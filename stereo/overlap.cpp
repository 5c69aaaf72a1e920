#include "stereo/overlap.hpp"

#include <future>
#include <utility>

#include "pipeline/error.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::stereo {

OverlappedRunner::OverlappedRunner(const std::string& pipeline_json, const std::string& source,
                                   const pipeline::Registry& registry)
    : pipeline_(pipeline::Pipeline::FromJson(pipeline_json, source, registry, {}, {"left_image", "right_image", "rig"})) {
  // The head: every stage up to and including the rectification. What follows reads the
  // rectified pair (segmentation, matching), so it waits for this frame's head, not the next's.
  const auto& stages = pipeline_.stages();
  for (std::size_t i = 0; i < stages.size(); ++i) {
    if (stages[i].type == "stereo.rectify") head_ = i + 1;
  }
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
