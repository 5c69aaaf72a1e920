// Thin adapters from declared options (each struct's OptionTable) to the capture functions.

#include "stereo/stereo_stages.hpp"

#include <opencv2/imgcodecs.hpp>

#include "cloud/option_table.hpp"
#include "cloud/point_cloud.hpp"
#include "stereo/capture.hpp"

namespace hedgefit::stereo {

namespace {

using cloud::Context;
using cloud::Options;

cv::Mat ReadImage(const std::string& path, const std::string& which) {
  if (path.empty()) throw Error("stage 'readers.stereo', option '" + which + "': give the " + which + " image");
  const cv::Mat m = cv::imread(path);
  if (m.empty()) throw Error(path + ": cannot read the image; give a PNG or JPEG file");
  return m;
}

// Every segmentation stage ends here: an empty mask is "no hedge", never an empty cloud later.
void PutMask(Context& ctx, const cv::Mat& mask) {
  const int pixels = cv::countNonZero(mask);
  if (pixels == 0) throw Error("no hedge found: the segmentation mask is empty");
  ctx.Note("mask_pixels", static_cast<std::int64_t>(pixels));
  ctx.Put("mask", mask);
}

const StereoRig& RigOf(Context& ctx) { return ctx.Get<StereoRig>("rig"); }

}  // namespace

void PutCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig, cloud::Context* ctx) {
  if (left_bgr.size() != right_bgr.size()) {
    throw Error("the left image is " + std::to_string(left_bgr.cols) + "x" + std::to_string(left_bgr.rows) +
                " but the right one is " + std::to_string(right_bgr.cols) + "x" + std::to_string(right_bgr.rows) +
                "; give the two views of one capture");
  }
  ctx->Put("left_image", left_bgr);
  ctx->Put("right_image", right_bgr);
  ctx->Put("rig", rig);
  ctx->Put("rectified", false);
}

void RegisterStereoStages(cloud::Registry& r) {
  using namespace hedgefit::cloud;
  r.Add(StageInfo{"readers.stereo", "Reads a stereo capture (left and right images) and its rig file",
                  {StringOption("left", "", "left image"), StringOption("right", "", "right image"),
                   StringOption("rig", "", "rig file from `hedgefit calibrate`")},
                  {},
                  {"left_image", "right_image", "rig"},
                  {}},
        MakeFactory([](const Options& o, Context& ctx) {
          if (o.GetString("rig").empty()) throw Error("stage 'readers.stereo', option 'rig': give the rig file");
          const cv::Mat l = ReadImage(o.GetString("left"), "left"), rt = ReadImage(o.GetString("right"), "right");
          PutCapture(l, rt, ReadRig(o.GetString("rig")), &ctx);
        }));
  r.Add(StageInfo{"stereo.rectify", "Undistorts and rectifies the pair with the rig (Bouguet)", {},
                  {"left_image", "right_image", "rig"}, {"left_image", "right_image", "raw_left_image", "raw_right_image"}, {}},
        MakeFactory([](const Options&, Context& ctx) {
          cv::Mat l, rt;
          RectifyPair(RigOf(ctx), ctx.Get<cv::Mat>("left_image"), ctx.Get<cv::Mat>("right_image"), &l, &rt);
          // The originals stay: stereo.sgbm resamples its region again from them with B-splines.
          ctx.Put("raw_left_image", ctx.Get<cv::Mat>("left_image"));
          ctx.Put("raw_right_image", ctx.Get<cv::Mat>("right_image"));
          ctx.Put("left_image", l);
          ctx.Put("right_image", rt);
          ctx.Put("rectified", true);
        }));
  r.Add(StageInfo{"stereo.segment",
                  "The paper's hedge mask: excess green, bilateral filter, gamma, Otsu, largest region, holes filled",
                  TableOptions<SegmentOptions>(), {"left_image"}, {"mask"}, {}},
        TableFactory<SegmentOptions>("stereo.segment", [](const SegmentOptions& p, const Options&, Context& ctx) {
          PutMask(ctx, SegmentHedge(ctx.Get<cv::Mat>("left_image"), p));
        }));
  r.Add(StageInfo{"stereo.mask", "The hedge mask from a file drawn on the original left image, rectified and eroded",
                  TableOptions<MaskOptions>(), {"left_image", "rig"}, {"mask"}, {}},
        TableFactory<MaskOptions>("stereo.mask", [](const MaskOptions& p, const Options&, Context& ctx) {
          PutMask(ctx, SegmentFromMaskFile(RigOf(ctx), p));
        }));
  r.Add(StageInfo{"stereo.segment_depth",
                  "The hedge mask by depth inside a box: coarse match of the box, the connected region at the depth of "
                  "its middle; for grey images",
                  TableOptions<DepthSegmentOptions>(), {"left_image", "right_image", "raw_left_image", "rig"}, {"mask"}, {}},
        TableFactory<DepthSegmentOptions>("stereo.segment_depth",
                                          [](const DepthSegmentOptions& p, const Options&, Context& ctx) {
                                            cv::Mat& l = ctx.Get<cv::Mat>("left_image");
                                            cv::Mat& rt = ctx.Get<cv::Mat>("right_image");
                                            PutMask(ctx, SegmentByDepthInBox(RigOf(ctx), ctx.Get<cv::Mat>("raw_left_image"),
                                                                             ctx.Get<cv::Mat>("raw_right_image"), &l, &rt, p));
                                          }));
  r.Add(StageInfo{"stereo.sgbm",
                  "Improved semi-global matching: SGBM, left-right check, background-side hole filling, sub-pixel "
                  "refinement; only over the mask's region and the working range's disparities",
                  TableOptions<MatchOptions>(), {"left_image", "right_image", "rig"},
                  {"disparity", "filled", "disparity_sigma", "matched_region"}, {}},
        TableFactory<MatchOptions>("stereo.sgbm", [](const MatchOptions& p, const Options&, Context& ctx) {
          const bool* rectified = ctx.Find<bool>("rectified");
          if (rectified && !*rectified) {
            throw Error("stage 'stereo.sgbm': the images are not rectified; add stereo.rectify before it");
          }
          const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
          // Headers: the matched region is re-rendered in place in the rectified images.
          cv::Mat l = ctx.Get<cv::Mat>("left_image"), rt = ctx.Get<cv::Mat>("right_image");
          const MatchResult m = MatchHedge(RigOf(ctx), ctx.Find<cv::Mat>("raw_left_image"),
                                           ctx.Find<cv::Mat>("raw_right_image"), &l, &rt, mask ? *mask : cv::Mat(), p);
          ctx.Note("matched_fraction", double(m.matched_region.area()) / double(l.total()));
          ctx.Note("filled", static_cast<std::int64_t>(m.filled_count));
          ctx.Note("disparity_range", std::vector<double>{double(m.min_disparity), double(m.min_disparity + m.num_disparities)});
          ctx.Put("disparity", m.disparity);
          ctx.Put("filled", m.filled);
          ctx.Put("disparity_sigma", m.disparity_sigma);
          ctx.Put("matched_region", m.matched_region);
        }));
  r.Add(StageInfo{"stereo.reproject",
                  "Disparity to points in the unrectified left camera frame (mm), coloured, inside the mask",
                  TableOptions<ReprojectOptions>(), {"disparity", "left_image", "rig"}, {"cloud"}, {}},
        TableFactory<ReprojectOptions>("stereo.reproject", [](const ReprojectOptions& p, const Options&, Context& ctx) {
          const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
          const cv::Mat* filled = ctx.Find<cv::Mat>("filled");
          const cv::Mat* sigma = ctx.Find<cv::Mat>("disparity_sigma");
          cloud::PointCloud pc = ReprojectMeasured(ctx.Get<cv::Mat>("disparity"), mask ? *mask : cv::Mat(),
                                                   filled ? *filled : cv::Mat(), ctx.Get<cv::Mat>("left_image"),
                                                   RigOf(ctx), p, sigma ? *sigma : cv::Mat());
          ctx.Note("points", static_cast<std::int64_t>(pc.size() - cloud::CountNonFinite(pc)));
          ctx.Put("cloud", std::move(pc));
        }));
}

}  // namespace hedgefit::stereo
