// hedgefit stream: every hedge of every frame of a stereo source (two cameras or videos, one
// side-by-side camera or video, or a directory that captures keep arriving in), one JSON line per
// hedge and frame: the source from the flags, measure::MeasureStream, the lines and a summary.

#include <nlohmann/json.hpp>

#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "apps/commands.hpp"
#include "cli/capture_flags.hpp"
#include "cli/parse.hpp"
#include "fitting/methods.hpp"
#include "io/frame_source.hpp"
#include "measure/measure_stream.hpp"
#include "pipeline/registry.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::apps {

namespace {

using json = nlohmann::ordered_json;

struct StreamArgs {
  std::string rig, left, right, side_by_side, watch, methods = "ransac_ray";
  double idle_s = 10;
  long max_frames = 0;
  bool no_clean = false, no_drop = false, strict = true;
  CaptureFlags capture;
};

}  // namespace

// The run's last line on stderr: frames, drops, the mean time per frame and per stage.
static void PrintStreamSummary(long frames, long dropped_total, double total_ms, const std::map<std::string, double>& stage_ms) {
  std::string per_stage;
  for (const auto& [type, ms] : stage_ms) {
    char buf[96];
    std::snprintf(buf, sizeof(buf), "%s%s %.0f", per_stage.empty() ? "" : ", ", type.c_str(), ms / double(std::max(1L, frames)));
    per_stage += buf;
  }
  std::fprintf(stderr, "stream: %ld frames, %ld dropped, %.0f ms per frame (%s ms)\n", frames, dropped_total,
               total_ms / double(std::max(1L, frames)), per_stage.c_str());
}

// The stream's run: built once, then frame after frame until the source ends.
static int RunStream(const StreamArgs& a) {
  PrepareRegistry(true);
  const pipeline::Registry& registry = pipeline::Registry::Global();
  measure::MeasureRequest request;
  request.capture = a.capture.Resolve(registry);
  request.methods = fitting::ParseMethodList(a.methods, "--method");
  request.clean = !a.no_clean;
  const int given = int(!a.left.empty() || !a.right.empty()) + int(!a.side_by_side.empty()) + int(!a.watch.empty());
  if (given != 1) throw Error("give one source: --left and --right, --side-by-side, or --watch");
  if (a.watch.empty() && a.side_by_side.empty() && (a.left.empty() || a.right.empty())) {
    throw Error("--left and --right: give both (video files or camera numbers)");
  }
  const stereo::StereoRig rig = stereo::ReadRig(a.rig);
  std::unique_ptr<io::Source> src;
  if (!a.watch.empty()) {
    src = io::WatchDirectory(a.watch, a.idle_s);
  } else if (!a.side_by_side.empty()) {
    src = io::OpenSideBySide(a.side_by_side);
  } else {
    src = io::OpenVideoPair(a.left, a.right);
  }
  // A frame's lines: measure's, each with the frame's head (and the capture's warning), or one
  // line with "hedges": 0 and why.
  auto print = [](const measure::StreamFrame& f) {
    for (const auto& line : f.result.lines) {
      json j = f.head;
      for (const auto& [k, v] : line.items()) j[k] = v;
      if (!f.result.hint.empty()) j["warning"] = f.result.hint;
      std::printf("%s\n", j.dump().c_str());
    }
    if (!f.error.empty()) {
      json j = f.head;
      j["hedges"] = 0;
      j["message"] = f.error;
      std::printf("%s\n", j.dump().c_str());
    }
    std::fflush(stdout);
  };
  const measure::StreamSummary s =
      measure::MeasureStream(std::move(src), !a.no_drop, rig, request, a.max_frames, registry, print);
  if (s.frames == 0) {
    char idle[32];
    std::snprintf(idle, sizeof(idle), "%g", a.idle_s);
    const std::string source = !a.watch.empty() ? "--watch " + a.watch + ": no capture arrived within " + idle +
                                                       " s (--idle-timeout)"
                             : !a.side_by_side.empty() ? "--side-by-side " + a.side_by_side + ": no frame could be read"
                                                        : "--left " + a.left + ": no frame pair could be read";
    throw ProcessingError(source);
  }
  PrintStreamSummary(s.frames, s.dropped, s.total_ms, s.stage_ms);
  if (s.unusable_frames > 0) {
    std::fprintf(stderr, "hedgefit: warning: stream: %ld of %ld frames gave unusable results (their lines say why)\n",
                 s.unusable_frames, s.frames);
    return kExitUnusable;
  }
  if (s.unchecked_frames > 0) {
    std::fprintf(stderr, "hedgefit: %s: stream: %ld of %ld frames could not check the rig against the frame "
                 "(rig_check unchecked; their lines' rig_check_reason says why)%s\n",
                 a.strict ? "error" : "warning", s.unchecked_frames, s.frames, a.strict ? "; --no-strict accepts them" : "");
    if (a.strict) return kExitUnusable;
  }
  return kExitOk;
}

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
  cmd->add_flag("--strict,!--no-strict", a->strict,
                "exit 3 when a frame's rig could not be checked against it (rig_check unchecked), as when a check "
                "finds it unusable; the default, for a robot; --no-strict accepts such frames");
  a->capture.Add(cmd);
  GroupFlags(cmd, {{"Inputs", {"--rig", "--left", "--right", "--side-by-side", "--watch", "--idle-timeout", "--max-frames", "--no-drop", "--strict"}}, {"Fitting", {"--method", "--no-clean"}}});
  cmd->callback([=]() { *run = [=]() { return RunStream(*a); }; });
}

}  // namespace hedgefit::apps
