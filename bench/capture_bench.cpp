// Capture to sphere, per 1920x1200 pair: hedgefit's path (rectify, segment, improved SGBM
// on the hedge's region over the working-range disparities, reproject, RANSAC + geometric
// fit) beside the paper's method on stock OpenCV (SGBM MODE_HH over the full frame with 128
// disparities, plus a right matcher for the left-right check), in one run.
// Usage: bench_capture [--repeats N]

#include <opencv2/calib3d.hpp>
#include <opencv2/ximgproc/disparity_filter.hpp>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <thread>

#include "bench/bench_util.hpp"
#include "cloud/cloud_stages.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "fitting/fitting_stages.hpp"
#include "fitting/methods.hpp"
#include "stereo/capture.hpp"
#include "sim/simulator.hpp"
#include "stereo/stereo_stages.hpp"

int main(int argc, char** argv) {
  using namespace hedgefit;
  int repeats = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--repeats") repeats = std::atoi(argv[i + 1]);
  }
  const sim::SimRig sim = sim::PaperRig(1.0);
  sim::SphereScene scene;
  scene.center = cv::Vec3d(70, 50, 2300);
  sim::RenderOptions ro;
  ro.supersample = 2;
  const cv::Mat left = sim::RenderSphere(sim, false, scene, ro), right = sim::RenderSphere(sim, true, scene, ro);
  const stereo::StereoRig rig = sim::RigFromSimulation(sim);

  double radius = 0;
  std::size_t points = 0;
  double fraction = 0;
  decltype(stereo::ConvertResult::stage_ms) stages{};
  const double ours = bench::MedianMs(repeats, [&] {
    const stereo::ConvertResult res = stereo::ConvertCapture(left, right, rig, stereo::ConvertOptions{});
    std::vector<Eigen::Vector3d> pts;
    for (const auto& p : res.cloud.points_mm) pts.push_back(p.cast<double>());
    radius = fitting::RunFitMethod("ransac_ray", pts,
                                   {{"distance_threshold", 15.0}, {"min_radius", 100.0}, {"max_radius", 1000.0}})
                 .sphere.radius_mm;
    points = pts.size();
    fraction = res.matched_fraction;
    stages = res.stage_ms;
  });
  // `hedgefit stream` / `measure`'s path in a warm process: the measure pipeline (capture
  // stages, default cleaning, ransac_ray) built once, run per frame.
  pipeline::Registry registry;
  cloud::RegisterCloudStages(registry);
  stereo::RegisterStereoStages(registry);
  fitting::RegisterFittingStages(registry);
  pipeline::Pipeline measure =
      pipeline::Pipeline::FromJson(stereo::MeasurePipelineJson(stereo::ConvertOptions{}, {"fitters.ransac_ray"}, true),
                                "measure", registry, {}, {"left_image", "right_image", "rig"});
  std::map<std::string, double> measure_stages;
  double measured_radius = 0;
  const double warm = bench::MedianMs(repeats, [&] {
    pipeline::Context ctx;
    ctx.quiet = true;
    stereo::PutCapture(left, right, rig, &ctx);
    const pipeline::RunReport report = measure.Run(ctx);
    for (const auto& s : report.stages) measure_stages[s.type] = s.wall_ms;
    measured_radius = ctx.Get<std::vector<fitting::SphereFitResult>>("fits").back().sphere.radius_mm;
  });
  const double stock = bench::MedianMs(repeats, [&] {
    cv::Mat lr, rr;
    stereo::RectifyPair(rig, left, right, &lr, &rr);
    auto sgbm = cv::StereoSGBM::create(0, 128, 5, 8 * 3 * 25, 32 * 3 * 25, -1, 0, 10, 0, 0, cv::StereoSGBM::MODE_HH);
    auto right_matcher = cv::ximgproc::createRightMatcher(sgbm);
    cv::Mat dl, dr;
    sgbm->compute(lr, rr, dl);
    right_matcher->compute(rr, lr, dr);
  });
  std::printf("capture to sphere, 1920x1200 pair, median of %d runs, %u hardware threads\n", repeats,
              std::thread::hardware_concurrency());
  std::printf("%-62s %10s %8s\n", "path", "ms/pair", "speed-up");
  std::printf("%-62s %10.0f %8s\n", "stock OpenCV: rectify + SGBM HH full frame, 128 disp + right matcher", stock, "1.0x");
  std::printf("%-62s %10.0f %7.1fx\n", "hedgefit: rectify, segment, region SGBM + LRC + refine, fit", ours, stock / ours);
  std::printf("%-62s %10.0f %7.1fx\n", "hedgefit stream/measure: warm pipeline incl. cleaning, one frame", warm,
              stock / warm);
  std::printf("hedgefit matched %.1f %% of the frame, %zu points, fitted r = %.2f mm (true 300)\n", 100 * fraction,
              points, radius);
  std::printf("hedgefit stages (last run): rectify %.0f ms, segment %.0f ms, match + refine %.0f ms, reproject %.0f ms, "
              "fit the rest\n",
              stages.rectify, stages.segment, stages.match, stages.reproject);
  std::printf("stream/measure stages (last run), r = %.2f mm:", measured_radius);
  for (const auto& [type, ms] : measure_stages) std::printf(" %s %.0f ms,", type.c_str(), ms);
  std::printf("\n");
  return 0;
}
