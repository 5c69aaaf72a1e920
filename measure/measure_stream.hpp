#pragma once
/// A warm process measuring every frame of a stereo source (`hedgefit stream`): the rig and
/// measure's recipe are built once; a grabber thread reads frames (a live source drops those the
/// measurement cannot keep up with, and says how many), and the next frame is rectified and
/// segmented on the second core while this one is measured (stereo::OverlappedRunner). Each
/// frame comes back in order, typed, as MeasureCapture's result with the frame's head.

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <memory>
#include <string>

#include "io/frame_source.hpp"
#include "measure/measure_capture.hpp"

namespace hedgefit::measure {

/// One frame measured: its head ("frame", "time", "name" for a watched capture, "dropped" when
/// frames were skipped before it), and its result or why it could not be measured.
struct StreamFrame {
  nlohmann::ordered_json head;
  MeasureResult result;
  std::string error;  ///< "" when measured
};

/// The whole run.
struct StreamSummary {
  long frames = 0, dropped = 0;
  long unusable_frames = 0;   ///< frames with a result a check found unusable
  long unchecked_frames = 0;  ///< frames whose rig could not be checked against them
  double total_ms = 0;        ///< time at the output, summed over frames (see MeasureStream)
  std::map<std::string, double> stage_ms;  ///< wall time per stage type, summed over frames
};

/// Measures every frame of `source` with `rig` as `request` says, stopping after `max_frames`
/// (0: at the source's end); `on_frame` is called in order, on this thread. `drop`: a live
/// source skips the frames that arrive while one is measured. A frame's time at the output is
/// since the previous frame's, or since it arrived when the stream was waiting for it.
StreamSummary MeasureStream(std::unique_ptr<io::Source> source, bool drop, const stereo::StereoRig& rig,
                            const MeasureRequest& request, long max_frames, const pipeline::Registry& registry,
                            const std::function<void(const StreamFrame&)>& on_frame);

}  // namespace hedgefit::measure
