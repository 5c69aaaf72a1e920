// Capture to spheres, per 1920 x 1200 pair, in one run and on the same images:
//  - the paper's method on stock OpenCV (rectify, SGBM MODE_HH over the full frame with 128
//    disparities, plus a right matcher for the left-right check);
//  - hedgefit's warm `stream` / `measure` pipeline as it was in 0.7.0 (stereo::ReferenceOptions:
//    the options that restore 0.7.0's work), taking turns frame by frame with today's;
//  - today's warm pipeline, frame after frame (latency per frame);
//  - today's `stream`: the next frame's rectification and segmentation overlapped with this
//    frame's measurement on the second core (time per frame at the output).
// Per path and stage: median and 95th percentile over --frames frames. Three scenes, hedgefit's
// renderer: the lab capture (one ball, r 300 mm at 2.3 m), a garden row of three (preset "row":
// r 450-600 mm at 2.1-2.7 m, a pot in front) and two hedges of the paper's outdoor size (preset
// "paper_pair": r 900 and 940 mm at 2.3 and 2.7 m), the frame issue "One pass" sets against the
// lab's.
// Usage: bench_capture [--frames N] [--stock-frames N] [--scenes lab,row,paper] [--method M] [--max-points N]
//                     [--sgbm-mode hh|sgbm|3way|hh4]
// (--max-points: today's pipeline matches and refines at most N pixels per hedge, as `measure
// --max-points`; --sgbm-mode: today's pipeline runs that variant of OpenCV's SGBM, stereo.sgbm's
// `mode`; the 0.7.0 path keeps its own of both).
// The process starts as `hedgefit` does (cli::PrepareProcess: glibc keeps freed blocks for reuse),
// so every path, stock OpenCV's included, runs under the allocator the shipped program has.

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/disparity_filter.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "bench/bench_util.hpp"
#include "cli/run.hpp"
#include "fitting/methods.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "sim/simulator.hpp"
#include "pipeline/option_table.hpp"
#include "stereo/capture.hpp"
#include "stereo/matching.hpp"
#include "stereo/overlap.hpp"
#include "stereo/stereo_stages.hpp"
#include "measure/modules.hpp"
#include "measure/recipes.hpp"

namespace {

using namespace hedgefit;
using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The q-quantile (nearest rank) of `v`.
double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t i = std::min(v.size() - 1, std::size_t(std::ceil(q * double(v.size())) - 1));
  return v[std::max<std::size_t>(0, i)];
}

std::string Radii(pipeline::Context& ctx) {
  std::ostringstream os;
  os.precision(5);
  if (const auto* fits = ctx.Find<std::vector<fitting::SphereFitResult>>("fits")) {
    for (const auto& f : *fits) os << (os.tellp() > 0 ? " " : "") << f.sphere.radius_mm;
  }
  return os.str();
}

// The steps a stage notes of its own time (`stereo.sgbm`'s), printed under it in this order.
struct Step {
  const char* stage;
  const char* note;
  const char* label;
};
constexpr Step kSteps[] = {
    {"stereo.sgbm", "rectify_region_ms", "regions rectified again (B-spline)"},
    {"stereo.sgbm", "sgbm_ms", "SGBM + right matcher + LR check"},
    {"stereo.sgbm", "refine_ms", "sub-pixel refinement"},
};

struct Timings {
  std::vector<double> total;
  std::map<std::string, std::vector<double>> stages;
  std::map<std::string, std::vector<double>> steps;  // by kSteps' note
  std::string radii;  // the last frame's fitted radii, mm

  // One frame: its total, each stage type's time (summed over its stages), the steps its stages
  // noted, its radii.
  void Add(double ms, const pipeline::RunReport& report, pipeline::Context& ctx) {
    total.push_back(ms);
    std::map<std::string, double> per, step;
    for (const auto& st : report.stages) {
      per[st.type] += st.wall_ms;
      for (const Step& k : kSteps) {
        const auto it = st.notes.find(k.note);
        if (st.type != k.stage || it == st.notes.end()) continue;
        if (const double* v = std::get_if<double>(&it->second)) step[k.note] += *v;
      }
    }
    for (const auto& [type, v] : per) stages[type].push_back(v);
    for (const auto& [note, v] : step) steps[note].push_back(v);
    radii = Radii(ctx);
  }
};

struct Scene {
  std::string name, what;
  cv::Mat left, right;
  stereo::StereoRig rig;
};

std::vector<Scene> MakeScenes(const std::vector<std::string>& names) {
  const sim::SimRig sim = sim::PaperRig(1.0);
  sim::RenderOptions ro;
  ro.supersample = 2;
  std::vector<Scene> out;
  for (const std::string& name : names) {
    Scene s;
    s.name = name;
    s.rig = sim::RigFromSimulation(sim);
    if (name == "lab") {
      sim::SphereScene scene;
      scene.center = cv::Vec3d(70, 50, 2300);
      s.what = "lab capture: one ball, r 300 mm at 2.3 m";
      s.left = sim::RenderSphere(sim, false, scene, ro), s.right = sim::RenderSphere(sim, true, scene, ro);
    } else if (name == "row") {
      const sim::GardenScene scene = sim::GardenPreset("row");
      s.what = "garden row of three: r 450, 520, 600 mm at 2.3-2.7 m";
      s.left = sim::RenderGarden(sim, false, scene, ro), s.right = sim::RenderGarden(sim, true, scene, ro);
    } else if (name == "paper") {
      const sim::GardenScene scene = sim::GardenPreset("paper_pair");
      s.what = "the paper's outdoor size, two side by side: r 900 and 940 mm at 2.3 and 2.7 m";
      s.left = sim::RenderGarden(sim, false, scene, ro), s.right = sim::RenderGarden(sim, true, scene, ro);
    } else {
      std::fprintf(stderr, "bench_capture: --scenes: unknown scene '%s' (lab, row, paper)\n", name.c_str());
      std::exit(2);
    }
    out.push_back(std::move(s));
  }
  return out;
}


// Warm pipelines, one per set of options, each run frame after frame: each frame's latency. The
// pipelines take turns frame by frame (A B A B ...), so a busy moment of the machine costs each alike.
std::vector<Timings> WarmFrames(const Scene& s, const std::vector<stereo::ConvertOptions>& options,
                                const std::vector<std::string>& fits, int frames, const pipeline::Registry& registry) {
  std::vector<pipeline::Pipeline> pipelines;
  for (const auto& o : options) {
    pipelines.push_back(pipeline::Pipeline::FromJson(measure::MeasurePipelineJson(o, fits, true), "measure", registry, {},
                                                     {"left_image", "right_image", "rig"}));
  }
  std::vector<Timings> out(pipelines.size());
  for (int i = 0; i < frames + 1; ++i) {  // the first frame builds the rectification maps: not counted
    for (std::size_t k = 0; k < pipelines.size(); ++k) {
      Timings& t = out[k];
      pipeline::Context ctx;
      ctx.quiet = true;
      const auto t0 = Clock::now();
      stereo::PutCapture(s.left, s.right, s.rig, &ctx);
      const pipeline::RunReport report = pipelines[k].Run(ctx);
      const double ms = Ms(t0);
      if (i > 0) t.Add(ms, report, ctx);
    }
  }
  return out;
}

// `stream`'s loop: stereo::OverlappedRunner rectifies and segments frame N + 1 on the second core
// while frame N is measured; the time per frame is between consecutive results.
Timings StreamFrames(const Scene& s, const stereo::ConvertOptions& o, const std::vector<std::string>& fits, int frames,
                     const pipeline::Registry& registry) {
  stereo::OverlappedRunner runner(measure::MeasurePipelineJson(o, fits, true), "stream", registry);
  Timings t;
  int fed = 0;
  auto next = [&](cv::Mat* l, cv::Mat* r, pipeline::Context*, std::string*) {
    if (fed >= frames + 1) return false;
    *l = s.left, *r = s.right;
    ++fed;
    return true;
  };
  auto last = Clock::now();
  int done = 0;
  runner.Run(s.rig, next, [&](pipeline::Context& ctx, const pipeline::RunReport& report, const std::string& error) {
    if (!error.empty()) std::fprintf(stderr, "bench_capture: %s\n", error.c_str());
    const double ms = Ms(last);
    last = Clock::now();
    if (done++ > 0) t.Add(ms, report, ctx);  // the first frame builds the rectification maps
  });
  return t;
}

Timings StockFrames(const Scene& s, int frames) {
  Timings t;
  // As a user of OpenCV alone rectifies: the maps made once, then cv::remap each frame (not
  // hedgefit's own remap, which stereo::RectifyPair uses).
  const stereo::StereoRig& rig = s.rig;
  cv::Mat l1, l2, r1, r2;
  cv::initUndistortRectifyMap(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size, CV_16SC2, l1, l2);
  cv::initUndistortRectifyMap(rig.K2, rig.D2, rig.R2, rig.P2, rig.image_size, CV_16SC2, r1, r2);
  for (int i = 0; i < frames; ++i) {
    const auto t0 = Clock::now();
    cv::Mat lr, rr;
    cv::remap(s.left, lr, l1, l2, cv::INTER_LINEAR);
    cv::remap(s.right, rr, r1, r2, cv::INTER_LINEAR);
    t.stages["rectify (cv::remap)"].push_back(Ms(t0));
    const auto t1 = Clock::now();
    auto sgbm = cv::StereoSGBM::create(0, 128, 5, 8 * 3 * 25, 32 * 3 * 25, -1, 0, 10, 0, 0, cv::StereoSGBM::MODE_HH);
    auto right_matcher = cv::ximgproc::createRightMatcher(sgbm);
    cv::Mat dl, dr;
    sgbm->compute(lr, rr, dl);
    right_matcher->compute(rr, lr, dr);
    t.stages["SGBM HH, 128 disp + right matcher"].push_back(Ms(t1));
    t.total.push_back(Ms(t0));
  }
  return t;
}

void Print(const char* path, const Timings& t, double stock_median) {
  const double med = Quantile(t.total, 0.5);
  std::printf("%-44s %8.0f %8.0f %6zu", path, med, Quantile(t.total, 0.95), t.total.size());
  if (stock_median > 0) {
    std::printf(" %7.1fx\n", stock_median / med);
  } else {
    std::printf(" %8s\n", "-");  // --stock-frames 0: nothing to compare with
  }
  for (const auto& [stage, v] : t.stages) {
    std::printf("  %-42s %8.1f %8.1f\n", stage.c_str(), Quantile(v, 0.5), Quantile(v, 0.95));
    for (const Step& k : kSteps) {
      const auto it = t.steps.find(k.note);
      if (stage != k.stage || it == t.steps.end()) continue;
      std::printf("    %-40s %8.1f %8.1f\n", k.label, Quantile(it->second, 0.5), Quantile(it->second, 0.95));
    }
  }
  if (!t.radii.empty()) std::printf("  fitted radii, mm: %s\n", t.radii.c_str());
}

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  cli::PrepareProcess();
  int frames = 20, stock_frames = 3;
  std::string scenes = "lab,row,paper", method = "ransac_ray", sgbm_mode;
  stereo::ConvertOptions today;
  const int done = bench::ParseOptionPairs(
      argc, argv, "bench_capture", "[--frames N] [--stock-frames N] [--scenes lab,row,paper] [--method M] [--max-points N] "
      "[--sgbm-mode hh|sgbm|3way|hh4]",
      [&](const std::string& a, const char* v) {
        if (a == "--frames" || a == "--repeats") frames = std::max(1, std::atoi(v));
        else if (a == "--stock-frames") stock_frames = std::max(0, std::atoi(v));
        else if (a == "--scenes") scenes = v;
        else if (a == "--method") method = v;
        else if (a == "--max-points") today.match.max_points = std::max(0, std::atoi(v));
        else if (a == "--sgbm-mode") sgbm_mode = v;
        else return false;
        return true;
      });
  if (done >= 0) return done;
  if (!sgbm_mode.empty()) {
    const pipeline::OptionTable<stereo::SgbmOptions>& table = stereo::SgbmOptions::Table();
    const auto specs = table.Specs();
    const auto mode = std::find_if(specs.begin(), specs.end(), [](const pipeline::OptionSpec& s) { return s.name == "mode"; });
    if (mode == specs.end() || std::find(mode->choices.begin(), mode->choices.end(), sgbm_mode) == mode->choices.end()) {
      std::fprintf(stderr, "bench_capture: --sgbm-mode %s: not one of stereo.sgbm's modes (hh, sgbm, 3way, hh4)\n",
                   sgbm_mode.c_str());
      return 2;
    }
    table.Apply({{"mode", sgbm_mode}}, &today.match.sgbm);
  }
  pipeline::Registry registry;
  measure::AddStageModules(registry);
  const std::vector<std::string> fits = {fitting::FindFitMethod(method, "--method").stage};
  std::printf("capture to spheres, 1920 x 1200 pairs (hedgefit's renderer), %u hardware threads; fit: %s; at most %d "
              "points per hedge;%s%s ms per frame\n",
              std::thread::hardware_concurrency(), method.c_str(), today.match.max_points,
              sgbm_mode.empty() ? "" : " today's SGBM mode: ", sgbm_mode.empty() ? "" : (sgbm_mode + ";").c_str());
  for (const Scene& s : MakeScenes(Split(scenes))) {
    std::printf("\n%s\n%-44s %8s %8s %6s %8s\n", s.what.c_str(), "path / stage", "median", "p95", "frames", "speed-up");
    const Timings stock = StockFrames(s, stock_frames);
    const double stock_med = stock.total.empty() ? 0 : Quantile(stock.total, 0.5);
    if (stock_frames > 0) Print("stock OpenCV (the paper's method)", stock, stock_med);
    const std::vector<Timings> warm =
        WarmFrames(s, {stereo::ReferenceOptions(), today}, fits, frames, registry);
    Print("hedgefit 0.7.0's path (ReferenceOptions), warm", warm[0], stock_med);
    Print("hedgefit, warm pipeline, one frame at a time", warm[1], stock_med);
    std::printf("%-44s %8.2f\n", "  ratio of medians, 0.7.0's path / today's",
                Quantile(warm[0].total, 0.5) / Quantile(warm[1].total, 0.5));
    Print("hedgefit stream: next frame prepared alongside", StreamFrames(s, today, fits, frames, registry),
          stock_med);
  }
  return 0;
}
