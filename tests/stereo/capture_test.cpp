// Capture to cloud: reprojection lands points in the unrectified left camera frame, a
// simulated capture converts to a cloud whose fitted sphere is the true one within the
// rig's depth resolution, and the segmentation finds the simulated hedge.

#include "stereo/capture.hpp"
#include "cloud/cloud_stages.hpp"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sys/wait.h>

#include <fstream>
#include <iostream>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "fitting/geometric_fit.hpp"
#include "fitting/ransac_fit.hpp"
#include "stereo/image_io.hpp"
#include "sim/simulator.hpp"
#include "stereo/stereo_stages.hpp"
#include "stereo/overlap.hpp"
#include "fitting/fitting_stages.hpp"
#include "fitting/methods.hpp"
#include "measure/modules.hpp"
#include "measure/measure_capture.hpp"
#include "measure/recipes.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::stereo {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
using namespace hedgefit::sim;  // the test data's renderer
namespace {

StereoRig TrueRig(const SimRig& sim) { return RigFromSimulation(sim); }

// A point reprojected from rectified pixel (u, v) with disparity d must project, through
// each camera's own (unrectified, distorted) model, to pixels that rectify back to (u, v)
// and (u - d, v): that pins the frame (R1 transposed), Q and the disparity sign.
TEST(Capture, ReprojectedPointsAreInTheUnrectifiedLeftFrame) {
  const StereoRig rig = TrueRig(PaperRig(0.5));
  cv::Mat disparity(rig.image_size, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const int u = 500, v = 250;
  const float d = 29.5f;  // about 2.2 m on this rig
  disparity.at<float>(v, u) = d;
  cv::Mat left(rig.image_size, CV_8UC3, cv::Scalar(10, 200, 30));
  ReprojectOptions o;
  const cloud::PointCloud pc = Reproject(disparity, cv::Mat(), left, rig, o);
  ASSERT_EQ(pc.size(), 1u);
  // The pixel it was measured at, for neighbours on the image grid (the cleaning's).
  EXPECT_EQ(pc.fields.at(cloud::kPixelUField).at(0), float(u));
  EXPECT_EQ(pc.fields.at(cloud::kPixelVField).at(0), float(v));
  const cv::Point3d p(pc.points_mm[0].x(), pc.points_mm[0].y(), pc.points_mm[0].z());
  EXPECT_NEAR(p.z, 2200, 150);
  std::vector<cv::Point2d> pl, pr;
  cv::projectPoints(std::vector<cv::Point3d>{p}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), rig.K1, rig.D1, pl);
  cv::Mat rvec;
  cv::Rodrigues(rig.R, rvec);
  cv::projectPoints(std::vector<cv::Point3d>{p}, rvec, rig.T, rig.K2, rig.D2, pr);
  std::vector<cv::Point2d> rl, rr;
  cv::undistortPoints(pl, rl, rig.K1, rig.D1, rig.R1, rig.P1);
  cv::undistortPoints(pr, rr, rig.K2, rig.D2, rig.R2, rig.P2);
  // Float storage of the point (mm at 2.2 m) limits agreement to ~1e-3 px.
  EXPECT_NEAR(rl[0].x, u, 0.01);
  EXPECT_NEAR(rl[0].y, v, 0.01);
  EXPECT_NEAR(rr[0].x, u - d, 0.01);
  EXPECT_NEAR(rr[0].y, v, 0.01);
  EXPECT_EQ(pc.colors[0], (cloud::Rgb{30, 200, 10}));  // colour from the left image (BGR -> RGB)
  ASSERT_EQ(pc.fields.count("sigma_z"), 1u);
  // sigma_Z = Z^2 sigma_d / (f b), in the rectified frame's depth.
  const double f = rig.P1.at<double>(0, 0);
  EXPECT_NEAR(pc.fields.at("sigma_z")[0], (f * rig.baseline_mm / d) * (f * rig.baseline_mm / d) * 0.2 / (f * rig.baseline_mm),
              0.01);
  // One pixel's footprint at the point, Z / f = b / d in the rectified frame (2.4 mm here; a
  // focal length or baseline mixed up is off by orders of magnitude, float storage by 1e-6).
  ASSERT_EQ(pc.fields.count(cloud::kPixelSizeField), 1u);
  EXPECT_NEAR(pc.fields.at(cloud::kPixelSizeField)[0], rig.baseline_mm / d, 1e-4);
}

// A simulated full-size capture of r = 300 mm at 2.3 m, converted with the true rig.
// Depth resolution there is Z^2 / (f b) = 40 mm per px of disparity (f = 933 px). After
// the sub-pixel refinement the disparity bias left over the hedge is <= 0.01 px (rings
// of the silhouette measured against the simulator's truth), i.e. 0.4 mm of depth; a
// cap fit roughly doubles a centre-to-rim depth error in the radius. Bounds: 1 mm on the
// radius, 1.5 mm on the centre (the paper's own errors were 1.6 and 16 mm). Without the
// refinement, SGBM's bias puts the centre ~7 mm too far, which the test also checks.
TEST(Capture, SimulatedSphereConvertsAndFits) {
  const SimRig sim = PaperRig(1.0);
  SphereScene scene;
  scene.center = cv::Vec3d(70, 50, 2300);
  RenderOptions ro;
  ro.supersample = 3;
  ro.blur_sigma_px = 0.5;
  const cv::Mat l = RenderSphere(sim, false, scene, ro), r = RenderSphere(sim, true, scene, ro);
  const StereoRig rig = TrueRig(sim);
  auto fit_of = [&](const ConvertResult& res) {
    std::vector<Eigen::Vector3d> pts;
    for (const auto& p : res.cloud.points_mm) pts.push_back(p.cast<double>());
    EXPECT_GT(pts.size(), 8000u);
    fitting::RansacFitOptions rso;
    rso.distance_threshold_mm = 15;
    rso.min_radius_mm = 100;
    rso.max_radius_mm = 1000;
    std::vector<std::size_t> in;
    const auto coarse = fitting::FitSphereRansac(pts, rso, &in);
    EXPECT_TRUE(coarse.converged) << coarse.message;
    std::vector<Eigen::Vector3d> inliers;
    for (auto i : in) inliers.push_back(pts[i]);
    const auto fit = fitting::FitSphereGeometric(inliers, {}, &coarse.sphere);
    EXPECT_TRUE(fit.converged);
    return fit.sphere;
  };
  ConvertOptions o;
  const ConvertResult res = ConvertCapture(l, r, rig, o);
  EXPECT_LT(res.matched_fraction, 0.2);  // only the hedge's region is matched
  // Every 2nd pixel and row (min_stride): about a quarter of the mask's pixels become points
  // (some fail the checks), and min_stride 1 keeps every one.
  const double mask_pixels = cv::countNonZero(res.mask);
  EXPECT_LT(double(res.cloud.size()), 0.26 * mask_pixels);
  EXPECT_GT(double(res.cloud.size()), 0.15 * mask_pixels);
  ConvertOptions every = o;
  every.match.min_stride = 1;
  EXPECT_GT(double(ConvertCapture(l, r, rig, every).cloud.size()), 0.6 * mask_pixels);
  const fitting::Sphere fit = fit_of(res);
  EXPECT_NEAR(fit.radius_mm, 300.0, 1.0);
  EXPECT_LT((fit.center_mm - Eigen::Vector3d(70, 50, 2300)).norm(), 1.5);

  // The fine match searched only the sphere's own disparities (coarse_range): f b / Z is 56.8 px
  // at the silhouette (Z = 2300 mm) and 65.3 px at the front (2000 mm), where the working range from
  // 1 m would search 96.
  ASSERT_FALSE(res.left_rect.empty());
  cv::Mat lr = res.left_rect.clone(), rr = res.right_rect.clone();
  const MatchResult narrow = MatchHedge(rig, nullptr, nullptr, &lr, &rr, res.mask, o.match);
  EXPECT_LE(narrow.min_disparity, 56);
  EXPECT_GE(narrow.min_disparity + narrow.num_disparities, 66);
  EXPECT_LE(narrow.num_disparities, 32);
  // One hedge given as a label image (as the garden segmentation gives them) is matched as its mask
  // is: MatchHedges merges within the matched region, the same values on the mask, none off it.
  {
    cv::Mat labels;
    cv::Mat(res.mask != 0).convertTo(labels, CV_32S, 1.0 / 255);
    const MatchResult merged = MatchHedges(rig, nullptr, nullptr, &lr, &rr, labels, o.match);
    int compared = 0, differ = 0, off_mask = 0;
    for (int y = 0; y < labels.rows; ++y) {
      for (int x = 0; x < labels.cols; ++x) {
        const float a = narrow.disparity.at<float>(y, x), b = merged.disparity.at<float>(y, x);
        if (labels.at<int>(y, x) == 0) {
          off_mask += std::isfinite(b) ? 1 : 0;
          continue;
        }
        ++compared;
        const bool same = (std::isnan(a) && std::isnan(b)) || a == b;
        differ += same && narrow.filled.at<std::uint8_t>(y, x) == merged.filled.at<std::uint8_t>(y, x) ? 0 : 1;
      }
    }
    EXPECT_GT(compared, 8000);
    EXPECT_EQ(differ, 0);
    EXPECT_EQ(off_mask, 0);
    EXPECT_EQ(merged.matched_region, narrow.matched_region);
  }
  MatchOptions whole = o.match;
  whole.coarse_range = false;
  EXPECT_GE(MatchHedge(rig, nullptr, nullptr, &lr, &rr, res.mask, whole).num_disparities, 80);

  // sigma_z comes from each pixel's own refinement: near the cap's middle, where the
  // surface faces the camera, the residuals to the true sphere scatter as predicted. Measured
  // rms(residual / sigma_z) = 1.3 (windows overlap, so the per-window estimate is a little
  // optimistic); the fixed 0.2 px fallback would give 0.4.
  {
    const auto& sigma_z = res.cloud.fields.at("sigma_z");
    double sum = 0;
    int n = 0;
    for (std::size_t i = 0; i < res.cloud.size(); ++i) {
      const Eigen::Vector3d v = res.cloud.points_mm[i].cast<double>() - Eigen::Vector3d(70, 50, 2300);
      if (std::acos(-v.z() / v.norm()) > 30 * M_PI / 180) continue;
      const double e = (v.norm() - 300) / sigma_z[i];
      sum += e * e;
      ++n;
    }
    ASSERT_GT(n, 2500);  // the 30-degree cap's ~14,000 pixels, every 2nd pixel and row (min_stride)
    EXPECT_GT(std::sqrt(sum / n), 0.8);
    EXPECT_LT(std::sqrt(sum / n), 2.0);
  }

  // Pixels the left-right check rejected are filled in the dense map but are not
  // measurements: they stay out of the cloud unless asked for.
  const int measured = cv::countNonZero(res.mask & ~res.filled & (res.disparity == res.disparity));
  EXPECT_EQ(res.cloud.size(), std::size_t(measured));
  ConvertOptions keep = o;
  keep.reproject.keep_filled = true;
  EXPECT_GT(ConvertCapture(l, r, rig, keep).cloud.size(), res.cloud.size());

  // A thinned hedge matched at half resolution and refined at full: the refinement gives the
  // sub-pixel precision back, so the same tolerances hold (SGBM alone misses them, below).
  ConvertOptions half = o;
  half.match.max_points = 12000;  // about a quarter of the cap's pixels: every 2nd pixel and row
  half.match.sgbm.half_res_from_stride = 2;
  const ConvertResult half_res = ConvertCapture(l, r, rig, half);
  EXPECT_LT(half_res.cloud.size(), std::size_t(cv::countNonZero(res.mask)) / 3);
  const fitting::Sphere half_fit = fit_of(half_res);
  EXPECT_NEAR(half_fit.radius_mm, 300.0, 1.0);
  EXPECT_LT((half_fit.center_mm - Eigen::Vector3d(70, 50, 2300)).norm(), 1.5);

  ConvertOptions no_refinement = o;
  no_refinement.match.sgbm.refine_radius = 0;
  const fitting::Sphere sgbm_only = fit_of(ConvertCapture(l, r, rig, no_refinement));
  EXPECT_GT(sgbm_only.center_mm.z() - 2300, 3.0);  // SGBM alone: too far

  // The segmentation mask matches the simulator's label truth on most pixels.
  RenderOptions lo;
  lo.labels = true;
  cv::Mat labels = RenderSphere(sim, false, scene, lo), truth_rect, dummy;
  RectifyPair(rig, labels, labels, &truth_rect, &dummy);
  const cv::Mat truth_mask = truth_rect == kLabelSphere;
  // The mask is eroded by erode_px on purpose: compare with the truth eroded alike.
  const cv::Mat truth_eroded = ErodeMask(truth_mask, o.segment.erode_px);
  const double iou =
      double(cv::countNonZero(truth_eroded & res.mask)) / double(cv::countNonZero(truth_eroded | res.mask));
  EXPECT_GT(iou, 0.9);
}

// Excess green's Otsu split selects something in any colour image: a blue checkerboard or a
// frame that is green everywhere must be "no hedge", not a hedge filling the frame.
// `stream`'s frames overlapped (stereo::OverlappedRunner): the rectification and segmentation of
// frame N + 1 run while frame N is measured, and each frame comes out, in order, exactly as the same pipeline
// gives it one frame at a time (the stages are deterministic: RANSAC is seeded), with what the
// source put in its context. A frame that cannot be measured (an empty right image) or read says
// why, and the frames after it are measured.
TEST(Capture, OverlappedFramesGiveWhatOneAtATimeGives) {
  const SimRig sim = PaperRig(0.5);
  SphereScene scene;
  scene.center = cv::Vec3d(70, 50, 2300);
  const cv::Mat l = RenderSphere(sim, false, scene), r = RenderSphere(sim, true, scene);
  const StereoRig rig = TrueRig(sim);
  Registry registry;
  measure::AddStageModules(registry);
  const std::string json = measure::MeasurePipelineJson(ConvertOptions{}, {"fitters.ransac_ray"}, true);
  Pipeline alone = Pipeline::FromJson(json, "test", registry, {}, {"left_image", "right_image", "rig"});
  Context ctx;
  ctx.quiet = true;
  PutCapture(l, r, rig, &ctx);
  alone.Run(ctx);
  const fitting::Sphere expected = ctx.Get<std::vector<fitting::SphereFitResult>>("fits").back().sphere;
  ASSERT_NEAR(expected.radius_mm, 300, 3);  // a fit at all: 300 mm within the half-size rig's few mm

  OverlappedRunner runner(json, "test", registry);
  EXPECT_EQ(runner.head(), 2u);  // stereo.rectify, stereo.segment_auto
  int given = 0;
  std::vector<std::string> errors;
  std::vector<double> radii;
  const long frames = runner.Run(
      rig,
      [&](cv::Mat* left, cv::Mat* right, Context* c, std::string* error) {
        if (given == 5) return false;
        c->Put("frame", given);
        if (given == 4) {
          *error = "unreadable";  // a frame the source could not read
        } else {
          *left = l;
          *right = given == 1 ? cv::Mat() : r;
        }
        ++given;
        return true;
      },
      [&](Context& c, const RunReport& report, const std::string& error) {
        EXPECT_EQ(c.Get<int>("frame"), int(errors.size()));  // in order, each with its own context
        errors.push_back(error);
        radii.push_back(error.empty() ? c.Get<std::vector<fitting::SphereFitResult>>("fits").back().sphere.radius_mm : 0);
        if (error.empty()) {
          EXPECT_EQ(report.stages.size(), runner.pipeline().stages().size());
        }
      });
  EXPECT_EQ(frames, 5);
  ASSERT_EQ(errors.size(), 5u);
  for (int i : {0, 2, 3}) {
    EXPECT_EQ(errors[std::size_t(i)], "") << i;
    EXPECT_EQ(radii[std::size_t(i)], expected.radius_mm) << i;
  }
  EXPECT_NE(errors[1], "");
  EXPECT_EQ(errors[4], "unreadable");
}

TEST(Capture, ColourSegmentationRefusesNonGreenAndWholeFrameRegions) {
  cv::Mat board(240, 320, CV_8UC3);
  for (int y = 0; y < board.rows; ++y) {
    for (int x = 0; x < board.cols; ++x) {
      board.at<cv::Vec3b>(y, x) = ((x / 40 + y / 40) % 2) ? cv::Vec3b(230, 60, 20) : cv::Vec3b(120, 30, 10);
    }
  }
  try {
    SegmentHedge(board, SegmentOptions{});
    FAIL() << "a blue checkerboard gave a hedge";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("no hedge found: nothing in the image is green", 0), 0u) << e.what();
  }
  // One green everywhere (a wall of hedge, a lens cap's green reflection): the whole frame.
  // (A textured lawn around a hedge is the garden issue: colour alone cannot tell them apart.)
  const cv::Mat green(240, 320, CV_8UC3, cv::Scalar(40, 150, 40));
  try {
    SegmentHedge(green, SegmentOptions{});
    FAIL() << "a frame that is green everywhere gave a hedge";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no hedge found"), std::string::npos) << e.what();
  }
}

TEST(Capture, NoHedgeIsAClearError) {
  const StereoRig rig = TrueRig(PaperRig(0.25));
  const cv::Mat brown(rig.image_size, CV_8UC3, cv::Scalar(60, 90, 140));  // no green anywhere
  try {
    ConvertCapture(brown, brown, rig, {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no hedge found"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ConvertCapture(brown, cv::Mat(10, 10, CV_8UC3), rig, {}), Error);
}

// For grey images: inside a box, the region at the depth of the box's middle. A second
// object at the same depth elsewhere in the box and the background behind are left out;
// a hole of unknown disparity inside the object is filled.
TEST(Capture, DepthSegmentationKeepsTheObjectInTheBox) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat d(120, 160, CV_32F, cv::Scalar(10.0f));  // background, 10 px
  const cv::Point c(70, 60);
  const int radius = 25;
  cv::Mat truth = cv::Mat::zeros(d.size(), CV_8U);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const double r2 = double((x - c.x) * (x - c.x) + (y - c.y) * (y - c.y));
      if (r2 < radius * radius) {
        d.at<float>(y, x) = float(14.0 + 0.5 * (1 - r2 / (radius * radius)));  // a dome, 14-14.5 px
        truth.at<std::uint8_t>(y, x) = 255;
      }
    }
  }
  d(cv::Rect(105, 20, 8, 8)).setTo(14.2f);  // same depth, not connected
  d(cv::Rect(66, 56, 5, 5)).setTo(nan);     // no match inside the object
  const cv::Rect box(40, 15, 80, 80);
  const cv::Mat mask = SegmentByDepth(d, box, 1.0, 0);
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(105, 20, 8, 8))), 0);
  EXPECT_EQ(cv::countNonZero(mask & ~truth), 0);
  EXPECT_EQ(cv::countNonZero(truth & ~mask), 0);  // the hole is filled
  // Nothing at one depth in the middle of the box is a clear error.
  cv::Mat empty(120, 160, CV_32F, cv::Scalar(nan));
  try {
    SegmentByDepth(empty, box, 1.0, 0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no hedge found"), std::string::npos) << e.what();
  }
}

// Excess green needs colour: a grey image gets a one-line error that says what to do.
TEST(Capture, GreyImagesAskForABoxOrAMask) {
  const cv::Mat grey(60, 80, CV_8UC3, cv::Scalar(90, 90, 90));
  try {
    SegmentHedge(grey, SegmentOptions{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--box X,Y,W,H"), std::string::npos) << e.what();
  }
}

// A rig from numbers for an already rectified pair: rectification leaves the images as
// they are, and a disparity reprojects to Z = f b / d, X = (u - cx) Z / f exactly.
TEST(Capture, RigForARectifiedPairReprojectsByTheNumbers) {
  const double f = 368.5347, cx = 318.1122, cy = 224.3349, b = 838.7445;
  const StereoRig rig = RigForRectifiedPair(cv::Size(640, 480), f, cx, cy, b);
  cv::Mat img(480, 640, CV_8UC3);
  cv::randu(img, 0, 255);
  cv::Mat l, r;
  RectifyPair(rig, img, img, &l, &r);
  EXPECT_EQ(cv::norm(l, img, cv::NORM_INF), 0.0);
  cv::Mat disparity(480, 640, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  disparity.at<float>(200, 290) = 13.0f;
  const cloud::PointCloud pc = Reproject(disparity, cv::Mat(), img, rig, {});
  ASSERT_EQ(pc.size(), 1u);
  const double z = f * b / 13.0;
  EXPECT_NEAR(pc.points_mm[0].z(), z, z * 1e-6);  // float storage
  EXPECT_NEAR(pc.points_mm[0].x(), (290 - cx) * z / f, 0.05);
  EXPECT_NEAR(pc.points_mm[0].y(), (200 - cy) * z / f, 0.05);
  EXPECT_THROW(RigForRectifiedPair(cv::Size(640, 480), f, cx, cy, 0), Error);
}

// ReprojectMeasured over the matcher's region (stereo.sgbm's `matched_region`) gives the cloud of
// the whole frame: the same points, colours and fields in the same order, the pixels' coordinates
// those of the frame. And a disparity a later stage wrote outside the region is not lost.
TEST(Capture, ReprojectingOverTheMatchedRegionGivesTheWholeFramesCloud) {
  const StereoRig rig = RigForRectifiedPair(cv::Size(640, 480), 368.5, 318.1, 224.3, 838.7);
  cv::Mat img(480, 640, CV_8UC3), mask(480, 640, CV_8U, cv::Scalar(255)), filled = cv::Mat::zeros(480, 640, CV_8U);
  cv::randu(img, 0, 255);
  const cv::Rect region(200, 120, 150, 90);
  cv::Mat disparity(480, 640, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  cv::Mat sigma = disparity.clone();
  cv::randu(disparity(region), 10.0, 14.0);
  cv::randu(sigma(region), 0.01, 0.1);
  mask(cv::Rect(200, 120, 20, 90)).setTo(0);    // masked out at the region's left
  filled(cv::Rect(300, 150, 10, 10)).setTo(255);  // filled, not measured
  const auto same = [](const cloud::PointCloud& a, const cloud::PointCloud& b) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a.points_mm[i], b.points_mm[i]) << i;
      ASSERT_EQ(a.colors[i], b.colors[i]) << i;
    }
    ASSERT_EQ(a.fields.size(), b.fields.size());
    for (const auto& [name, values] : a.fields) ASSERT_EQ(values, b.fields.at(name)) << name;
  };
  const cloud::PointCloud whole = ReprojectMeasured(disparity, mask, filled, img, rig, {}, sigma);
  EXPECT_EQ(whole.size(), std::size_t(130 * 90 - 100));  // the region less the masked strip and the filled square
  same(ReprojectMeasured(disparity, mask, filled, img, rig, {}, sigma, cv::Mat(), region), whole);
  disparity.at<float>(400, 50) = 12.0f;  // outside the region
  const cloud::PointCloud more = ReprojectMeasured(disparity, mask, filled, img, rig, {}, sigma);
  EXPECT_EQ(more.size(), whole.size() + 1);
  same(ReprojectMeasured(disparity, mask, filled, img, rig, {}, sigma, cv::Mat(), region), more);
}

}  // namespace
}  // namespace hedgefit::stereo

namespace hedgefit::stereo {
namespace {

// A batch with one corrupt capture: it is reported and skipped, the rest complete, and
// the exit status says something failed.
TEST(ConvertCli, BatchSkipsACorruptCaptureAndFinishesTheRest) {
  const auto dir = hedgefit::testing::ScratchDir();
  const SimRig sim = PaperRig(0.25);
  WriteRig((dir / "rig.yaml").string(), TrueRig(sim));
  std::filesystem::create_directories(dir / "in");
  SphereScene scene;
  cv::imwrite((dir / "in" / "good_left.png").string(), RenderSphere(sim, false, scene, RenderOptions{}));
  cv::imwrite((dir / "in" / "good_right.png").string(), RenderSphere(sim, true, scene, RenderOptions{}));
  std::ofstream(dir / "in" / "bad_left.png") << "not a png";
  std::ofstream(dir / "in" / "bad_right.png") << "not a png";
  const std::string cmd = "cd '" + dir.string() + "' && '" + std::string(HEDGEFIT_EXE) +
                          "' convert --input in --rig rig.yaml --output-dir out --threads 2 > log.txt 2>&1";
  const int status = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::ifstream log(dir / "log.txt");
  const std::string text((std::istreambuf_iterator<char>(log)), {});
  EXPECT_NE(text.find("bad: skipped: in/bad_left.png: not a PNG, JPEG, TIFF, BMP or PNM image"), std::string::npos) << text;
  EXPECT_NE(text.find("converted 1 of 2 captures"), std::string::npos) << text;
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "good.pcd"));
  EXPECT_FALSE(std::filesystem::exists(dir / "out" / "bad.pcd"));
}

// hedgefit decodes PNG and JPEG itself (libpng, libjpeg: OpenCV's imgcodecs would load ~140
// libraries into every command) and other formats through its imgcodecs module. Every pixel must
// be the one OpenCV's imread gives, in colour and in grey: on the shared data's real camera files
// (OpenCV's JPEG chessboards, Middlebury's Aloe JPEG, Motorcycle PNG and Cones TIFF, PCL's grey
// outdoor PNG) when present, and always on the PNG variants cameras write (grey, 16-bit, with
// alpha) and on JPEG and BMP files. Encoding round-trips: PNG exactly, JPEG as OpenCV decodes it.
TEST(ImageIo, DecodesEveryPixelAsOpenCvDoes) {
  const auto dir = hedgefit::testing::ScratchDir();
  cv::Mat colour(61, 83, CV_8UC3), grey(61, 83, CV_8UC1), deep(61, 83, CV_16UC1), alpha(61, 83, CV_8UC4);
  cv::randu(colour, 0, 255);
  cv::randu(grey, 0, 255);
  cv::randu(deep, 0, 65535);
  cv::randu(alpha, 0, 255);
  std::vector<std::string> files;
  for (const auto& [name, image] : std::vector<std::pair<std::string, cv::Mat>>{
           {"colour.png", colour}, {"grey.png", grey}, {"deep.png", deep}, {"alpha.png", alpha},
           {"colour.jpg", colour}, {"grey.jpg", grey}, {"colour.bmp", colour}}) {
    ASSERT_TRUE(cv::imwrite((dir / name).string(), image)) << name;
    files.push_back((dir / name).string());
  }
  int real = 0;
  for (const std::string rel : {"calib_chessboard/left01.jpg", "stereo_gt/aloe/aloeL.jpg",
                                "stereo_gt/middlebury2014_motorcycle_Q/im0.png", "stereo_gt/middlebury2003_cones_pandora/left.tif",
                                "stereo_plants/pcl_outdoor_stereo_pair/stereo_left.png"}) {
    if (std::filesystem::exists(hedgefit::testing::DataPath(rel))) files.push_back(hedgefit::testing::DataPath(rel)), ++real;
  }
  for (const std::string& f : files) {
    for (const int flags : {cv::IMREAD_COLOR, cv::IMREAD_GRAYSCALE, cv::IMREAD_UNCHANGED}) {
      const cv::Mat expected = cv::imread(f, flags), got = ReadImageFile(f, flags);
      ASSERT_FALSE(expected.empty()) << f;
      ASSERT_EQ(got.type(), expected.type()) << f << " flags " << flags;
      ASSERT_EQ(got.size(), expected.size()) << f << " flags " << flags;
      EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0) << f << " flags " << flags;
    }
  }
  std::cout << files.size() - real << " synthetic and " << real << " real files decoded as OpenCV does\n";
  for (const cv::Mat& image : {colour, grey, deep, alpha}) {
    std::vector<unsigned char> bytes;
    ASSERT_TRUE(EncodeImage(".png", image, &bytes));
    EXPECT_EQ(cv::norm(DecodeImage(bytes, cv::IMREAD_UNCHANGED, "png"), image, cv::NORM_INF), 0.0);
  }
  std::vector<unsigned char> bytes;
  ASSERT_TRUE(EncodeImage(".jpg", colour, &bytes, 90));
  EXPECT_EQ(cv::norm(DecodeImage(bytes, cv::IMREAD_COLOR, "jpg"), cv::imdecode(bytes, cv::IMREAD_COLOR), cv::NORM_INF), 0.0);
  EXPECT_FALSE(EncodeImage(".nope", colour, &bytes));
  EXPECT_THROW(DecodeImage({1, 2, 3}, cv::IMREAD_COLOR, "noise"), Error);
}

// A capture cut short (a copy interrupted, a file still being written) is refused by name:
// OpenCV would decode a JPEG's missing rows as grey and the matcher would carry on. The whole
// files are read, so the check cannot pass by refusing everything.
TEST(ReadCaptureImage, FilesCutShortAreRefused) {
  const auto dir = hedgefit::testing::ScratchDir();
  cv::Mat img(120, 160, CV_8UC3);
  cv::randu(img, 0, 255);
  for (const std::string ext : {".png", ".jpg"}) {
    const std::string whole = (dir / ("whole" + ext)).string(), cut = (dir / ("cut" + ext)).string();
    ASSERT_TRUE(cv::imwrite(whole, img));
    std::ifstream in(whole, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() * 2 / 3);
    EXPECT_EQ(ReadCaptureImage(whole).size(), img.size()) << ext;
    try {
      ReadCaptureImage(cut);
      ADD_FAILURE() << ext << ": a file cut to two thirds was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(cut + ": the " + std::string(ext == ".png" ? "PNG" : "JPEG") +
                                           " file is cut short"),
                std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace hedgefit::stereo

#include "pipeline/pipeline.hpp"
#include "fitting/fitting_stages.hpp"
#include "stereo/stereo_stages.hpp"
#include "stereo/overlap.hpp"
#include "fitting/fitting_stages.hpp"
#include "fitting/methods.hpp"

namespace hedgefit::stereo {
namespace {

// The true rig as dir/rig.yaml and the default sphere scene as dir/l.png, dir/r.png.
SphereScene WriteSimulatedCapture(const std::filesystem::path& dir, const SimRig& sim) {
  WriteRig((dir / "rig.yaml").string(), TrueRig(sim));
  SphereScene scene;
  RenderOptions ro;
  ro.supersample = 2;
  cv::imwrite((dir / "l.png").string(), RenderSphere(sim, false, scene, ro));
  cv::imwrite((dir / "r.png").string(), RenderSphere(sim, true, scene, ro));
  return scene;
}

TEST(StereoStages, CaptureToFitInOnePipeline) {
  const auto dir = hedgefit::testing::ScratchDir();
  const SimRig sim = PaperRig(0.5);
  WriteSimulatedCapture(dir, sim);
  pipeline::Registry registry;
  measure::AddStageModules(registry);
  const std::string d = dir.string();
  const std::string json = R"([{"type": "readers.stereo", "left": ")" + d + R"(/l.png", "right": ")" + d +
                           R"(/r.png", "rig": ")" + d + R"(/rig.yaml"}, {"type": "stereo.rectify"},
      {"type": "stereo.segment"}, {"type": "stereo.sgbm"}, {"type": "stereo.reproject"},
      {"type": "fitters.ransac", "distance_threshold": 30, "min_radius": 100, "max_radius": 1000}])";
  pipeline::Pipeline p = pipeline::Pipeline::FromJson(json, "p", registry);
  pipeline::Context ctx;
  p.Run(ctx);
  // Every 2nd pixel and row (min_stride) of the ~10,000 the sphere covers at half scale.
  EXPECT_GT(ctx.Get<cloud::PointCloud>("cloud").size(), 2000u);
  const auto& fits = ctx.Get<std::vector<fitting::SphereFitResult>>("fits");
  ASSERT_EQ(fits.size(), 1u);
  ASSERT_TRUE(fits[0].converged);
  // Same bounds as SimulatedSphereConvertsAndFits (half-size rig, silhouette bias).
  EXPECT_NEAR(fits[0].sphere.radius_mm, 300.0, 5.0);

  // Matching unrectified images is refused with a clear message.
  const std::string no_rectify = R"([{"type": "readers.stereo", "left": ")" + d + R"(/l.png", "right": ")" + d +
                                 R"(/r.png", "rig": ")" + d + R"(/rig.yaml"}, {"type": "stereo.sgbm"}])";
  pipeline::Pipeline q = pipeline::Pipeline::FromJson(no_rectify, "q", registry);
  pipeline::Context ctx2;
  try {
    q.Run(ctx2);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "stage 'stereo.sgbm': the images are not rectified; add stereo.rectify before it");
  }
}

// The measuring layer's typed call (measure/measure_capture.hpp), which `measure`, `stream` and
// Python make: from files and from images in memory it is one measurement, its printed lines are
// its fits, and an option no capture stage has is refused by name before anything runs.
TEST(MeasureCapture, FromFilesAndFromMemoryIsOneMeasurement) {
  const auto dir = hedgefit::testing::ScratchDir();
  const SimRig sim = PaperRig(0.5);
  WriteSimulatedCapture(dir, sim);
  pipeline::Registry registry;
  measure::AddStageModules(registry);
  const std::string l = (dir / "l.png").string(), r = (dir / "r.png").string(), rig = (dir / "rig.yaml").string();
  measure::MeasureRequest request;
  request.methods = {"ransac_ray", "geometric"};
  const measure::MeasureResult files = measure::MeasureCapture(l, r, rig, request, registry);
  const measure::MeasureResult memory = measure::MeasureCapture(cv::imread(l, cv::IMREAD_COLOR), cv::imread(r, cv::IMREAD_COLOR),
                                                                ReadRig(rig), request, registry);
  ASSERT_EQ(files.fits.size(), 2u);
  ASSERT_EQ(memory.fits.size(), 2u);
  EXPECT_EQ(files.converged, 2);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(files.fits[k].method, request.methods[k]);
    // The same images, rig and stages: the very same numbers.
    EXPECT_EQ(files.fits[k].sphere.center_mm, memory.fits[k].sphere.center_mm);
    EXPECT_EQ(files.fits[k].sphere.radius_mm, memory.fits[k].sphere.radius_mm);
    // Same bounds as SimulatedSphereConvertsAndFits (half-size rig, silhouette bias).
    EXPECT_NEAR(files.fits[k].sphere.radius_mm, 300.0, 5.0);
    // The printed line is the fit, to the micrometre.
    EXPECT_EQ(files.lines[k]["method"], request.methods[k]);
    EXPECT_NEAR(files.lines[k]["radius_mm"].get<double>(), files.fits[k].sphere.radius_mm, 0.0005);
  }
  EXPECT_TRUE(files.unchecked.empty() || !files.hint.empty()) << "an unchecked rig is said in the hint";
  EXPECT_GT(files.stage_ms.count("stereo.sgbm"), 0u);
  request.capture_options["no_such_option"] = 3.0;
  try {
    measure::MeasureCapture(l, r, rig, request, registry);
    FAIL() << "an unknown capture option was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_option"), std::string::npos) << e.what();
  }
}

// `hedgefit convert` and a pipeline written by hand with the same stages and options must
// give the very same points, for each way of finding the hedge: they are one implementation,
// so any difference (a drifted default, a step one path skips) shows as unequal clouds.
TEST(StereoStages, ConvertAndTheEquivalentPipelineGiveTheSamePoints) {
  const auto dir = hedgefit::testing::ScratchDir();
  const SimRig sim = PaperRig(0.5);
  const SphereScene scene = WriteSimulatedCapture(dir, sim);
  // The user's mask and box are drawn on the unrectified left image: the label truth.
  RenderOptions lo;
  lo.labels = true;
  const cv::Mat sphere = RenderSphere(sim, false, scene, lo) == kLabelSphere;
  cv::imwrite((dir / "mask.png").string(), sphere);
  const cv::Rect b = cv::boundingRect(sphere);
  const std::string box = std::to_string(b.x - 8) + "," + std::to_string(b.y - 8) + "," + std::to_string(b.width + 16) +
                          "," + std::to_string(b.height + 16);
  const std::string d = dir.string();
  struct Mode {
    std::string name, flags, segment_stage;
  };
  // Non-default options on purpose, so each must reach its stage on both paths.
  const std::vector<Mode> modes = {
      // The default: colour where the mask isolates the hedge, as here.
      {"auto", "--erode 3 --gamma 1.2", R"({"type": "stereo.segment_auto", "erode": 3, "gamma": 1.2})"},
      {"colour", "--erode 3 --gamma 1.2 --garden-above 0", R"({"type": "stereo.segment", "erode": 3, "gamma": 1.2})"},
      {"mask", "--mask mask.png --erode 3", R"({"type": "stereo.mask", "filename": ")" + d + R"(/mask.png", "erode": 3})"},
      {"box", "--box " + box + " --erode 3",
       // convert's --block-size and --min-z set every stage that has them: the depth stage too.
       R"({"type": "stereo.segment_depth", "box": [)" + box + R"(], "erode": 3, "block_size": 7, "min_z": 1800})"}};
  for (const Mode& m : modes) {
    SCOPED_TRACE(m.name);
    const std::string cli = "cd '" + d + "' && '" HEDGEFIT_EXE "' convert --left l.png --right r.png --rig rig.yaml -q " +
                            "--block-size 7 --min-z 1800 -o " + m.name + "_cli.pcd " + m.flags;
    ASSERT_EQ(std::system(cli.c_str()), 0) << cli;
    std::ofstream(dir / "p.json") << R"([{"type": "readers.stereo", "left": ")" << d << R"(/l.png", "right": ")" << d
                                  << R"(/r.png", "rig": ")" << d << R"(/rig.yaml"}, {"type": "stereo.rectify"}, )"
                                  << m.segment_stage
                                  << R"(, {"type": "stereo.sgbm", "block_size": 7, "min_z": 1800}, )"
                                  << R"({"type": "stereo.reproject"}, ")" << d << "/" << m.name << R"(_json.pcd"])";
    const std::string pipeline = "cd '" + d + "' && '" HEDGEFIT_EXE "' pipeline p.json -q";
    ASSERT_EQ(std::system(pipeline.c_str()), 0) << pipeline;
    const cloud::PointCloud a = cloud::ReadCloud((dir / (m.name + "_cli.pcd")).string());
    const cloud::PointCloud c = cloud::ReadCloud((dir / (m.name + "_json.pcd")).string());
    ASSERT_GT(a.size(), 1000u);  // a whole cloud came through (the larger masks every 2nd pixel and row: min_stride)
    ASSERT_EQ(a.size(), c.size());
    for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.points_mm[i], c.points_mm[i]) << i;
    EXPECT_EQ(a.fields.at("disparity"), c.fields.at("disparity"));
  }
}

// The matching slot: a plugin's matcher runs in place of stereo.sgbm with no change to
// convert. StereoBM (integer-ish disparities, no refinement) is far coarser, so the check is
// only that the cloud lies on the true sphere to within StereoBM's 1/16 px steps and its
// block-size fattening at the rim: the median |distance to the true sphere| under 15 mm.
TEST(StereoStages, APluginMatcherFillsTheMatchingSlot) {
  const auto dir = hedgefit::testing::ScratchDir();
  const SimRig sim = PaperRig(0.5);
  const SphereScene scene = WriteSimulatedCapture(dir, sim);
  const std::string cmd = "cd '" + dir.string() + "' && HEDGEFIT_PLUGIN_PATH='" HEDGEFIT_TEST_PLUGIN_DIR
                          "/block_matcher' '" HEDGEFIT_EXE "' convert --left l.png --right r.png --rig rig.yaml -q "
                          "--matcher stereo.block_matcher -o bm.pcd";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const cloud::PointCloud c = cloud::ReadCloud((dir / "bm.pcd").string());
  ASSERT_GT(c.size(), 1000u);
  EXPECT_EQ(c.fields.count("disparity"), 1u);
  std::vector<double> d;
  const Eigen::Vector3d centre(scene.center[0], scene.center[1], scene.center[2]);
  for (const auto& p : c.points_mm) d.push_back(std::abs((p.cast<double>() - centre).norm() - scene.radius));
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(d.size() / 2), d.end());
  EXPECT_LT(d[d.size() / 2], 15.0);
  // Without the plugin on the search path the name is unknown, with a suggestion.
  const std::string bad = "cd '" + dir.string() + "' && HEDGEFIT_PLUGIN_PATH=/nonexistent '" HEDGEFIT_EXE
                          "' convert --left l.png --right r.png --rig rig.yaml -q --matcher stereo.block_matcher "
                          "-o bm2.pcd 2>/dev/null";
  EXPECT_NE(std::system(bad.c_str()), 0);
  EXPECT_FALSE(std::filesystem::exists(dir / "bm2.pcd"));
}

// Two views of uniform noise, unrelated, on an already rectified rig (identity rectification,
// so a shift between the views is a disparity), and options that take the whole frame as the
// hedge (a mask file of all 255 in `dir`).
struct NoisePair {
  StereoRig rig = RigForRectifiedPair(cv::Size(480, 300), 233.3, 239.5, 149.5, 140.0);
  cv::Mat left, right;
  ConvertOptions options;
  NoisePair(std::uint64_t seed, const std::filesystem::path& dir)
      : left(rig.image_size, CV_8UC3), right(rig.image_size, CV_8UC3) {
    cv::RNG rng(seed);
    rng.fill(left, cv::RNG::UNIFORM, 0, 256);
    rng.fill(right, cv::RNG::UNIFORM, 0, 256);
    cv::imwrite((dir / "all.png").string(), cv::Mat(rig.image_size, CV_8U, cv::Scalar(255)));
    options.mode = SegmentMode::kMask;
    options.mask.filename = (dir / "all.png").string();
  }
};

// Whatever the images, no point leaves the matcher outside the working range: where the views
// are unrelated noise (nothing to match) every disparity written lies within f b / max_z..f b /
// min_z.
TEST(StereoStages, NoPointOutsideTheWorkingRange) {
  NoisePair n(5, hedgefit::testing::ScratchDir());
  const StereoRig& rig = n.rig;
  cv::Mat &l = n.left, &r = n.right;
  // The left half of the views is one surface 15 px of disparity away (2.2 m, inside the range),
  // so the views are a stereo pair (a pair that matches nowhere is refused); the right half
  // stays unrelated noise.
  l.colRange(15, l.cols / 2 + 15).copyTo(r.colRange(0, l.cols / 2));
  ConvertOptions& o = n.options;
  o.match.min_z_mm = 1800;
  o.match.max_z_mm = 2600;
  o.reproject.keep_filled = true;  // filled values too
  // Noise matches somewhere at every disparity: without the range check SGBM's padded search
  // and the filling put points beyond it.
  const ConvertResult res = ConvertCapture(l, r, rig, o);
  ASSERT_GT(res.cloud.size(), 100u);
  const double fb = rig.P1.at<double>(0, 0) * rig.baseline_mm;
  for (float d : res.cloud.fields.at("disparity")) {
    ASSERT_GE(d, fb / 2600 - 1e-4);
    ASSERT_LE(d, fb / 1800 + 1e-4);
  }
}

// Two views that match nowhere (unrelated images; a pair given left for right is the same to the
// matcher) are refused rather than fitted: a few hundred chance survivors of the left-right check
// out of 144000 pixels describe no hedge.
TEST(StereoStages, ViewsThatDoNotMatchAreRefused) {
  NoisePair n(6, hedgefit::testing::ScratchDir());
  const StereoRig& rig = n.rig;
  cv::Mat &l = n.left, &r = n.right;
  const ConvertOptions& o = n.options;
  try {
    ConvertCapture(l, r, rig, o);
    FAIL() << "unrelated views were measured";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("match between the views: the images are not a stereo pair of this rig"),
              std::string::npos)
        << e.what();
  }
  // The same views as a pair (the right one the left shifted by 15 px of disparity) are measured:
  // max_points keeps every 2nd pixel and row of the 144000, 36000, and over two thirds match.
  l.colRange(15, l.cols).copyTo(r.colRange(0, l.cols - 15));
  EXPECT_GT(ConvertCapture(l, r, rig, o).cloud.size(), 24000u);
  // Thinned hard (every 9th pixel and row: 1777 of the 144000), the pair is judged on the pixels
  // kept, not refused for matching under 2 % of the whole hedge.
  ConvertOptions thin = o;
  thin.match.max_points = 2000;
  EXPECT_GT(ConvertCapture(l, r, rig, thin).cloud.size(), 1000u);
}

}  // namespace
}  // namespace hedgefit::stereo
