// A test plugin that fills the capture path's matching slot: stereo.block_matcher runs
// OpenCV's StereoBM over the whole rectified pair. It shows a new matcher is one file: `convert
// --matcher stereo.block_matcher` then runs it in place of stereo.sgbm.

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <limits>

#include "pipeline/plugin.hpp"
#include "stereo/matching.hpp"
#include "stereo/rig.hpp"

namespace {

using namespace hedgefit::pipeline;

void RegisterBlockMatcher(Registry& registry) {
  StageInfo info{"stereo.block_matcher",
                 "OpenCV StereoBM over the whole rectified pair (test plugin for the matching slot)",
                 {DoubleOption("min_z", 1500, "working range, nearest", "mm").Min(1),
                  DoubleOption("max_z", 3500, "working range, farthest", "mm").Min(1)},
                 {"left_image", "right_image", "rig"},
                 {"disparity"},
                 {}};
  registry.Add(info, MakeFactory([](const Options& o, Context& ctx) {
    const auto& rig = ctx.Get<hedgefit::stereo::StereoRig>("rig");
    int min_d = 0, num_d = 0;
    hedgefit::stereo::DisparityRangeForDepth(rig.P1.at<double>(0, 0), rig.baseline_mm, o.GetDouble("min_z"),
                                             o.GetDouble("max_z"), &min_d, &num_d);
    cv::Mat l, r;
    cv::cvtColor(ctx.Get<cv::Mat>("left_image"), l, cv::COLOR_BGR2GRAY);
    cv::cvtColor(ctx.Get<cv::Mat>("right_image"), r, cv::COLOR_BGR2GRAY);
    auto bm = cv::StereoBM::create((num_d + 15) / 16 * 16, 15);
    bm->setMinDisparity(min_d);
    cv::Mat raw, disparity;
    bm->compute(l, r, raw);
    raw.convertTo(disparity, CV_32F, 1.0 / 16);
    disparity.setTo(std::numeric_limits<float>::quiet_NaN(), raw <= min_d * 16);
    ctx.Put("disparity", disparity);
  }));
}

}  // namespace

HEDGEFIT_PLUGIN("block_matcher", "1.0", RegisterBlockMatcher)
