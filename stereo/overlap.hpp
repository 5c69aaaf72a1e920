#pragma once
/// Frames overlapped on two cores: the head of a capture pipeline (its leading reader,
/// rectification and segmentation stages) runs for frame N + 1 on a second thread while the rest
/// (matching, cleaning, fitting) runs for frame N.
/// Results come out in order; each frame's report holds every stage's time.

#include <opencv2/core.hpp>

#include <functional>
#include <string>

#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

class OverlappedRunner {
 public:
  /// `pipeline_json`: a capture pipeline that is given the images (stereo::MeasurePipelineJson
  /// without files); `source` names it in errors.
  OverlappedRunner(const std::string& pipeline_json, const std::string& source, const pipeline::Registry& registry);

  /// The next frame's images into `left`, `right`; false when there are no more. Runs on the
  /// second thread. `ctx` is the frame's context: what the caller puts there (a frame number, a
  /// time) comes back with the frame. A `left` left empty is a frame that could not be read:
  /// put its reason in `*error`; it comes back with that error, unmeasured.
  using NextFrame = std::function<bool(cv::Mat* left, cv::Mat* right, pipeline::Context* ctx, std::string* error)>;
  /// Called in order for every frame, on the calling thread. `error` is empty, or why the frame
  /// could not be measured (its context then holds what the stages before the failure put).
  using FrameDone = std::function<void(pipeline::Context& ctx, const pipeline::RunReport& report, const std::string& error)>;

  /// Measures every frame `next` gives; returns the number of frames.
  long Run(const StereoRig& rig, const NextFrame& next, const FrameDone& done);

  const pipeline::Pipeline& pipeline() const { return pipeline_; }
  /// How many leading stages run ahead, on the next frame (0: nothing to overlap).
  std::size_t head() const { return head_; }

 private:
  pipeline::Pipeline pipeline_;
  std::size_t head_ = 0;
};

}  // namespace hedgefit::stereo
