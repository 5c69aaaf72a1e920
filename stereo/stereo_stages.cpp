// Thin adapters from declared options to the capture functions. Artifacts: "left_image",
// "right_image" (cv::Mat BGR), "raw_left_image", "raw_right_image" (before rectification),
// "rig" (StereoRig), "rectified" (bool), "mask" (CV_8U),
// "disparity" (CV_32F), "filled" (CV_8U, 255 where the disparity was filled rather than
// measured), "disparity_sigma" (CV_32F px, the refinement's standard deviation), and "cloud".

#include "stereo/stereo_stages.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cloud/point_cloud.hpp"
#include "stereo/capture.hpp"

namespace hedgefit::stereo {

namespace {

using cloud::Context;
using cloud::Options;

}  // namespace

void RegisterStereoStages(cloud::Registry& r) {
  using namespace hedgefit::cloud;
  r.Add(StageInfo{"readers.stereo", "Reads a stereo capture (left and right images) and its rig file",
                  {StringOption("left", "", "left image"), StringOption("right", "", "right image"),
                   StringOption("rig", "", "rig file from `hedgefit calibrate`")},
                  {},
                  {"left_image", "right_image", "rig"},
                  {}},
        MakeFactory([](const Options& o, Context& ctx) {
          for (const char* key : {"left", "right", "rig"}) {
            if (o.GetString(key).empty()) {
              throw Error(std::string("stage 'readers.stereo', option '") + key + "': give the file");
            }
          }
          const cv::Mat l = cv::imread(o.GetString("left")), rt = cv::imread(o.GetString("right"));
          if (l.empty()) throw Error(o.GetString("left") + ": cannot read the image");
          if (rt.empty()) throw Error(o.GetString("right") + ": cannot read the image");
          ctx.Put("left_image", l);
          ctx.Put("right_image", rt);
          ctx.Put("rig", ReadRig(o.GetString("rig")));
          ctx.Put("rectified", false);
        }));
  r.Add(StageInfo{"stereo.rectify", "Undistorts and rectifies the pair with the rig (Bouguet)", {},
                  {"left_image", "right_image", "rig"}, {"left_image", "right_image", "raw_left_image", "raw_right_image"}, {}},
        MakeFactory([](const Options&, Context& ctx) {
          cv::Mat l, rt;
          RectifyPair(ctx.Get<StereoRig>("rig"), ctx.Get<cv::Mat>("left_image"), ctx.Get<cv::Mat>("right_image"), &l, &rt);
          // The originals stay available: stereo.sgbm resamples its region again from them
          // with B-splines, as `hedgefit convert` does.
          ctx.Put("raw_left_image", ctx.Get<cv::Mat>("left_image"));
          ctx.Put("raw_right_image", ctx.Get<cv::Mat>("right_image"));
          ctx.Put("left_image", l);
          ctx.Put("right_image", rt);
          ctx.Put("rectified", true);
        }));
  r.Add(StageInfo{"stereo.segment", "The hedge mask: excess green, bilateral filter, gamma, Otsu, largest region",
                  {DoubleOption("gamma", 1.5, "gamma on the excess-green value").Min(1e-3),
                   DoubleOption("esp", 0.0, "offset added before the gamma"),
                   IntOption("erode", SegmentOptions{}.erode_px,
                             "drop this many silhouette pixels (also from a user mask)", "px")
                       .Range(0, 200),
                   BoolOption("largest_component", true, "keep only the largest region"),
                   BoolOption("fill_holes", true, "fill holes inside the region"),
                   StringOption("mask", "", "use this mask image instead (same size as the left image)")},
                  {"left_image"},
                  {"mask"},
                  {}},
        MakeFactory([](const Options& o, Context& ctx) {
          cv::Mat mask;
          if (!o.GetString("mask").empty()) {
            mask = cv::imread(o.GetString("mask"), cv::IMREAD_GRAYSCALE);
            if (mask.empty()) throw Error(o.GetString("mask") + ": cannot read the mask image");
            mask = ErodeMask(mask > 127, static_cast<int>(o.GetInt("erode")));
          } else {
            SegmentOptions s;
            s.gamma = o.GetDouble("gamma");
            s.esp = o.GetDouble("esp");
            s.erode_px = static_cast<int>(o.GetInt("erode"));
            s.largest_component = o.GetBool("largest_component");
            s.fill_holes = o.GetBool("fill_holes");
            mask = SegmentHedge(ctx.Get<cv::Mat>("left_image"), s);
          }
          ctx.Note("mask_pixels", static_cast<std::int64_t>(cv::countNonZero(mask)));
          ctx.Put("mask", mask);
        }));
  r.Add(StageInfo{"stereo.sgbm",
                  "Improved semi-global matching: SGBM, left-right check, background-side hole filling, bilateral "
                  "smoothing; only over the mask's region and the working range's disparities",
                  {StringOption("mode", "hh", "paths: hh (8), sgbm (5), 3way, hh4").Choices({"hh", "sgbm", "3way", "hh4"}),
                   IntOption("block_size", 5, "matching block", "px").Range(1, 31),
                   IntOption("p1", 0, "smoothness penalty, 0 = 8 * channels * block^2").Min(0),
                   IntOption("p2", 0, "smoothness penalty, 0 = 32 * channels * block^2").Min(0),
                   IntOption("uniqueness", 10, "uniqueness ratio", "%").Range(0, 100),
                   DoubleOption("lrc_tolerance", 1.0, "left-right check tolerance; < 0 turns it off", "px"),
                   BoolOption("fill_holes", true, "fill rejected pixels from the background side"),
                   DoubleOption("bilateral_sigma", SgbmOptions{}.bilateral_sigma_disp, "bilateral range sigma (the paper uses ~1.5); 0 = off", "px").Min(0),
                   IntOption("refine_radius", SgbmOptions{}.refine_radius,
                             "sub-pixel refinement window half-size (slanted window, masked); 0 = off", "px")
                       .Range(0, 15),
                   IntOption("refine_iterations", SgbmOptions{}.refine_iterations, "Gauss-Newton steps per pixel")
                       .Range(1, 50),
                   DoubleOption("refine_max_sigma", SgbmOptions{}.refine_max_sigma_px,
                                "keep SGBM's value where the refined one's standard deviation is larger", "px")
                       .Min(1e-6),
                   DoubleOption("min_z", 1500, "working range, nearest", "mm").Min(1),
                   DoubleOption("max_z", 3500, "working range, farthest", "mm").Min(1),
                   BoolOption("region_only", true, "match only the mask's bounding box"),
                   IntOption("margin", 24, "margin around the mask's bounding box", "px").Range(0, 10000)},
                  {"left_image", "right_image", "rig"},
                  {"disparity", "filled", "disparity_sigma"},
                  {}},
        [](const Options& o) -> std::unique_ptr<Stage> {
          SgbmOptions sg;
          const std::string mode = o.GetString("mode");
          sg.mode = mode == "hh" ? SgbmMode::kHh8 : mode == "sgbm" ? SgbmMode::kSgbm5 : mode == "3way" ? SgbmMode::kSgbm3Way : SgbmMode::kHh4;
          sg.block_size = static_cast<int>(o.GetInt("block_size"));
          sg.p1 = static_cast<int>(o.GetInt("p1"));
          sg.p2 = static_cast<int>(o.GetInt("p2"));
          sg.uniqueness_ratio = static_cast<int>(o.GetInt("uniqueness"));
          sg.lrc_tolerance_px = o.GetDouble("lrc_tolerance");
          sg.fill_holes = o.GetBool("fill_holes");
          sg.bilateral_sigma_disp = o.GetDouble("bilateral_sigma");
          sg.refine_radius = static_cast<int>(o.GetInt("refine_radius"));
          sg.refine_iterations = static_cast<int>(o.GetInt("refine_iterations"));
          sg.refine_max_sigma_px = o.GetDouble("refine_max_sigma");
          sg = CheckedParams(sg, "stereo.sgbm");
          const double min_z = o.GetDouble("min_z"), max_z = o.GetDouble("max_z");
          if (!(max_z > min_z)) throw Error("stage 'stereo.sgbm', option min_z/max_z: need min_z < max_z (mm)");
          const bool region = o.GetBool("region_only");
          const int margin = static_cast<int>(o.GetInt("margin"));
          return std::make_unique<LambdaStage>(o, [=](const Options&, Context& ctx) {
            const bool* rectified = ctx.Find<bool>("rectified");
            if (rectified && !*rectified) {
              throw Error("stage 'stereo.sgbm': the images are not rectified; add stereo.rectify before it");
            }
            const StereoRig& rig = ctx.Get<StereoRig>("rig");
            const cv::Mat& l = ctx.Get<cv::Mat>("left_image");
            const cv::Mat& rt = ctx.Get<cv::Mat>("right_image");
            SgbmOptions run = sg;
            DisparityRangeForDepth(rig.P1.at<double>(0, 0), rig.baseline_mm, min_z, max_z, &run.min_disparity,
                                   &run.num_disparities);
            cv::Rect roi(0, 0, l.cols, l.rows);
            const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
            if (region && mask && cv::countNonZero(*mask) > 0) roi = MatchRegion(*mask, run, margin);
            const cv::Mat* raw_l = ctx.Find<cv::Mat>("raw_left_image");
            const cv::Mat* raw_r = ctx.Find<cv::Mat>("raw_right_image");
            if (raw_l && raw_r) {
              cv::Mat l_out = l, r_out = rt;  // headers: the region is rewritten in place
              RectifyRegionPrecisely(rig, *raw_l, *raw_r, roi, &l_out, &r_out);
            }
            const DisparityMap d = ComputeDisparity(l(roi), rt(roi), run, mask ? (*mask)(roi) : cv::Mat());
            cv::Mat full(l.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
            d.disparity.copyTo(full(roi));
            cv::Mat filled = cv::Mat::zeros(l.size(), CV_8U);
            d.rejected.copyTo(filled(roi));
            cv::Mat sigma(l.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
            if (!d.sigma.empty()) d.sigma.copyTo(sigma(roi));
            ctx.Note("matched_fraction", double(roi.area()) / double(l.total()));
            ctx.Note("filled", static_cast<std::int64_t>(d.filled));
            ctx.Note("disparity_range", std::vector<double>{double(run.min_disparity), double(run.min_disparity + run.num_disparities)});
            ctx.Put("disparity", full);
            ctx.Put("filled", filled);
            ctx.Put("disparity_sigma", sigma);
          });
        });
  r.Add(StageInfo{"stereo.reproject",
                  "Disparity to points in the unrectified left camera frame (mm), coloured, inside the mask",
                  {BoolOption("organized", false, "keep the image grid (NaN where no point)"),
                   BoolOption("extra_fields", true, "add disparity and sigma_z fields"),
                   DoubleOption("sigma_disparity", 0.2, "disparity noise for sigma_z where the refinement gave none", "px").Min(0),
                   BoolOption("keep_filled", false, "also reproject hole-filled (unmeasured) disparities")},
                  {"disparity", "left_image", "rig"},
                  {"cloud"},
                  {}},
        MakeFactory([](const Options& o, Context& ctx) {
          ReprojectOptions ro;
          ro.organized = o.GetBool("organized");
          ro.extra_fields = o.GetBool("extra_fields");
          ro.sigma_disparity_px = o.GetDouble("sigma_disparity");
          ro.keep_filled = o.GetBool("keep_filled");
          const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
          const cv::Mat* filled = ctx.Find<cv::Mat>("filled");
          const cv::Mat* sigma = ctx.Find<cv::Mat>("disparity_sigma");
          cv::Mat use = mask ? *mask : cv::Mat();
          if (filled && !ro.keep_filled) use = use.empty() ? ~*filled : (use & ~*filled);
          cloud::PointCloud pc = Reproject(ctx.Get<cv::Mat>("disparity"), use,
                                           ctx.Get<cv::Mat>("left_image"), ctx.Get<StereoRig>("rig"), ro,
                                           sigma ? *sigma : cv::Mat());
          ctx.Note("points", static_cast<std::int64_t>(pc.size() - cloud::CountNonFinite(pc)));
          ctx.Put("cloud", std::move(pc));
        }));
}

}  // namespace hedgefit::stereo
