// Hedges where they grow: the garden renders (leafy balls on a lawn before a hedge row, a pot,
// trees, a hard sun) must give every hedge, each with its own cloud, and the envelope fit must
// find each ball's outer envelope, not its mean leaf surface.

#include "stereo/depth_segmentation.hpp"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "bench/garden_bench.hpp"
#include "bench/lab_bench.hpp"
#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "cloud/filters.hpp"
#include "eval/truth_file.hpp"
#include "fitting/envelope_fit.hpp"
#include "sim/camera_model.hpp"
#include "stereo/capture.hpp"
#include "sim/povray.hpp"
#include "sim/simulator.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::stereo {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
using namespace hedgefit::sim;  // the test data's renderer
namespace {

struct Rendered {
  SimRig sim;
  GardenScene scene;
  cv::Mat left, right, left_labels;
};

Rendered Render(const std::string& preset, double scale) {
  Rendered r;
  r.sim = PaperRig(scale);
  r.scene = GardenPreset(preset);
  RenderOptions ro;
  ro.supersample = 2;
  ro.blur_sigma_px = 0.5;
  ro.noise_sigma = 1.0;  // independent per camera
  r.left = RenderGarden(r.sim, false, r.scene, ro);
  r.right = RenderGarden(r.sim, true, r.scene, ro);
  RenderOptions lo;
  lo.labels = true;
  r.left_labels = RenderGarden(r.sim, false, r.scene, lo);
  return r;
}

// The paper's lab sphere (a non-green background: found by colour) on the same rig, with 1 grey
// level of noise independent per camera: the captures whose path the garden options must not touch.
std::pair<cv::Mat, cv::Mat> RenderLabSphere(const SimRig& sim) {
  SphereScene sc;
  sc.center = cv::Vec3d(70, 50, 2300);
  RenderOptions ro;
  ro.supersample = 2;
  ro.noise_sigma = 1.0;
  return {RenderSphere(sim, false, sc, ro), RenderSphere(sim, true, sc, ro)};
}

std::size_t FinitePoints(const cloud::PointCloud& c) {
  std::size_t n = 0;
  for (const auto& p : c.points_mm) n += cloud::IsFinite(p) ? 1 : 0;
  return n;
}

// The scene itself: each hedge's label covers its projected centre, and the truth's surface
// radius lies inside the envelope by less than the shell's depth.
TEST(GardenScene, HedgesAreWhereTheTruthSaysAndTheShellIsInsideTheEnvelope) {
  const Rendered r = Render("row", 0.25);
  const cv::Matx33d K = r.sim.left.K;
  for (std::size_t i = 0; i < r.scene.hedges.size(); ++i) {
    const cv::Vec3d c = GardenHedgeCenter(r.scene, i);
    std::vector<cv::Point2d> px;
    cv::projectPoints(std::vector<cv::Point3d>{cv::Point3d(c[0], c[1], c[2])}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                      cv::Mat(K), cv::Mat(r.sim.left.dist), px);
    const cv::Point p(int(std::lround(px[0].x)), int(std::lround(px[0].y)));
    ASSERT_TRUE(cv::Rect(0, 0, r.left_labels.cols, r.left_labels.rows).contains(p));
    EXPECT_EQ(int(r.left_labels.at<std::uint8_t>(p)), kLabelHedge + int(i)) << "hedge " << i;
    const double surface = GardenHedgeSurfaceRadius(r.scene, i);
    const GardenHedge& h = r.scene.hedges[i];
    EXPECT_LT(surface, h.radius_mm - 0.1 * h.leaf_depth_mm);
    EXPECT_GT(surface, h.radius_mm - h.leaf_depth_mm);
  }
}

// The "single" garden at half scale as the left camera sees it exactly: its labels, every
// pixel's first hit (RenderGardenSurface) and the ball's truth.
struct ExactView {
  SimRig sim = PaperRig(0.5);
  GardenScene scene = GardenPreset("single");
  cv::Mat labels, surface;
  fitting::Sphere truth;
  ExactView() {
    RenderOptions lo;
    lo.labels = true;
    labels = RenderGarden(sim, false, scene, lo);
    surface = RenderGardenSurface(sim, scene);
    const cv::Vec3d c = GardenHedgeCenter(scene, 0);
    truth = {Eigen::Vector3d(c[0], c[1], c[2]), scene.hedges[0].radius_mm};
  }
};

// The envelope fit against the renderer's own leaves, with no matcher in between: the exact
// first hit of each hedge pixel's ray (RenderGardenSurface). Every hit lies inside the truth's
// envelope, and the fit reads the envelope where those leaves end and the centre where the
// truth puts it. About a quarter of this renderer's leaf surface lies on the envelope itself
// (LeafDepthFraction), so the fit has exact points there: it came within 0.001 mm of both;
// 0.3 mm on R and 0.5 mm on the centre fail a fit that reads the mean leaf (12 mm inside) or
// lets the leaf layer push the centre back.
TEST(GardenScene, EnvelopeFitReadsTheRenderedLeavesEnvelope) {
  const ExactView view;
  const cv::Mat &labels = view.labels, &surface = view.surface;
  ASSERT_EQ(surface.type(), CV_32FC3);
  ASSERT_EQ(surface.size(), labels.size());
  const Eigen::Vector3d centre = view.truth.center_mm;
  const double R = view.truth.radius_mm;
  std::vector<Eigen::Vector3d> pts;
  double farthest = 0;
  for (int v = 0; v < labels.rows; ++v) {
    for (int u = 0; u < labels.cols; ++u) {
      if (labels.at<std::uint8_t>(v, u) != kLabelHedge) continue;
      const cv::Vec3f p = surface.at<cv::Vec3f>(v, u);
      ASSERT_TRUE(std::isfinite(p[2])) << "hedge pixel (" << u << ", " << v << ") has no surface point";
      pts.emplace_back(p[0], p[1], p[2]);
      farthest = std::max(farthest, (pts.back() - centre).norm());
    }
  }
  ASSERT_GT(pts.size(), 5000u);
  EXPECT_LE(farthest, R + 0.1);  // the sphere tracer stops within 0.05 mm of a leaf
  const fitting::EnvelopeFit e = fitting::FitEnvelope(pts);
  ASSERT_TRUE(e.fit.converged) << e.fit.message;
  EXPECT_NEAR(e.fit.sphere.radius_mm, R, 0.3);
  EXPECT_LT((e.fit.sphere.center_mm - centre).norm(), 0.5);
}

// bench garden's table of the matcher against the renderer's leaves (bench::MeasureLeafLayer):
// the exact first hits read as no error in every depth bin, with as many leaves within 2 mm of
// the envelope measured as there truly are; the same points moved 3 mm deeper along their rays
// (what a matcher that reads too far does) read deeper in every bin, by the ray's radial share
// of 3 mm (cos of the incidence: 1 face-on, above 0.1 but near the rim), and fewer of them
// within 2 mm of the envelope. Lawn pixels' points are left out.
TEST(GardenScene, LeafLayerTableHoldsPointsToTheirPixelsTrueLeaf) {
  const ExactView view;
  const cv::Mat &labels = view.labels, &surface = view.surface;
  const SimRig& sim = view.sim;
  const fitting::Sphere& truth = view.truth;
  std::vector<Eigen::Vector3d> exact, deeper;
  std::size_t lawn = 0;
  for (int v = 0; v < labels.rows; ++v) {
    for (int u = 0; u < labels.cols; ++u) {
      const cv::Vec3f p = surface.at<cv::Vec3f>(v, u);
      const Eigen::Vector3d q(p[0], p[1], p[2]);
      if (labels.at<std::uint8_t>(v, u) == kLabelHedge) {
        exact.push_back(q);
        deeper.push_back(q + 3.0 * q.normalized());
      } else if (labels.at<std::uint8_t>(v, u) == kLabelGround && lawn < 500 && (v + u) % 97 == 0) {
        exact.push_back(q), deeper.push_back(q), ++lawn;
      }
    }
  }
  ASSERT_EQ(lawn, 500u);
  const bench::LeafLayerErrors e = bench::MeasureLeafLayer(exact, surface, sim.left, truth);
  EXPECT_EQ(e.points, exact.size() - lawn);
  std::size_t binned = 0;
  for (const bench::LeafDepthBin& b : e.bins) {
    binned += b.points;
    EXPECT_NEAR(b.mean_error_mm, 0.0, 0.01) << b.from_mm << "-" << b.to_mm << " mm";  // float32 points
  }
  EXPECT_EQ(binned, e.points);
  EXPECT_GT(e.true_outer_share, 0.1);  // a quarter of this renderer's leaf surface is on the envelope
  EXPECT_DOUBLE_EQ(e.measured_outer_share, e.true_outer_share);
  const bench::LeafLayerErrors d = bench::MeasureLeafLayer(deeper, surface, sim.left, truth);
  EXPECT_EQ(d.points, e.points);
  for (const bench::LeafDepthBin& b : d.bins) {
    if (b.points == 0) continue;
    EXPECT_LT(b.mean_error_mm, -0.3) << b.from_mm << "-" << b.to_mm << " mm";
    EXPECT_GE(b.mean_error_mm, -3.0) << b.from_mm << "-" << b.to_mm << " mm";
  }
  EXPECT_LT(d.measured_outer_share, e.true_outer_share);
}

TEST(GardenScene, TruthFileListsEveryHedgeAndReadsBack) {
  const auto dir = testing::ScratchDir();
  const auto files = WriteGarden(dir.string(), 0.2, RenderOptions{}, {"row"});
  const auto truths = eval::ReadSphereTruths((dir / "garden_row.truth.json").string());
  const GardenScene sc = GardenPreset("row");
  ASSERT_EQ(truths.size(), sc.hedges.size());
  for (std::size_t i = 0; i < truths.size(); ++i) {
    const cv::Vec3d c = GardenHedgeCenter(sc, i);
    EXPECT_NEAR(truths[i].center_mm.x(), c[0], 1e-6);
    EXPECT_NEAR(truths[i].radius_mm, sc.hedges[i].radius_mm, 1e-9);
    ASSERT_TRUE(truths[i].surface_radius_mm.has_value());
  }
  // One sphere is asked for, three are listed: refused, not the first silently taken.
  EXPECT_THROW(eval::ReadSphereTruth((dir / "garden_row.truth.json").string()), Error);
  EXPECT_NO_THROW(ReadRig((dir / "rig.yaml").string()));
}

// The row at the paper's resolution, end to end: three hedges found (the pot rejected as not
// green), each cloud within its envelope, and the envelope fit on target.
TEST(GardenCapture, RowOfThreeBallsGivesThreeHedgesAndTheirEnvelopes) {
  const Rendered r = Render("row", 1.0);
  const StereoRig rig = RigFromSimulation(r.sim);
  ConvertOptions o;
  o.mode = SegmentMode::kGarden;
  const ConvertResult res = ConvertCapture(r.left, r.right, rig, o);
  ASSERT_EQ(res.hedges.size(), 3u);
  const auto groups = cloud::HedgeGroups(res.cloud);
  ASSERT_EQ(groups.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const GardenHedge& h = r.scene.hedges[i];
    const cv::Vec3d c = GardenHedgeCenter(r.scene, i);
    const Eigen::Vector3d centre(c[0], c[1], c[2]);
    EXPECT_EQ(res.hedges[i].id, int(i) + 1);
    EXPECT_EQ(groups[i].id, int(i) + 1);
    // Ids left to right, as the truth lists them: hedge i's points lie around truth i.
    std::vector<Eigen::Vector3d> pts;
    std::size_t outside = 0;
    for (std::size_t k : groups[i].indices) {
      pts.push_back(res.cloud.points_mm[k].cast<double>());
      if ((pts.back() - centre).norm() - h.radius_mm > 50) ++outside;
    }
    ASSERT_GT(pts.size(), 5000u);
    // The issue's target: at most 2 % of a hedge's points more than 50 mm outside its envelope
    // (lawn, pot or background taken for hedge).
    EXPECT_LE(double(outside) / double(pts.size()), 0.02) << "hedge " << i + 1;
    const fitting::EnvelopeFit fit = fitting::FitEnvelope(pts);
    ASSERT_TRUE(fit.fit.converged) << fit.fit.message;
    // Tolerances: the shell's mean leaf depth here is 12-14 mm, so a fit that found the leaf
    // surface instead of the envelope would be ~12 mm small and its centre ~10 mm far; 6 mm is
    // half of that, and ~3x the stereo error this rig shows on the smooth lab sphere.
    EXPECT_NEAR(fit.fit.sphere.radius_mm, h.radius_mm, 6.0) << "hedge " << i + 1;
    EXPECT_LT((fit.fit.sphere.center_mm - centre).norm(), 6.0) << "hedge " << i + 1;
    EXPECT_NEAR(fit.surface_radius_mm, GardenHedgeSurfaceRadius(r.scene, i), 6.0) << "hedge " << i + 1;
  }
  // Three regions matched, not the row's bounding box.
  EXPECT_LT(res.matched_fraction, 0.45);
}

// The less-certain cut (garden_sigma_ratio) is what brings the envelope in: the 5 x 5 window
// reads the outermost leaves ~1.2 mm too deep where it straddles deeper ones, so with every pixel
// kept the envelope of each ball is 1-3 mm small (1.2-2.8 mm here); keeping each tile's better-pinned half must
// bring the row's mean |error| down by at least 0.5 mm (a third of the 1.5 mm leaf-window bias),
// without moving the centres further than the 6 mm above.
TEST(GardenCapture, TheLessCertainCutBringsTheEnvelopeOut) {
  const Rendered r = Render("row", 1.0);
  const StereoRig rig = RigFromSimulation(r.sim);
  auto mean_error = [&](double ratio) {
    ConvertOptions o;
    o.mode = SegmentMode::kGarden;
    o.match.garden_sigma_ratio = ratio;
    // Cleaned as `measure` cleans it (statistical outlier removal, its defaults).
    const cloud::PointCloud clean =
        cloud::StatisticalOutlierRemoval(ConvertCapture(r.left, r.right, rig, o).cloud, {}).cloud;
    const auto groups = cloud::HedgeGroups(clean);
    EXPECT_EQ(groups.size(), 3u);
    double sum = 0;
    for (std::size_t i = 0; i < std::min<std::size_t>(3, groups.size()); ++i) {
      std::vector<Eigen::Vector3d> pts;
      for (std::size_t k : groups[i].indices) pts.push_back(clean.points_mm[k].cast<double>());
      const fitting::EnvelopeFit fit = fitting::FitEnvelope(pts);
      EXPECT_TRUE(fit.fit.converged) << fit.fit.message;
      const cv::Vec3d c = GardenHedgeCenter(r.scene, i);
      EXPECT_LT((fit.fit.sphere.center_mm - Eigen::Vector3d(c[0], c[1], c[2])).norm(), 6.0) << "hedge " << i + 1;
      sum += std::abs(fit.fit.sphere.radius_mm - r.scene.hedges[i].radius_mm);
    }
    return sum / 3;
  };
  const double all = mean_error(0), cut = mean_error(MatchOptions().garden_sigma_ratio);
  EXPECT_LT(cut, all - 0.5) << "every pixel: " << all << " mm, the better-pinned half: " << cut << " mm";
}

TEST(GardenSegment, PotIsRejectedAsNotGreenAndNamed) {
  const Rendered r = Render("single", 0.5);
  const StereoRig rig = RigFromSimulation(r.sim);
  cv::Mat l, rt;
  RectifyPair(rig, r.left, r.right, &l, &rt);
  const GardenSegmentation g = FindHedges(rig, l, rt, GardenSegmentOptions{});
  ASSERT_EQ(g.hedges.size(), 1u);
  EXPECT_TRUE(g.ground_found);
  bool pot = false;
  for (const auto& why : g.rejected) pot = pot || why.find("not green") != std::string::npos;
  EXPECT_TRUE(pot) << "the terracotta pot should be rejected by colour";
  // The hedge's box holds the truth's projected centre.
  const cv::Vec3d c = GardenHedgeCenter(r.scene, 0);
  std::vector<cv::Point2d> px;
  cv::projectPoints(std::vector<cv::Point3d>{cv::Point3d(c[0], c[1], c[2])}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                    cv::Mat(r.sim.left.K), cv::Mat(r.sim.left.dist), px);
  EXPECT_TRUE(g.hedges[0].image_box.contains(cv::Point(int(px[0].x), int(px[0].y))));
  // Its depth range brackets the ball's front and its limbs.
  EXPECT_LT(g.hedges[0].min_z_mm, c[2] - 0.8 * r.scene.hedges[0].radius_mm);
  EXPECT_GT(g.hedges[0].max_z_mm, c[2] - 0.1 * r.scene.hedges[0].radius_mm);
}

// The coarse match fattens a near object into what lies beside it: a strip of lawn next to a pot
// seen from a low camera, the gap between two balls where the hedge row behind is out of range.
// Both joined a ball to its neighbour in one blob (the pot's points then made 18 % of the
// hedge's cloud; the two balls were one blob, "not round", and neither was found). A row whose
// balls touch is one blob to begin with, and the coarse match fills the shadowed lawn where they
// meet, so its outline has hardly a waist (none of the three was found). Each ball must
// come out alone, as a real camera records it, with at most 2 % of its points more than 50 mm
// outside its envelope (the issue's target).
TEST(GardenSegment, NeighboursTheCoarseMatchJoinsAreCutApart) {
  const SimRig sim = PaperRig(0.5);
  const StereoRig rig = RigFromSimulation(sim);
  RenderOptions ro;
  ro.supersample = 2;
  ro.blur_sigma_px = 0.5;
  const CameraModel camera;  // a real camera: gains, white balance, vignetting, Bayer, noise
  for (const std::string name : {"pair", "low_camera", "touching"}) {
    const GardenScene scene = GardenPreset(name);
    const cv::Mat left = ApplyCameraModel(RenderGarden(sim, false, scene, ro), camera, false, 7);
    const cv::Mat right = ApplyCameraModel(RenderGarden(sim, true, scene, ro), camera, true, 7);
    ConvertOptions o;
    o.mode = SegmentMode::kGarden;
    ConvertResult res;
    try {
      res = ConvertCapture(left, right, rig, o);
    } catch (const Error& e) {
      ADD_FAILURE() << name << ": " << e.what();
      continue;
    }
    const auto groups = cloud::HedgeGroups(res.cloud);
    ASSERT_EQ(groups.size(), scene.hedges.size()) << name;
    for (std::size_t i = 0; i < groups.size(); ++i) {
      const cv::Vec3d t = GardenHedgeCenter(scene, i);
      const Eigen::Vector3d centre(t[0], t[1], t[2]);
      std::size_t outside = 0;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (std::size_t k : groups[i].indices) {
        const Eigen::Vector3d p = res.cloud.points_mm[k].cast<double>();
        mean += p;
        if ((p - centre).norm() - scene.hedges[i].radius_mm > 50) ++outside;
      }
      ASSERT_GT(groups[i].indices.size(), 1000u) << name;
      mean /= double(groups[i].indices.size());
      // Ids left to right: hedge i's points lie on ball i (its visible cap's mean is within a
      // radius of the centre), and hardly any lie off it.
      EXPECT_LT((mean - centre).norm(), scene.hedges[i].radius_mm) << name << ", hedge " << i + 1;
      EXPECT_LE(double(outside) / double(groups[i].indices.size()), 0.02) << name << ", hedge " << i + 1;
    }
  }
}

// The paper's outdoor case with the default options (no --garden, no working range given): a
// r 920 mm ball about 2 m away, its front leaves 1.1 m from the cameras. A working range that
// starts at 1.5 m cut the ball's front away and left a ring no fit could use ("refined radius
// 25 m"). Half scale, 1 grey level of noise per camera.
TEST(GardenCapture, PaperOutdoorBallIsMeasuredWithTheDefaults) {
  const Rendered r = Render("outdoor", 0.5);
  const StereoRig rig = RigFromSimulation(r.sim);
  const ConvertResult res = ConvertCapture(r.left, r.right, rig, ConvertOptions{});
  const auto groups = cloud::HedgeGroups(res.cloud);
  ASSERT_EQ(groups.size(), 1u);
  const cv::Vec3d c = GardenHedgeCenter(r.scene, 0);
  const Eigen::Vector3d centre(c[0], c[1], c[2]);
  ASSERT_LT(centre.z() - r.scene.hedges[0].radius_mm, 1150.0) << "the scene is not the paper's near case";
  std::vector<Eigen::Vector3d> pts;
  for (std::size_t k : groups[0].indices) pts.push_back(res.cloud.points_mm[k].cast<double>());
  ASSERT_GT(pts.size(), 5000u);
  // The front leaves are in the cloud: points within 100 mm of the ball's nearest point.
  const double nearest = centre.norm() - r.scene.hedges[0].radius_mm;
  EXPECT_TRUE(std::any_of(pts.begin(), pts.end(), [&](const Eigen::Vector3d& p) { return p.norm() < nearest + 100; }));
  const fitting::EnvelopeFit fit = fitting::FitEnvelope(pts);
  ASSERT_TRUE(fit.fit.converged) << fit.fit.message;
  // The shell's mean leaf depth here is ~16 mm: a fit to the leaf surface would be that small;
  // 8 mm is half of it, several times the envelope's error on the row at full scale.
  EXPECT_NEAR(fit.fit.sphere.radius_mm, r.scene.hedges[0].radius_mm, 8.0);
  EXPECT_LT((fit.fit.sphere.center_mm - centre).norm(), 8.0);
}

// The lab keeps working: the paper's sphere before a wall is one hedge in garden mode too.
// garden_refine_max_radius reaches the hedges the garden segmentation found by depth, and only
// them: on a leafy ball the 9 x 9 retry (4) settles pixels the 5 x 5 window leaves (so the two
// settings give clouds of different sizes), while the lab sphere, found by colour, is matched
// with refine_max_radius whatever garden_refine_max_radius says (the same number of points, and
// a different one when refine_max_radius itself changes).
TEST(GardenCapture, TheGardenRetryWindowAppliesToHedgesFoundByDepthOnly) {
  const Rendered r = Render("single", 0.5);
  const StereoRig rig = RigFromSimulation(r.sim);
  auto points = [&](const cv::Mat& left, const cv::Mat& right, SegmentMode mode, int garden_retry, int retry = 4) {
    ConvertOptions o;
    o.mode = mode;
    o.match.garden_refine_max_radius = garden_retry;
    o.match.sgbm.refine_max_radius = retry;
    return FinitePoints(ConvertCapture(left, right, rig, o).cloud);
  };
  const std::size_t leafy_small = points(r.left, r.right, SegmentMode::kGarden, 2),
                    leafy_retry = points(r.left, r.right, SegmentMode::kGarden, 4);
  EXPECT_GT(leafy_small, 1000u);
  EXPECT_GT(leafy_retry, leafy_small);  // the retry settles some pixels the small window drops
  const auto [l, rt] = RenderLabSphere(r.sim);
  const std::size_t lab = points(l, rt, SegmentMode::kColour, 2);
  EXPECT_EQ(lab, points(l, rt, SegmentMode::kColour, 4));
  EXPECT_NE(lab, points(l, rt, SegmentMode::kColour, 2, 2));  // its own retry does change it
}

// The cut keeps the better-pinned half of each tile: the median is the tile's own (a tile of ten
// times the noise keeps its half too), only measured pixels of the mask count and are cut (filled,
// unmasked and unrefined ones are left as they are), and a tile with too few pixels is left alone.
TEST(GardenCapture, DropLessCertainCutsEachTileAboveItsOwnMedian) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat mask = cv::Mat::zeros(64, 96, CV_8U), filled = cv::Mat::zeros(64, 96, CV_8U);
  cv::Mat sigma(64, 96, CV_32F, cv::Scalar(nan)), disparity(64, 96, CV_32F, cv::Scalar(40.0f));
  // Tile (0, 0): sigma 1..256 px/1000 in a shuffled order; tile (32, 0): ten times that.
  for (int k = 0; k < 256; ++k) {
    const int x = (k * 37) % 16, y = ((k * 37) / 16) % 16;  // a permutation of the 16 x 16 block
    mask.at<std::uint8_t>(y, x) = mask.at<std::uint8_t>(y, x + 32) = 255;
    sigma.at<float>(y, x) = 0.001f * float(k + 1);
    sigma.at<float>(y, x + 32) = 0.01f * float(k + 1);
  }
  // Tile (64, 0): 5 pixels, too few for a median.
  for (int k = 0; k < 5; ++k) mask.at<std::uint8_t>(40, 64 + k) = 255, sigma.at<float>(40, 64 + k) = 1.0f + float(k);
  // In tile (0, 0): a filled pixel with a large sigma (not measured: not counted, not cut), an
  // unrefined one (sigma NaN) and an unmasked one with a large sigma.
  mask.at<std::uint8_t>(20, 3) = 255, filled.at<std::uint8_t>(20, 3) = 255, sigma.at<float>(20, 3) = 9.0f;
  mask.at<std::uint8_t>(21, 3) = 255;
  sigma.at<float>(22, 3) = 9.0f;
  const int dropped = DropLessCertain(mask, sigma, filled, 1.0, 32, &disparity);
  // 256 values: the median is the 129th (index 128), so the 127 above it go in each tile.
  EXPECT_EQ(dropped, 2 * 127);
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (const int tx : {0, 32}) {
        const float s = sigma.at<float>(y, x + tx), limit = (tx == 0 ? 0.001f : 0.01f) * 129;
        EXPECT_EQ(std::isnan(disparity.at<float>(y, x + tx)), s > limit * 1.0001f) << x + tx << ", " << y;
      }
    }
  }
  for (int k = 0; k < 5; ++k) EXPECT_FALSE(std::isnan(disparity.at<float>(40, 64 + k)));
  for (const int y : {20, 21, 22}) EXPECT_FALSE(std::isnan(disparity.at<float>(y, 3))) << y;
  // Ratio 1.5 keeps every pixel up to 1.5 times the median: 0.194-0.256 in the first tile (ten
  // times that in the second) goes, 63 a tile; 0 keeps all.
  cv::Mat d2(64, 96, CV_32F, cv::Scalar(40.0f));
  EXPECT_EQ(DropLessCertain(mask, sigma, filled, 1.5, 32, &d2), 2 * 63);
  EXPECT_EQ(DropLessCertain(mask, sigma, filled, 0.0, 32, &d2), 0);
}

// garden_sigma_ratio reaches the hedges the garden segmentation found by depth, and only them:
// the leafy ball keeps about half its measured pixels (each tile's better-pinned half), the lab
// sphere, found by colour, all of them.
TEST(GardenCapture, TheLessCertainCutAppliesToHedgesFoundByDepthOnly) {
  const Rendered r = Render("single", 0.5);
  const StereoRig rig = RigFromSimulation(r.sim);
  auto points = [&](const cv::Mat& left, const cv::Mat& right, SegmentMode mode, double ratio) {
    ConvertOptions o;
    o.mode = mode;
    o.match.garden_sigma_ratio = ratio;
    return FinitePoints(ConvertCapture(left, right, rig, o).cloud);
  };
  const double all = double(points(r.left, r.right, SegmentMode::kGarden, 0)),
               cut = double(points(r.left, r.right, SegmentMode::kGarden, 1));
  EXPECT_GT(all, 2000);
  // Half of each tile's measured pixels, give or take the tiles too small to cut and ties.
  EXPECT_NEAR(cut / all, 0.5, 0.1);
  const auto [l, rt] = RenderLabSphere(r.sim);
  EXPECT_EQ(points(l, rt, SegmentMode::kColour, 0), points(l, rt, SegmentMode::kColour, 1));
}

// bench lab's and bench garden's interval table: a coordinate counts as inside when its error is
// at most 1.96 stated standard errors (points' and matching terms added in quadrature); fits
// that did not converge or state no error are left out.
TEST(BenchIntervals, CoverageCountsEachCoordinateAgainstItsStatedInterval) {
  const fitting::Sphere truth{Eigen::Vector3d(0, 0, 2000), 500};
  fitting::SphereFitResult f;
  f.converged = true;
  f.sphere = {Eigen::Vector3d(1.9, -2.1, 2000), 503};  // errors 1.9, -2.1, 0, +3 mm
  f.std_error_mm = Eigen::Vector4d(0.6, 0.6, 1, 1);
  f.matching_std_error_mm = Eigen::Vector4d(0.8, 0.8, 0, 1);  // totals 1, 1, 1, sqrt(2) mm
  bench::IntervalCoverage c;
  c.Add(f, truth);
  EXPECT_EQ(c.cases, 4);
  EXPECT_EQ(c.inside, 2);  // 1.9 <= 1.96 and 0 are inside; 2.1 > 1.96 and 3 > 2.77 are not
  EXPECT_NEAR(c.StatedRms(), std::sqrt((1 + 1 + 1 + 2) / 4.0), 1e-12);
  EXPECT_NEAR(c.ErrorRms(), std::sqrt((1.9 * 1.9 + 2.1 * 2.1 + 0 + 9) / 4.0), 1e-12);
  EXPECT_NEAR(c.MatchingPercent(), 100 * (0.64 + 0.64 + 0 + 1) / 5.0, 1e-9);
  fitting::SphereFitResult failed = f, unstated = f;
  failed.converged = false;
  unstated.std_error_mm.reset();
  unstated.matching_std_error_mm.reset();
  c.Add(failed, truth);
  c.Add(unstated, truth);
  EXPECT_EQ(c.cases, 4);
}

TEST(GardenSegment, LabSphereIsOneHedge) {
  const SimRig sim = PaperRig(0.5);
  SphereScene sc;
  sc.center = cv::Vec3d(70, 50, 2300);
  RenderOptions ro;
  ro.supersample = 2;
  const StereoRig rig = RigFromSimulation(sim);
  cv::Mat l, rt;
  RectifyPair(rig, RenderSphere(sim, false, sc, ro), RenderSphere(sim, true, sc, ro), &l, &rt);
  const GardenSegmentation g = FindHedges(rig, l, rt, GardenSegmentOptions{});
  ASSERT_EQ(g.hedges.size(), 1u);
  EXPECT_NEAR(g.hedges[0].approx_radius_mm, sc.radius, 0.25 * sc.radius);
}

// Other shrubs: leafy, green, no balls. A shrub against a ball leaves their outline no waist
// (its lobes fill it), but its front is a pit of its own in the depth: the ball must come out
// alone, with at most 2 % of its points more than 50 mm outside its envelope (the issue's target).
// The shrubs may be taken for hedges (they are green, round enough and stand on the lawn); they
// are not in the truth, and the ball's cloud must not hold them.
TEST(GardenSegment, AShrubAgainstABallIsCutFromIt) {
  const Rendered r = Render("shrubs", 0.5);
  const StereoRig rig = RigFromSimulation(r.sim);
  ConvertOptions o;
  o.mode = SegmentMode::kGarden;
  const ConvertResult res = ConvertCapture(r.left, r.right, rig, o);
  const cv::Vec3d t = GardenHedgeCenter(r.scene, 0);
  const Eigen::Vector3d centre(t[0], t[1], t[2]);
  const double radius = r.scene.hedges[0].radius_mm;
  std::size_t best_outside = 0, best_n = 0;
  double best_d = 1e18;
  for (const auto& g : cloud::HedgeGroups(res.cloud)) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    std::size_t outside = 0;
    for (std::size_t k : g.indices) {
      const Eigen::Vector3d p = res.cloud.points_mm[k].cast<double>();
      mean += p;
      if ((p - centre).norm() - radius > 50) ++outside;
    }
    mean /= double(std::max<std::size_t>(1, g.indices.size()));
    if ((mean - centre).norm() < best_d) best_d = (mean - centre).norm(), best_outside = outside, best_n = g.indices.size();
  }
  ASSERT_LT(best_d, radius) << "no hedge's points lie on the ball";
  ASSERT_GT(best_n, 1000u);
  EXPECT_LE(double(best_outside) / double(best_n), 0.02);
}

// A ball near either side of the image. SGBM cannot match the left view's first min + num
// disparities columns (their search would leave the right view), nor, through the left-right
// check, the columns whose match lies in the right view's last ones: the coarse match lost a
// tenth of the frame on each side (48 coarse columns), so a ball near the left edge lost its
// outer part, and one cut by the right edge came out "not round" and was not found. Both views
// are now padded. The box must reach the ball's true outline (its label, rectified), or on the
// left the first column the right camera sees, within the mask's erosion (9 px at half scale)
// and two coarse pixels; and a ball cut by the frame says so.
TEST(GardenSegment, BallsAtTheImageEdgesKeepTheirOutline) {
  const SimRig sim = PaperRig(0.5);
  const StereoRig rig = RigFromSimulation(sim);
  RenderOptions ro;
  ro.supersample = 2;
  ro.blur_sigma_px = 0.5;
  ro.noise_sigma = 1.0;
  RenderOptions lo;
  lo.labels = true;
  for (const double x : {-1800.0, 2250.0}) {
    GardenScene sc = GardenPreset("single");
    sc.hedges = {sc.hedges[0]};
    sc.hedges[0].x_mm = x, sc.hedges[0].radius_mm = 500;
    sc.pot_x_mm = 300;
    cv::Mat l, r;
    RectifyPair(rig, RenderGarden(sim, false, sc, ro), RenderGarden(sim, true, sc, ro), &l, &r);
    // The ball's true outline, rectified as the images are.
    const cv::Rect truth = cv::boundingRect(RectifyLeftMask(rig, RenderGarden(sim, false, sc, lo) == kLabelHedge));
    GardenSegmentation g;
    try {
      g = FindHedges(rig, l, r, GardenSegmentOptions{});
    } catch (const Error& e) {
      ADD_FAILURE() << "ball at x " << x << ": " << e.what();
      continue;
    }
    ASSERT_EQ(g.hedges.size(), 1u) << "ball at x " << x;
    const cv::Rect box = g.hedges[0].box;
    const bool cut = truth.x + truth.width >= l.cols - 1;
    ASSERT_EQ(cut, x > 0) << "the scene is not the case meant: label box " << truth;
    EXPECT_EQ(g.hedges[0].touches_border, cut) << "ball at x " << x;
    // On the left the right camera does not see the first d columns (d the disparity there): at
    // most that of the ball's nearest point.
    const cv::Vec3d c = GardenHedgeCenter(sc, 0);
    const double d_max = rig.P1.at<double>(0, 0) * rig.baseline_mm / (c[2] - sc.hedges[0].radius_mm);
    EXPECT_LE(box.x - std::max(double(truth.x), d_max), 13) << "ball at x " << x << ": box " << box << ", label " << truth;
    EXPECT_LE(truth.x + truth.width - (box.x + box.width), 13) << "ball at x " << x << ": box " << box << ", label " << truth;
  }
}

// A garden without a hedge: lawn, pot, hedge row and trees only. "No hedge", never a lawn.
TEST(GardenSegment, NoHedgeIsAnErrorNamingWhatWasRejected) {
  SimRig sim = PaperRig(0.5);
  GardenScene sc = GardenPreset("single");
  sc.hedges.clear();
  RenderOptions ro;
  ro.supersample = 1;
  const StereoRig rig = RigFromSimulation(sim);
  cv::Mat l, rt;
  RectifyPair(rig, RenderGarden(sim, false, sc, ro), RenderGarden(sim, true, sc, ro), &l, &rt);
  try {
    FindHedges(rig, l, rt, GardenSegmentOptions{});
    FAIL() << "expected no hedge";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no hedge found"), std::string::npos) << e.what();
  }
}

// The independent renderer's garden (POV-Ray, hedges of leaf discs, a real camera's noise and
// colour) at half the paper's resolution: its geometry must agree with its truth file (camera
// axes, crop, pitch, the level frame), and the garden path must find the hedge in it.
TEST(GardenPovray, SingleBallIsFoundWhereItsTruthSays) {
  if (!HavePovray()) GTEST_SKIP() << "povray is not installed (scripts/setup.sh installs it)";
  const auto dir = testing::ScratchDir();
  WritePovrayGarden(dir.string(), 0.5, CameraModel(), {"single"});
  const auto truths = eval::ReadSphereTruths((dir / "garden_single.truth.json").string());
  ASSERT_EQ(truths.size(), 1u);
  const GardenScene sc = GardenPreset("single");
  // The leaves' mean surface lies inside the envelope, by less than the shell's depth.
  ASSERT_TRUE(truths[0].surface_radius_mm.has_value());
  EXPECT_LT(*truths[0].surface_radius_mm, sc.hedges[0].radius_mm - 0.1 * sc.hedges[0].leaf_depth_mm);
  EXPECT_GT(*truths[0].surface_radius_mm, sc.hedges[0].radius_mm - sc.hedges[0].leaf_depth_mm);
  ConvertOptions o;
  o.mode = SegmentMode::kGarden;
  const ConvertResult res = ConvertCapture(cv::imread((dir / "garden_single_left.png").string()),
                                           cv::imread((dir / "garden_single_right.png").string()),
                                           ReadRig((dir / "rig.yaml").string()), o);
  ASSERT_EQ(res.hedges.size(), 1u);  // the pot is not a hedge, nor is the lawn or the hedge row
  std::vector<Eigen::Vector3d> pts;
  std::size_t outside = 0;
  for (const auto& p : res.cloud.points_mm) {
    if (!cloud::IsFinite(p)) continue;
    pts.push_back(p.cast<double>());
    if ((pts.back() - truths[0].center_mm).norm() - truths[0].radius_mm > 50) ++outside;
  }
  ASSERT_GT(pts.size(), 3000u);
  EXPECT_LE(double(outside) / double(pts.size()), 0.02);  // the issue's target
  const fitting::EnvelopeFit fit = fitting::FitEnvelope(pts);
  ASSERT_TRUE(fit.fit.converged) << fit.fit.message;
  // At half scale one pixel of disparity is ~90 mm of depth at 2.4 m, so a few hundredths of a
  // pixel of matching bias move the centre by a few mm; 15 mm allows that. A camera axis flipped,
  // a crop off by a pixel's worth of principal point or a wrong pitch moves it by tens to
  // hundreds of mm. The radius: the dark body inside the leaves is 38 mm inside the envelope.
  EXPECT_LT((fit.fit.sphere.center_mm - truths[0].center_mm).norm(), 15.0);
  EXPECT_NEAR(fit.fit.sphere.radius_mm, truths[0].radius_mm, 12.0);
}

// POV-Ray's per-pixel truth (RenderPovrayGardenSurface: a second render with every texture its
// distance from the camera): on the ball's pixels every first hit lies between the dark body
// (InnerRadius, 38 mm inside) and the envelope, to the depth's 0.12 mm grey level and the
// leaves' float rounding (R + 0.11 and R - 38.06 mm at most), and the exact hits' envelope fit
// reads the ball: on all 24,361 hits it comes within 0.72 mm of R and 1.47 mm of the centre (the
// shell model's own error on POV-Ray's disc leaves), on the 10,000 it keeps by default within
// 0.98 and 1.11 mm, on every 3rd hit 0.33-0.97 and 0.26-1.56 mm by where the count starts; 1.5 mm
// on R and 2 mm on the centre. A wrong range, a ray through the wrong pixel (a crop off by the
// principal point's offset) or a flipped axis puts hits mm to m off the ball.
TEST(GardenPovray, DepthRenderGivesEachPixelsTrueLeaf) {
  if (!HavePovray()) GTEST_SKIP() << "povray is not installed (scripts/setup.sh installs it)";
  const auto dir = testing::ScratchDir();
  const SimRig rig = PovrayRig(0.5);
  const GardenScene sc = GardenPreset("single");
  const cv::Mat surface = RenderPovrayGardenSurface(rig, sc, dir.string());
  ASSERT_EQ(surface.type(), CV_32FC3);
  ASSERT_EQ(surface.size(), rig.left.size);
  const cv::Vec3d cv_c = GardenHedgeCenter(sc, 0);
  const Eigen::Vector3d c(cv_c[0], cv_c[1], cv_c[2]);
  const double R = sc.hedges[0].radius_mm;
  // The ball's pixels: those whose ray passes within 0.9 R of its centre.
  std::vector<cv::Point2d> px;
  cv::projectPoints(std::vector<cv::Point3d>{cv::Point3d(c.x(), c.y(), c.z())}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                    cv::Mat(rig.left.K), cv::Mat(rig.left.dist), px);
  const double r_px = 0.9 * R / c.norm() * rig.left.K(0, 0);
  std::vector<Eigen::Vector3d> pts;
  double nearest = 1e9, farthest = 0;
  for (int v = 0; v < surface.rows; ++v) {
    for (int u = 0; u < surface.cols; ++u) {
      if (std::hypot(u - px[0].x, v - px[0].y) > r_px) continue;
      const cv::Vec3f p = surface.at<cv::Vec3f>(v, u);
      ASSERT_TRUE(std::isfinite(p[2])) << "pixel (" << u << ", " << v << ") of the ball has no hit";
      pts.emplace_back(p[0], p[1], p[2]);
      const double s = (pts.back() - c).norm();
      nearest = std::min(nearest, s), farthest = std::max(farthest, s);
    }
  }
  ASSERT_GT(pts.size(), 5000u);
  EXPECT_LE(farthest, R + 0.3);
  EXPECT_GE(nearest, R - sc.hedges[0].leaf_depth_mm - 8 - 0.3);
  const fitting::EnvelopeFit e = fitting::FitEnvelope(pts);
  ASSERT_TRUE(e.fit.converged) << e.fit.message;
  EXPECT_NEAR(e.fit.sphere.radius_mm, R, 1.5);
  EXPECT_LT((e.fit.sphere.center_mm - c).norm(), 2.0);
}

// The watershed's order (highest first, equal values in pixel order) from the radix sort is the
// one a comparison sort of (value, pixel) pairs gives: on values with many ties, both zeros,
// negatives, NaN and -inf (never in the order) and pixels outside the region.
TEST(GardenSegment, TheWatershedsOrderIsTheComparisonSortsOrder) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> level(-40, 40), kind(0, 19);
  for (int trial = 0; trial < 20; ++trial) {
    const std::size_t n = 500 + 300 * std::size_t(trial);
    std::vector<double> values(n);
    std::vector<std::uint8_t> inside(n);
    for (std::size_t i = 0; i < n; ++i) {
      const int k = kind(rng);
      values[i] = k == 0   ? std::numeric_limits<double>::quiet_NaN()
                  : k == 1 ? -std::numeric_limits<double>::infinity()
                  : k == 2 ? -0.0
                  : k == 3 ? 0.0
                           : double(float(level(rng) * 0.37f));  // floats' values, many equal
      inside[i] = kind(rng) < 17;
    }
    std::vector<std::pair<double, int>> keyed;
    for (std::size_t i = 0; i < n; ++i) {
      if (inside[i] && std::isfinite(values[i])) keyed.emplace_back(values[i], int(i));
    }
    std::sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) {
      return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    const std::vector<int> order = stereo::detail::HighestFirst(values, inside);
    ASSERT_EQ(order.size(), keyed.size());
    for (std::size_t k = 0; k < order.size(); ++k) ASSERT_EQ(order[k], keyed[k].second) << "trial " << trial << ", place " << k;
  }
}

TEST(GardenSegment, BadOptionsAreNamed) {
  GardenSegmentOptions o;
  o.min_radius_mm = 900;
  o.max_radius_mm = 800;
  try {
    o.Check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("min_radius"), std::string::npos);
  }
  o = {};
  o.block_size = 4;
  EXPECT_THROW(o.Check(), Error);
}

}  // namespace
}  // namespace hedgefit::stereo

namespace hedgefit::stereo {
namespace {

// bench garden --random draws gardens from seeds: the same seed the same garden, every ball of
// the issue's range (r 420-600 mm, centre 2.0-2.7 m away) standing apart from the next, and a
// name that is not "random" and digits is refused.
TEST(GardenPresets, RandomGardensComeFromTheirSeedWithinTheIssuesRange) {
  std::size_t balls = 0, shrubs = 0;
  for (int seed = 1; seed <= 40; ++seed) {
    const std::string name = "random" + std::to_string(seed);
    const GardenScene a = GardenPreset(name), b = GardenPreset(name);
    ASSERT_EQ(a.hedges.size(), b.hedges.size()) << name;
    ASSERT_GE(a.hedges.size(), 1u) << name;
    ASSERT_LE(a.hedges.size(), 3u) << name;
    EXPECT_EQ(a.texture_seed, b.texture_seed) << name;
    for (std::size_t i = 0; i < a.hedges.size(); ++i) {
      EXPECT_EQ(a.hedges[i].x_mm, b.hedges[i].x_mm) << name;
      EXPECT_EQ(a.hedges[i].radius_mm, b.hedges[i].radius_mm) << name;
      EXPECT_GE(a.hedges[i].radius_mm, 420) << name;
      EXPECT_LE(a.hedges[i].radius_mm, 600) << name;
      EXPECT_GE(a.hedges[i].z_mm, 2000) << name;
      EXPECT_LE(a.hedges[i].z_mm, 2700) << name;
      if (i > 0) {  // apart: a gap of at least 150 mm across the view
        EXPECT_GE(a.hedges[i].x_mm - a.hedges[i - 1].x_mm, a.hedges[i].radius_mm + a.hedges[i - 1].radius_mm + 150)
            << name;
      }
    }
    balls += a.hedges.size();
    shrubs += a.shrub_lobes.empty() ? 0 : 1;
  }
  EXPECT_GT(balls, 60u);  // one to three each: rows are common
  EXPECT_GT(shrubs, 5u);  // and so are shrubs (two in five, about 16 of 40)
  EXPECT_NE(GardenPreset("random1").hedges.front().x_mm, GardenPreset("random2").hedges.front().x_mm);
  for (const char* bad : {"random", "random-1", "random7x", "randomness", "random99999999999999999"}) {
    EXPECT_THROW(GardenPreset(bad), Error) << bad;
  }
}

}  // namespace
}  // namespace hedgefit::stereo
