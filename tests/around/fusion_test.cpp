// Several captures around a hedge, fused: the manifest and TUM readers, and the fusion itself on
// synthetic leafy balls whose truth is known (each capture sees the cap facing it, leaves at an
// exponential depth below the envelope plus noise along the view ray, as the envelope model has it),
// with exact poses and with odometry-like errors.

#include "around/fusion.hpp"
#include "around/poses.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "fitting/methods.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::around {
namespace {

namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("hedgefit_around_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d.string();
}

void Touch(const std::string& path) { std::ofstream(path) << "x"; }

Eigen::Isometry3d Pose(double heading_deg, const Eigen::Vector3d& centre, double distance) {
  // A camera `distance` from `centre` (level), looking at it; y down, as OpenCV's.
  const double h = heading_deg * M_PI / 180;
  const Eigen::Vector3d forward(std::sin(h), 0, std::cos(h));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(2) = forward;
  T.linear().col(1) = Eigen::Vector3d::UnitY();
  T.linear().col(0) = Eigen::Vector3d::UnitY().cross(forward);
  T.translation() = centre - distance * forward;
  return T;
}

TEST(Poses, AManifestReadsBackAsWritten) {
  const std::string dir = TempDir("manifest");
  std::vector<PosedCapture> caps(2);
  for (int k = 0; k < 2; ++k) {
    caps[std::size_t(k)].name = "c" + std::to_string(k);
    caps[std::size_t(k)].left = "c" + std::to_string(k) + "_left.png";
    caps[std::size_t(k)].right = "c" + std::to_string(k) + "_right.png";
    caps[std::size_t(k)].time_s = k * 0.5;
    caps[std::size_t(k)].world_from_camera = Pose(40.0 * k, Eigen::Vector3d(100, 600, 2000), 2300);
  }
  WriteManifest(dir + "/m.json", caps, "rig.yaml");
  const std::vector<PosedCapture> back = ReadManifest(dir + "/m.json");
  ASSERT_EQ(back.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(back[std::size_t(k)].left, (fs::path(dir) / caps[std::size_t(k)].left).string());
    EXPECT_EQ(back[std::size_t(k)].rig, (fs::path(dir) / "rig.yaml").string());  // relative to the manifest
    // Written to 1e-9: the poses agree to far below a micrometre and a microdegree.
    EXPECT_LT((back[std::size_t(k)].world_from_camera.matrix() - caps[std::size_t(k)].world_from_camera.matrix()).norm(), 1e-6);
  }
}

TEST(Poses, ATumTrajectoryFindsItsCapturesByTime) {
  const std::string dir = TempDir("tum");
  std::vector<PosedCapture> caps(3);
  for (int k = 0; k < 3; ++k) {
    caps[std::size_t(k)].time_s = 1700000000.25 + k;
    caps[std::size_t(k)].world_from_camera = Pose(30.0 * k, Eigen::Vector3d(0, 500, 0), 2000);
    char stem[64];
    std::snprintf(stem, sizeof(stem), "%.6f", *caps[std::size_t(k)].time_s);
    Touch(dir + "/" + stem + "_left.png");
    Touch(dir + "/" + stem + "_right.png");
  }
  WriteTum(dir + "/t.tum", caps);
  const std::vector<PosedCapture> back = ReadTumCaptures(dir + "/t.tum", dir);
  ASSERT_EQ(back.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(*back[std::size_t(k)].time_s, *caps[std::size_t(k)].time_s, 1e-6);
    EXPECT_NE(back[std::size_t(k)].left.find("_left.png"), std::string::npos);
    EXPECT_NE(back[std::size_t(k)].right.find("_right.png"), std::string::npos);
    // Metres with 9 decimals: within a micrometre; the quaternion to 1e-9.
    EXPECT_LT((back[std::size_t(k)].world_from_camera.translation() - caps[std::size_t(k)].world_from_camera.translation()).norm(), 1e-3);
    EXPECT_LT(RotationDeg(back[std::size_t(k)].world_from_camera * caps[std::size_t(k)].world_from_camera.inverse()), 1e-6);
  }
}

TEST(Poses, BadManifestsAndTrajectoriesSayWhatIsWrong) {
  const std::string dir = TempDir("bad");
  auto expect_error = [](const std::function<void()>& f, const std::string& part) {
    try {
      f();
      ADD_FAILURE() << "no error; expected one naming '" << part << "'";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  std::ofstream(dir + "/a.json") << R"({"captures": [{"left": "l.png", "right": "r.png", "world_from_camera": [1, 0, 0]}]})";
  expect_error([&] { ReadManifest(dir + "/a.json"); }, "16 numbers");
  std::ofstream(dir + "/b.json") << R"({"captures": [{"left": "l.png", "right": "r.png",
      "world_from_camera": [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}]})";
  expect_error([&] { ReadManifest(dir + "/b.json"); }, "not a rigid motion");
  std::ofstream(dir + "/c.json") << R"({"captures": [{"left": "l.png"}]})";
  expect_error([&] { ReadManifest(dir + "/c.json"); }, "capture 1");
  std::ofstream(dir + "/t.tum") << "1.0 0 0 0 0 0 0 2\n";
  expect_error([&] { ReadTumCaptures(dir + "/t.tum", dir); }, "unit length");
  std::ofstream(dir + "/u.tum") << "# a comment\n5.0 0 0 0 0 0 0 1\n";
  expect_error([&] { ReadTumCaptures(dir + "/u.tum", dir); }, "no capture");
  expect_error([&] { ReadManifest(dir + "/missing.json"); }, "cannot read");
}

// A leafy ball as one camera sees it: the cap facing it, each point a ray's first leaf: the
// envelope less an exponential depth (mean kLeafMm) for the two thirds not clipped, plus noise.
constexpr double kRadius = 500, kLeafMm = 12, kNoiseMm = 1.5;

ViewHedge SeeBall(const Eigen::Vector3d& centre_world, const Eigen::Isometry3d& world_from_camera, std::mt19937* rng) {
  ViewHedge h;
  h.id = 1;
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  const Eigen::Vector3d c = camera_from_world * centre_world;
  std::normal_distribution<double> g(0, 1);
  std::exponential_distribution<double> leaf(1 / kLeafMm);
  std::uniform_real_distribution<double> u(0, 1);
  while (h.points_mm.size() < 6000) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(*rng), g(*rng), g(*rng)).normalized();
    const Eigen::Vector3d on = c + kRadius * d;
    const Eigen::Vector3d ray = on.normalized();
    const double facing = -ray.dot(d);
    if (facing < 0.25) continue;  // grazing: stereo loses it
    const double depth = (u(*rng) < 1.0 / 3 ? 0.0 : leaf(*rng)) / facing + kNoiseMm * g(*rng);
    h.points_mm.push_back(on + depth * ray);
  }
  h.fit = fitting::RunFitMethod("envelope", h.points_mm, {}, 42, true);
  return h;
}

std::vector<View> Ring(int n, const Eigen::Vector3d& centre, double distance, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<View> views;
  for (int k = 0; k < n; ++k) {
    View v;
    v.name = std::to_string(k + 1);
    v.world_from_camera = Pose(360.0 * k / n, centre, distance);
    v.hedges.push_back(SeeBall(centre, v.world_from_camera, &rng));
    views.push_back(v);
  }
  return views;
}

TEST(Fuse, ARingWithExactPosesGivesTheWholeBall) {
  const Eigen::Vector3d centre(200, 600, 3000);
  const std::vector<View> views = Ring(6, centre, 2300, 5);
  FuseOptions o;
  o.registration = "none";
  const FuseResult r = Fuse(views, o);
  ASSERT_EQ(r.hedges.size(), 1u);
  const FusedHedge& h = r.hedges[0];
  // 36000 points, noise 1.5 mm and 12 mm leaves: the fit settles to a few tenths of a millimetre;
  // 1 mm is the issue's target, 2 mm for the centre.
  EXPECT_NEAR(h.fit.fit.sphere.radius_mm, kRadius, 1.0);
  EXPECT_LT((h.fit.fit.sphere.center_mm - centre).norm(), 2.0);
  // The stated errors hold the truth (95 %, with the 1.5 factor a handful of runs allows).
  for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(h.fit.fit.sphere.center_mm[k] - centre[k]), 1.5 * 1.96 * h.std_error_mm[k]);
  // Caps facing six cameras round the level: everything but the top and bottom. A cap with
  // cos(angle to the camera) > 0.25 from 2.3 m covers about a third of the sphere each.
  EXPECT_GT(h.coverage, 0.70);
  for (double c : h.view_coverage) EXPECT_LT(c, 0.45);
  EXPECT_EQ(h.views.size(), 6u);
  EXPECT_EQ(r.cloud.size(), 36000u);
  EXPECT_EQ(r.cloud.fields.at("capture").size(), r.cloud.size());
  // The world's vertical from the cameras' -y.
  EXPECT_LT((r.up + Eigen::Vector3d::UnitY()).norm(), 1e-9);
}

TEST(Fuse, OdometryErrorsAreCorrectedAndAFarPoseIsLeftOut) {
  const Eigen::Vector3d centre(0, 600, 0);
  std::vector<View> views = Ring(5, centre, 2300, 9);
  std::vector<Eigen::Isometry3d> truth;
  for (const View& v : views) truth.push_back(v.world_from_camera);
  // Odometry: the first capture exact, the others off by 40-90 mm and 1-2 degrees of heading.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (std::size_t k = 1; k < views.size(); ++k) {
    const Eigen::Vector3d dt(u(rng), 0.1 * u(rng), u(rng));
    views[k].world_from_camera.translation() += (40 + 10 * double(k)) * dt.normalized();
    views[k].world_from_camera.linear() =
        Eigen::AngleAxisd((1 + 0.25 * double(k)) * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() *
        views[k].world_from_camera.linear();
  }
  // ... and a sixth capture whose pose puts its ball 2 m away: another place, not this hedge.
  View far = Ring(1, centre, 2300, 11)[0];
  far.name = "far";
  far.world_from_camera.translation() += Eigen::Vector3d(2000, 0, 0);
  views.push_back(far);
  const FuseResult r = Fuse(views, FuseOptions());
  ASSERT_EQ(r.poses.size(), 6u);
  EXPECT_FALSE(r.poses[5].used);
  EXPECT_NE(r.poses[5].left_out.find("within"), std::string::npos) << r.poses[5].left_out;
  ASSERT_FALSE(r.warnings.empty());
  ASSERT_EQ(r.hedges.size(), 1u);
  const FusedHedge& h = r.hedges[0];
  EXPECT_EQ(h.views.size(), 5u);
  // The ball is where the first capture (exact) puts it, to that capture's own centre with the
  // fused radius: 6000 points with 1.5 mm of noise pin it to a few tenths of a millimetre.
  EXPECT_NEAR(h.fit.fit.sphere.radius_mm, kRadius, 1.0);
  EXPECT_LT((h.fit.fit.sphere.center_mm - centre).norm(), 1.0);
  for (std::size_t k = 0; k < 5; ++k) {
    ASSERT_TRUE(r.poses[k].used) << r.poses[k].left_out;
    // One ball pins each capture's position relative to it, not its turn about it (3 of 6):
    // what the hedge needs, so its centre seen through each refined pose is the fused one (the
    // captures' centres agree to their own few tenths of a millimetre; 40-110 mm before).
    const Eigen::Vector3d seen = r.poses[k].refined * views[k].hedges[0].fit.sphere.center_mm;
    EXPECT_LT((seen - h.fit.fit.sphere.center_mm).norm(), 2.0) << k;
    if (k > 0) {
      EXPECT_EQ(r.poses[k].determined_dof, 3) << k;
    }
  }
}

// Exact poses, fused with the prior they deserve (0.5 mm, 0.05 degrees: a motion-capture
// system's), stay where they are: each capture's own centre is a few tenths of a millimetre off
// (its leaves, its noise), which its stated error holds, and the first capture is the frame. A
// correction is the move from the given pose; 0.1 mm and 0.005 degrees are a fifth and a tenth of
// the prior (they move 0.013 mm and 0.0024 degrees at most here). (Solved with every
// capture free and the whole moved back onto the first, the others took the first one's own
// correction: on an arc the far captures moved by its turn times their distance from it.)
TEST(Fuse, ExactPosesStayWhereTheyAre) {
  const Eigen::Vector3d centre(0, 600, 0);
  std::mt19937 rng(23);
  std::vector<View> views;
  for (int k = 0; k < 6; ++k) {
    View v;
    v.name = std::to_string(k + 1);
    v.world_from_camera = Pose(-75 + 30.0 * k, centre, 2300);
    v.hedges.push_back(SeeBall(centre, v.world_from_camera, &rng));
    views.push_back(v);
  }
  FuseOptions o;
  o.prior_translation_mm = 0.5;
  o.prior_rotation_deg = 0.05;
  const FuseResult r = Fuse(views, o);
  ASSERT_EQ(r.hedges.size(), 1u);
  for (const PoseResult& p : r.poses) {
    ASSERT_TRUE(p.used) << p.left_out;
    EXPECT_LT(p.correction_mm, 0.1) << p.name;
    EXPECT_LT(p.correction_deg, 0.005) << p.name;
  }
  EXPECT_LT((r.hedges[0].fit.fit.sphere.center_mm - centre).norm(), 1.0);
}

TEST(Fuse, CoverageOfAHemisphereIsHalf) {
  std::vector<Eigen::Vector3d> pts;
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0, 1);
  while (pts.size() < 200000) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    if (d.z() > 0) pts.push_back(500 * d);
  }
  // Cells straddling the rim hold points on one side: up to a ring's worth (1/18) more than half.
  const double c = CoveredShare(pts, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY(), 10, 3);
  EXPECT_GE(c, 0.5);
  EXPECT_LE(c, 0.5 + 1.0 / 18 + 0.01);
}

// Four captures on an arc 2.6 m from the middle of a row of two balls, 40 degrees apart: the
// first sees B only, the others B and A.
std::vector<View> RowOfTwo(const Eigen::Vector3d& a, const Eigen::Vector3d& b, unsigned seed) {
  const Eigen::Vector3d mid = (a + b) / 2;
  std::mt19937 rng(seed);
  std::vector<View> views;
  for (int k = 0; k < 4; ++k) {
    View v;
    v.name = std::to_string(k + 1);
    v.world_from_camera = Pose(-60 + 40.0 * k, mid, 2600);
    v.hedges.push_back(SeeBall(b, v.world_from_camera, &rng));
    if (k > 0) {
      v.hedges.push_back(SeeBall(a, v.world_from_camera, &rng));
      v.hedges.back().id = 2;
    }
    views.push_back(v);
  }
  return views;
}

// A row of two balls seen across an arc, the first capture (exact, the frame) seeing only the
// near one (B) and the other three both, with odometry whose heading drifts 1.5-2.5 degrees. The
// centres pin each capture's pose relative to the pair, but nothing in the data pins the pair's
// turn about B: only the given poses (their prior, 3 degrees by default, and their steps) do, so
// the far ball (A, 1.4 m from B) lands a few centimetres off along that turn. Its interval says so
// (the registration's share); its fit's own interval, a few millimetres, would not hold it.
TEST(Fuse, WhatOnlyThePriorPinsIsInTheInterval) {
  const Eigen::Vector3d a(-700, 600, 0), b(700, 600, 0);
  std::vector<View> views = RowOfTwo(a, b, 21);
  for (std::size_t k = 1; k < views.size(); ++k) {
    views[k].world_from_camera.linear() =
        Eigen::AngleAxisd((1 + 0.5 * double(k)) * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() *
        views[k].world_from_camera.linear();
  }
  const FuseResult r = Fuse(views, FuseOptions());
  ASSERT_EQ(r.hedges.size(), 2u);
  for (const FusedHedge& h : r.hedges) {
    const bool far = h.views.size() == 3u;
    const Eigen::Vector3d truth = far ? a : b;
    const Eigen::Vector3d err = h.fit.fit.sphere.center_mm - truth;
    if (!far) {
      // B is where the exact first capture puts it, to its own few tenths of a millimetre.
      EXPECT_LT(err.norm(), 1.5);
      continue;
    }
    // A: turned about B by part of the drift (1.5-2.5 degrees over 1.4 m is 37-61 mm; the prior
    // shares it between the given poses and the centres).
    EXPECT_GT(err.norm(), 10) << "the test's drift should leave A off";
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(std::abs(err[k]), 1.96 * h.std_error_mm[k]) << k << ": " << err.transpose();
    }
    // Without the registration's share: the fit's own and the captures' disagreement.
    const double own = std::max(std::isfinite(h.likelihood_se_mm.z()) ? h.likelihood_se_mm.z() : 0.0,
                                std::isfinite(h.jackknife_se_mm.z()) ? h.jackknife_se_mm.z() : 0.0);
    EXPECT_GT(own, 0);
    EXPECT_GT(std::abs(err.z()), 1.96 * own) << "the fit's own interval already held it";
    EXPECT_GT(h.registration_se_mm.z(), 10);
  }
}

// An odometry's error accumulates: each step's heading is 0.5 degrees off, so the captures'
// headings are 0.5, 1 and 1.5 degrees off by the last, and their positions follow the turned
// steps. The first capture sees only B; the others B and A, 1.4 m apart (RowOfTwo).
std::vector<View> DriftingArc(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  std::vector<View> views = RowOfTwo(a, b, 29);
  std::vector<Eigen::Isometry3d> truth;
  for (const View& v : views) truth.push_back(v.world_from_camera);
  for (std::size_t k = 1; k < views.size(); ++k) {
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.5 * double(k) * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    const Eigen::Vector3d step = truth[k].translation() - truth[k - 1].translation();
    views[k].world_from_camera.translation() = views[k - 1].world_from_camera.translation() + turn * step;
    views[k].world_from_camera.linear() = turn * truth[k].linear();
  }
  return views;
}

// The fused far ball's error from `a`, and its standard errors.
Eigen::Vector3d FarError(const std::vector<View>& views, const Eigen::Vector3d& a, const FuseOptions& o, Eigen::Vector3d* se) {
  const FuseResult r = Fuse(views, o);
  EXPECT_EQ(r.hedges.size(), 2u);
  for (const FusedHedge& h : r.hedges) {
    if (h.views.size() != 3u) continue;
    *se = h.std_error_mm.head<3>();
    return h.fit.fit.sphere.center_mm - a;
  }
  ADD_FAILURE() << "A not fused";
  return Eigen::Vector3d::Constant(1e9);
}

// The hedges pin the captures relative to the pair but not the pair's turn about B, which only
// the given poses hold. Each given pose alone is off by up to 1.5 degrees (A 37 mm round); the
// step from the first to the second by 0.5 (12 mm), and the steps say so: A is fused nearer, and
// still inside its interval.
TEST(Fuse, TheStepsBetweenCapturesPinWhatTheHedgesLeaveFree) {
  const Eigen::Vector3d a(-700, 600, 0), b(700, 600, 0);
  const std::vector<View> views = DriftingArc(a, b);
  FuseOptions without;
  without.step_rotation_deg = 0;
  Eigen::Vector3d se_without, se;
  const Eigen::Vector3d err_without = FarError(views, a, without, &se_without), err = FarError(views, a, FuseOptions(), &se);
  // Without the steps the absolute priors share the turn: about a degree, 20-30 mm at A.
  EXPECT_GT(err_without.norm(), 15) << err_without.transpose();
  // With them the first step (0.5 degrees off, 1 sigma of 1) weighs three times each given
  // pose's prior (3 degrees): the turn is read about 0.6 degrees off, 15 mm, against about 0.9
  // without. A fifth less at the least.
  EXPECT_LT(err.norm(), 0.8 * err_without.norm()) << err.transpose() << " against " << err_without.transpose();
  for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(err[k]), 1.96 * se[k]) << k << ": " << err.transpose();
}

// A manifest need not list its captures in the order they were taken. With a time each, the steps
// follow the path the odometry went, and the result is the one of the captures listed in order;
// without, the steps link the captures as listed (the first to the last, then back), which reads
// the turn from a step 1.5 degrees off rather than 0.5, and A lands elsewhere.
TEST(Fuse, TheStepsFollowTheCapturesTimes) {
  const Eigen::Vector3d a(-700, 600, 0), b(700, 600, 0);
  const std::vector<View> in_order = DriftingArc(a, b);
  std::vector<View> listed;
  for (int k : {0, 3, 1, 2}) listed.push_back(in_order[std::size_t(k)]);
  Eigen::Vector3d se;
  const Eigen::Vector3d err = FarError(in_order, a, FuseOptions(), &se);
  const Eigen::Vector3d untimed = FarError(listed, a, FuseOptions(), &se);
  // The listed order's first step is off by three times the path's first: the turn is read
  // about twice as far round at A (30 against 15 mm); half of that, 7 mm, at the least.
  EXPECT_GT((untimed - err).norm(), 7) << untimed.transpose() << " against " << err.transpose();
  for (std::size_t k = 0; k < listed.size(); ++k) listed[k].time_s = 100.0 + std::stod(listed[k].name);
  const Eigen::Vector3d timed = FarError(listed, a, FuseOptions(), &se);
  // The same solve up to the order of its sums.
  EXPECT_LT((timed - err).norm(), 1e-3) << timed.transpose() << " against " << err.transpose();
}

}  // namespace
}  // namespace hedgefit::around

namespace hedgefit::around {
namespace {

// Something one capture took for a hedge and no other saw (a shrub beside the ball, the lawn) is
// fused as a hedge of its own, but reported unconfirmed with its reason, never as a plain hedge;
// the ball every capture saw stays confirmed. A radius past the limits is unconfirmed too.
TEST(Fuse, AHedgeOneCaptureSawIsUnconfirmed) {
  const Eigen::Vector3d centre(0, 600, 0);
  std::vector<View> views = Ring(4, centre, 2300, 13);
  std::mt19937 rng(17);
  const Eigen::Vector3d beside = views[0].world_from_camera * Eigen::Vector3d(1500, 0, 2600);
  ViewHedge phantom = SeeBall(beside, views[0].world_from_camera, &rng);
  phantom.id = 2;
  views[0].hedges.push_back(phantom);
  FuseOptions o;
  o.registration = "none";
  const FuseResult r = Fuse(views, o);
  ASSERT_EQ(r.hedges.size(), 2u);
  int confirmed = 0;
  for (const FusedHedge& h : r.hedges) {
    if (h.unconfirmed.empty()) {
      ++confirmed;
      EXPECT_LT((h.fit.fit.sphere.center_mm - centre).norm(), 5.0);
      EXPECT_EQ(h.views.size(), 4u);
    } else {
      EXPECT_EQ(h.views.size(), 1u);
      EXPECT_NE(h.unconfirmed.find("seen by 1 of the 4 captures"), std::string::npos) << h.unconfirmed;
    }
  }
  EXPECT_EQ(confirmed, 1);
  EXPECT_TRUE(std::any_of(r.warnings.begin(), r.warnings.end(),
                          [](const std::string& w) { return w.find("unconfirmed") != std::string::npos; }));
  // The limits: the ball itself, past confirm_max_radius.
  o.confirm_max_radius_mm = kRadius - 50;
  const FuseResult small = Fuse(views, o);
  for (const FusedHedge& h : small.hedges) {
    EXPECT_FALSE(h.unconfirmed.empty());
    if (h.views.size() == 4u) {
      EXPECT_NE(h.unconfirmed.find("radius"), std::string::npos) << h.unconfirmed;
    }
  }
}

}  // namespace
}  // namespace hedgefit::around
