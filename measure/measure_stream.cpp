#include "measure/measure_stream.hpp"

#include <chrono>

#include "pipeline/error.hpp"
#include "stereo/overlap.hpp"

namespace hedgefit::measure {

StreamSummary MeasureStream(std::unique_ptr<io::Source> source, bool drop, const stereo::StereoRig& rig,
                            const MeasureRequest& request, long max_frames, const pipeline::Registry& registry,
                            const std::function<void(const StreamFrame&)>& on_frame) {
  using Clock = std::chrono::steady_clock;
  stereo::OverlappedRunner runner(MeasureRecipe(request, registry), "stream", registry);
  io::Grabber grabber(std::move(source), drop);
  StreamSummary s;
  long taken = 0;
  Clock::time_point last_out = Clock::now();
  // On the runner's second thread: the next frame, and its head.
  auto next = [&](cv::Mat* left, cv::Mat* right, pipeline::Context* ctx, std::string* error) {
    if (max_frames != 0 && taken >= max_frames) return false;
    io::Frame f;
    long dropped = 0;
    if (!grabber.Take(&f, &dropped)) return false;
    nlohmann::ordered_json head;
    head["frame"] = taken++;
    head["time"] = Rounded(f.time_s);
    if (!f.name.empty()) head["name"] = f.name;
    if (dropped) head["dropped"] = dropped;
    ctx->Put("stream_head", head);
    ctx->Put("stream_dropped", dropped);
    ctx->Put("stream_arrived", Clock::now());
    *error = f.error;
    *left = f.left, *right = f.right;
    return true;
  };
  // On this thread, in order.
  auto done = [&](pipeline::Context& ctx, const pipeline::RunReport& report, const std::string& error) {
    StreamFrame frame;
    frame.head = ctx.Get<nlohmann::ordered_json>("stream_head");
    s.dropped += ctx.Get<long>("stream_dropped");
    frame.error = error;
    if (frame.error.empty()) {
      try {
        frame.result = ReadMeasureResult(ctx, report);
        for (const auto& [type, ms] : frame.result.stage_ms) s.stage_ms[type] += ms;
        s.unusable_frames += frame.result.unusable;
        s.unchecked_frames += !frame.result.unchecked.empty();
      } catch (const Error& e) {
        frame.error = e.what();
      }
    }
    on_frame(frame);
    const Clock::time_point now = Clock::now();
    s.total_ms += std::chrono::duration<double, std::milli>(now - std::max(last_out, ctx.Get<Clock::time_point>("stream_arrived"))).count();
    last_out = now;
    ++s.frames;
  };
  runner.Run(rig, next, done);
  return s;
}

}  // namespace hedgefit::measure
