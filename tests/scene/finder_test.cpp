// The hedge finder against scenes with known answers: the ground model on a synthetic lawn,
// simulated garden scans (sim/scan.hpp) from a spinning LiDAR and a photogrammetry-like model,
// the real Velodyne scans of a calibration sphere with default settings, and PCL's test clouds,
// in which there is no ball.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <sstream>
#include <fstream>
#include <random>

#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"
#include "fitting/methods.hpp"
#include "fitting/uncertainty.hpp"
#include "pipeline/print.hpp"
#include "scene/find_report.hpp"
#include "scene/finder.hpp"
#include "scene/ground.hpp"
#include "scene/scene_stages.hpp"
#include "pipeline/pipeline.hpp"
#include "sim/scan.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::scene {
namespace {

// A sloped, bumpy lawn sampled every 50 mm with 5 mm noise, and a 1 m ball standing on it that
// hides the lawn under it.
TEST(Ground, FollowsASlopedBumpyLawnAndFillsUnderABall) {
  sim::ScanGround lawn;
  lawn.slope_x = 0.05, lawn.slope_y = -0.03, lawn.bump_mm = 50, lawn.wavelength_mm = 5000;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 5);
  const Eigen::Vector3d ball(5000, 5000, lawn.Height(5000, 5000) + 1000);
  std::vector<Eigen::Vector3f> pts;
  for (double x = 0; x < 10000; x += 50) {
    for (double y = 0; y < 10000; y += 50) {
      if (std::hypot(x - ball.x(), y - ball.y()) < 1000) {
        // The ball's upper half where the lawn is hidden.
        const double h = std::sqrt(1000.0 * 1000 - (x - ball.x()) * (x - ball.x()) - (y - ball.y()) * (y - ball.y()));
        pts.emplace_back(float(x), float(y), float(ball.z() + h));
      } else {
        pts.emplace_back(float(x), float(y), float(lawn.Height(x, y) + noise(rng)));
      }
    }
  }
  std::vector<std::uint8_t> is_ground;
  const GroundModel g = FitGround(pts, {}, &is_ground);
  ASSERT_FALSE(g.empty());
  // The lawn's noise is 5 mm; its bumps (50 mm over 5 m) bend it by at most 0.08 mm per 10 mm:
  // a 250 mm cell's local quadratic follows them to a few mm.
  double worst = 0;
  for (double x = 500; x < 9500; x += 137) {
    for (double y = 500; y < 9500; y += 137) {
      if (std::hypot(x - ball.x(), y - ball.y()) < 1300) continue;
      worst = std::max(worst, std::abs(g.HeightAt(x, y) - lawn.Height(x, y)));
    }
  }
  EXPECT_LT(worst, 8.0);
  EXPECT_NEAR(g.noise_mm, 5.0, 1.5);
  // Under the ball the ground is filled in from the lawn around it: the bumps' curvature over
  // the 2 m hole is the only error (at most ~20 mm for 50 mm bumps of 5 m).
  EXPECT_NEAR(g.HeightAt(ball.x(), ball.y()), lawn.Height(ball.x(), ball.y()), 20.0);
  // The ball's points stand far above it: none is ground.
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (pts[i].z() > ball.z()) {
      ASSERT_EQ(is_ground[i], 0) << "a ball point read as ground";
    }
  }
}

struct Scored {
  std::size_t found = 0, false_balls = 0;
  double worst_radius = 0, worst_center = 0, worst_ground = 0;  // radius and centre over the radius; ground, mm
  std::string notes;
};

// A fused photogrammetry model of `scene` (5 mm of noise), as the tests below scan their gardens.
cloud::PointCloud PhotogrammetryScan(const sim::ScanScene& scene, std::uint64_t seed) {
  sim::ScanOptions so;
  so.sensor = sim::Sensor::kPhotogrammetry;
  so.noise_mm = 5;
  so.seed = seed;
  return sim::ScanGarden(scene, so);
}

Scored ScoreScan(const sim::ScanScene& scene, const FindResult& r) {
  Scored s;
  std::vector<bool> used(r.objects.size(), false);
  for (const auto& t : scene.balls) {
    int pick = -1;
    double best = 0.5 * t.radius_mm;
    for (std::size_t k = 0; k < r.objects.size(); ++k) {
      if (!r.objects[k].ball) continue;
      const double d = (r.objects[k].fit.sphere.center_mm - t.center_mm).norm();
      if (d < best) best = d, pick = int(k);
    }
    if (pick < 0) {
      s.notes += "missed the ball of radius " + std::to_string(t.radius_mm) + "; ";
      continue;
    }
    used[std::size_t(pick)] = true;
    const auto& o = r.objects[std::size_t(pick)];
    ++s.found;
    s.worst_radius = std::max(s.worst_radius, std::abs(o.fit.sphere.radius_mm - t.radius_mm) / t.radius_mm);
    s.worst_center = std::max(s.worst_center, best / t.radius_mm);
    s.worst_ground = std::max(s.worst_ground, std::abs(o.ground_mm - scene.ground.Height(t.center_mm.x(), t.center_mm.y())));
  }
  for (std::size_t k = 0; k < r.objects.size(); ++k) {
    if (r.objects[k].topiary && !used[k]) ++s.false_balls;  // a ball, or a clipped shape found by height
  }
  return s;
}

// A 16-beam LiDAR 1.5 m up with 10 mm of noise, driving past `scene`.
cloud::PointCloud Lidar16Scan(const sim::ScanScene& scene) {
  sim::ScanOptions so;
  so.sensor = sim::Sensor::kLidar16;
  so.noise_mm = 10;
  fitting::QuietSolverWarnings();
  return sim::ScanGarden(scene, so);
}

// A 16-beam LiDAR 1.5 m up, driving past a garden of seven balls (two touching, one pressed
// against a hedge row, two domes sunk into the lawn) among roses, a tree, a bench and a fence.
TEST(FindHedges, EveryBallOfALidarScanAndNothingElse) {
  const sim::ScanScene scene = sim::RandomScanGarden(1);
  const cloud::PointCloud c = Lidar16Scan(scene);
  const FindResult r = FindHedges(c);
  const Scored s = ScoreScan(scene, r);
  EXPECT_EQ(s.found, scene.balls.size()) << s.notes;
  EXPECT_EQ(s.false_balls, 0u) << "a rose, the tree, the row, the bench or the fence was called a ball";
  // The envelope is the leaves' outer surface; their mean surface lies 1.5-3 % inside it on these
  // shells (20-60 mm deep, a third of it on average), so 0.5 % tells the envelope from the mean
  // leaf; the issue's target is 1 %.
  EXPECT_LT(s.worst_radius, 0.005);
  EXPECT_LT(s.worst_center, 0.02);  // the issue's target
  EXPECT_LT(s.worst_ground, 20.0);  // the issue's target, mm
  // Objects that are not balls are reported with their reason.
  std::size_t others = 0;
  for (const auto& o : r.objects) {
    if (!o.ball) {
      ++others;
      EXPECT_FALSE(o.reason.empty()) << "object " << o.id;
    }
  }
  EXPECT_GE(others, scene.others.size() - 1) << "the roses, the tree, the row, the bench and the fence are objects";
}

// find runs its objects, its clipped shapes and its final fits in parallel, each into its own
// slot with generators seeded alike: on one thread it gives the same answer, to the bit, as on
// every core. Fails if two objects shared a generator or a slot, or if the order they finish in
// reached the result.
TEST(FindHedges, TheAnswerDoesNotDependOnTheThreads) {
  const cloud::PointCloud c = Lidar16Scan(sim::RandomScanGarden(1));
  const FindResult all = FindHedges(c);
  FindResult one;
  tbb::task_arena single(1);
  single.execute([&] { one = FindHedges(c); });
  ASSERT_EQ(one.objects.size(), all.objects.size());
  ASSERT_GT(all.Balls(), 0u);
  for (std::size_t k = 0; k < all.objects.size(); ++k) {
    const FoundObject& a = all.objects[k];
    const FoundObject& b = one.objects[k];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.verdict, b.verdict) << "object " << a.id;
    EXPECT_EQ(a.reason, b.reason) << "object " << a.id;
    EXPECT_EQ(a.indices, b.indices) << "object " << a.id;
    EXPECT_EQ(a.fit.converged, b.fit.converged) << "object " << a.id;
    if (!a.fit.converged) continue;
    for (int i = 0; i < 3; ++i) EXPECT_EQ(a.fit.sphere.center_mm[i], b.fit.sphere.center_mm[i]) << "object " << a.id;
    EXPECT_EQ(a.fit.sphere.radius_mm, b.fit.sphere.radius_mm) << "object " << a.id;
    EXPECT_EQ(a.fit.std_error_mm, b.fit.std_error_mm) << "object " << a.id;
  }
}

// A photogrammetry-like model: ten views fused, depth noise growing with range, 1 % of the
// points flung along their rays, in metres as such models come.
TEST(FindHedges, EveryBallOfAFusedModelInMetres) {
  const sim::ScanScene scene = sim::RandomScanGarden(2);
  cloud::PointCloud c = PhotogrammetryScan(scene, 2);
  for (auto& p : c.points_mm) p /= 1000.f;
  ASSERT_EQ(cloud::GuessUnits(cloud::LargestExtent(c), cloud::MedianSpacing(c)), "m");
  for (auto& p : c.points_mm) p *= 1000.f;
  fitting::QuietSolverWarnings();
  const Scored s = ScoreScan(scene, FindHedges(c));
  EXPECT_EQ(s.found, scene.balls.size()) << s.notes;
  EXPECT_EQ(s.false_balls, 0u);
  EXPECT_LT(s.worst_radius, 0.01);  // the issue's target; the depth noise here is 5-50 mm
  EXPECT_LT(s.worst_center, 0.02);
  EXPECT_LT(s.worst_ground, 20.0);
}

// The same model exported as surveys export them: metres in UTM (easting 500 km, northing 5,700
// km, 50 m up), as text. In single precision those coordinates step by 0.03 m and 0.5 m, and find
// found no ball; shifted on reading (PointCloud::offset) the points keep the text's 0.1 mm, so
// the same tolerances hold once the reported centres are taken back to the model's frame, and
// the reports give positions in the file's frame.
TEST(FindHedges, AModelInUtmCoordinatesIsFoundAsInItsOwnFrame) {
  const sim::ScanScene scene = sim::RandomScanGarden(2);
  const cloud::PointCloud c = PhotogrammetryScan(scene, 2);
  const Eigen::Vector3d utm_m(500000.0, 5700000.0, 50.0);
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string file = (dir / "utm.xyz").string();
  {
    std::ofstream out(file);
    char line[96];
    for (const auto& p : c.points_mm) {
      if (!p.allFinite()) continue;
      const Eigen::Vector3d q = p.cast<double>() / 1000.0 + utm_m;
      out << std::string(line, std::size_t(std::snprintf(line, sizeof(line), "%.4f %.4f %.4f\n", q.x(), q.y(), q.z())));
    }
  }
  fitting::QuietSolverWarnings();
  FindReport rep = FindInCloudFile(file, 0, FindOptions{});
  EXPECT_EQ(rep.scale, 1000.0);
  EXPECT_GT(rep.offset_mm.norm(), 5e9);
  // The reports give positions in the file's frame: a ball's centre there is its centre as
  // found (in the shifted frame) plus the shift, about 5.7e9 mm north.
  const auto ball = std::find_if(rep.result.objects.begin(), rep.result.objects.end(), [](const FoundObject& o) { return o.ball; });
  ASSERT_NE(ball, rep.result.objects.end());
  std::ostringstream table, json;
  WriteFindTable(table, {rep});
  WriteFindJson(json, {rep});
  const double north = ball->fit.sphere.center_mm.y() + rep.offset_mm.y();
  EXPECT_GT(north, 5.69e9);
  EXPECT_NE(table.str().find("shifted by"), std::string::npos);
  EXPECT_NE(table.str().find(pipeline::Format("%.1f", north)), std::string::npos) << table.str();
  EXPECT_NE(json.str().find("\"offset_mm\""), std::string::npos);
  // Back to the model's frame (the file's frame less the UTM origin): the same tolerances as in
  // its own frame.
  const Eigen::Vector3d back = rep.offset_mm - 1000.0 * utm_m;
  for (auto& o : rep.result.objects) {
    o.fit.sphere.center_mm += back;
    o.ground_mm += back.z();
  }
  const Scored s = ScoreScan(scene, rep.result);
  EXPECT_EQ(s.found, scene.balls.size()) << s.notes;
  EXPECT_EQ(s.false_balls, 0u);
  EXPECT_LT(s.worst_radius, 0.01);
  EXPECT_LT(s.worst_center, 0.02);
  EXPECT_LT(s.worst_ground, 20.0);
}

// The seat of a bench (1.5 x 0.45 m, 60 mm thick, on legs) in a fused model: the watershed can
// leave a slice of it that fits a box (cuboid) closely (seed 3, a tuning seed, where the slice
// arises). Two rules refuse it: its walls hold no points half-way down to the lawn (fit_shape's
// WallCover; a clipped box is leafy to the ground), and a box whose length nothing pins has a
// jackknifed interval running to kilometres (max_axis_uncertainty). The bench is no topiary with
// the defaults, and with the second rule off; with the first off it was one (checked by hand).
TEST(FindHedges, ABenchSeatIsNoClippedBox) {
  const sim::ScanScene scene = sim::RandomScanGarden(3);
  const cloud::PointCloud c = PhotogrammetryScan(scene, 3);
  fitting::QuietSolverWarnings();
  Eigen::Vector2d bench = Eigen::Vector2d::Zero();
  for (const auto& o : scene.others) {
    if (o.kind == "bench") bench = o.center_mm.head<2>();
  }
  auto topiary_at_bench = [&](const FindResult& r) {
    int n = 0;
    for (const auto& o : r.objects) {
      if (!o.topiary || !o.shape || o.ball) continue;
      n += ((r.scene_from_cloud * o.shape->center_mm).head<2>() - bench).norm() < 1000;
    }
    return n;
  };
  EXPECT_EQ(topiary_at_bench(FindHedges(c)), 0);
  FindOptions off;
  off.topiary.max_axis_uncertainty = 1e9;
  EXPECT_EQ(topiary_at_bench(FindHedges(c, off)), 0) << "the seat's walls show no points half-way down";
}

// A cloud that says nothing of where its sensor stood is judged as seen from above: the rays
// through a solid ball's core end on its top. Two clouds of one sphere (r 300 mm, its centre 1.25
// radii above a lawn sampled every 25 mm, 3 mm of noise, leaves a mean 6 mm deep): a sparse plant whose
// points happen to lie on one side and the underside of that sphere, the lawn seen under it and
// nothing on its top (the real garden half turned 55 degrees had one by a low fence, r 277 mm);
// and a clipped ball seen from above, its top and sides held and the lawn under it hidden. The
// first is no ball (without the rule it was one, r 293.8-300.4 mm over five draws), the second is,
// with its radius within a leaf layer of the truth.
TEST(FindHedges, ABallSeenThroughFromAboveIsNoBall) {
  const Eigen::Vector3d centre(2000, 2000, 375);
  const double r = 300;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 3);
  std::exponential_distribution<double> leaf(1 / 6.0);
  auto cloud_of = [&](bool solid) {
    cloud::PointCloud c;
    for (double x = 0; x < 4000; x += 25) {
      for (double y = 0; y < 4000; y += 25) {
        if (solid && std::hypot(x - centre.x(), y - centre.y()) < r) continue;  // hidden under the ball
        c.points_mm.emplace_back(float(x), float(y), float(noise(rng)));
      }
    }
    // About one point per 25 x 25 mm of the sphere (a Fibonacci lattice).
    const int n = int(4 * M_PI * r * r / (25 * 25));
    for (int k = 0; k < n; ++k) {
      const double z = 1 - (2 * k + 1.0) / n, az = std::fmod(k * 2.399963229728653, 2 * M_PI);
      const double el = std::asin(z) * 180 / M_PI, az_deg = az * 180 / M_PI;
      const bool keep = solid ? el > -20 : (el < 25 && az_deg < 150);
      if (!keep) continue;
      const double rr = r - leaf(rng) + noise(rng), h = std::sqrt(1 - z * z);
      c.points_mm.push_back((centre + rr * Eigen::Vector3d(h * std::cos(az), h * std::sin(az), z)).cast<float>());
    }
    c.width = std::uint32_t(c.size());
    return c;
  };
  fitting::QuietSolverWarnings();
  double through = -1;  // the share past the ball the check read on the last cloud
  auto balls_near = [&](const FindResult& res, std::string* why) {
    int n = 0;
    for (const auto& o : res.objects) {
      if ((o.top_center_mm - centre.head<2>()).norm() > r) continue;
      if (std::isfinite(o.seen_through)) through = o.seen_through;
      if (o.ball) {
        ++n;
        // The envelope's radius: the leaves' tips, within 10 mm of the truth (the 3 mm noise and
        // a 6 mm mean leaf depth whose deepest tenth lies 14 mm down).
        EXPECT_NEAR(o.fit.sphere.radius_mm, r, 10) << o.verdict;
      }
      *why += o.verdict + ": " + o.reason + "; ";
    }
    return n;
  };
  std::string why;
  // (Its reason is the clipped shapes' search's, which judges it next.)
  EXPECT_EQ(balls_near(FindHedges(cloud_of(false)), &why), 0) << why;
  // Nothing on its top; the lawn under its core, 1.25 - 1 - 0.1 radii below its underside.
  EXPECT_GT(through, 0.9) << why;
  why.clear();
  through = -1;
  EXPECT_EQ(balls_near(FindHedges(cloud_of(true)), &why), 1) << why;
  // Every point over its core on its top but the deepest leaves (the exponential layer's tail
  // past the shell's band, 36 mm: about 1 % of them).
  EXPECT_GE(through, 0) << why;
  EXPECT_LT(through, 0.05) << why;
}

// A cloud that does not say where it was seen from: the envelope lays a ball's leaves along a
// guessed view or radially, whichever explains the points better. Two clipped balls (r 300 mm,
// their centres 375 mm above a lawn sampled every 25 mm, 3 mm of noise, 30 % of the leaves cut
// flush with the envelope, the rest exponentially deeper, mean 12 mm): one modelled from views all
// round, its leaves radially under every part of it above 20 degrees below its equator; one
// scanned from one side, 2 m off at its centre's height, its leaves along that scanner's rays.
// Along one guessed view the first read 29-36 mm of leaf depth over eight draws (10-12 % of its
// radius) and was refused as not clipped. Each is found with its leaf depth (0.7 x 12 = 8.4 mm)
// and radius within what 3 mm of noise and some thousand points leave: the layer's depth to 4 mm
// (the share on the envelope trading against the exponential's depth where the noise is a third
// of it; the finder's shell, 36 mm about its sphere, cuts the deepest 3 %), the radius to 6 mm
// (2 %) and the centre to 6 mm.
TEST(FindHedges, LeavesLaidRadiallyOrAlongTheViewAreBothRead) {
  const Eigen::Vector3d centre(2000, 2000, 375);
  const double r = 300, mean_depth = 12, flush = 0.3;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 3);
  std::exponential_distribution<double> leaf(1 / mean_depth);
  std::uniform_real_distribution<double> u(0, 1);
  auto depth = [&] { return u(rng) < flush ? 0.0 : leaf(rng); };
  auto cloud_of = [&](bool all_round) {
    cloud::PointCloud c;
    for (double x = 0; x < 4000; x += 25) {
      for (double y = 0; y < 4000; y += 25) {
        if (std::hypot(x - centre.x(), y - centre.y()) < r) continue;  // hidden under the ball
        c.points_mm.emplace_back(float(x), float(y), float(noise(rng)));
      }
    }
    const Eigen::Vector3d scanner = centre - Eigen::Vector3d(0, 2000, 0);
    const int n = int(4 * M_PI * r * r / (15 * 15));  // a point per 15 x 15 mm (a Fibonacci lattice)
    for (int k = 0; k < n; ++k) {
      const double z = 1 - (2 * k + 1.0) / n, az = std::fmod(k * 2.399963229728653, 2 * M_PI), h = std::sqrt(1 - z * z);
      const Eigen::Vector3d normal(h * std::cos(az), h * std::sin(az), z);
      const Eigen::Vector3d tip = centre + r * normal;
      if (all_round) {
        if (std::asin(z) < -20 * M_PI / 180) continue;
        c.points_mm.push_back((centre + (r - depth() + noise(rng)) * normal).cast<float>());
        continue;
      }
      // Seen from the scanner: in front of the limb (15 degrees to spare), deeper along its ray.
      const Eigen::Vector3d ray = (tip - scanner).normalized();
      if (-ray.dot(normal) < std::cos(75 * M_PI / 180)) continue;
      c.points_mm.push_back((tip + (depth() + noise(rng)) * ray).cast<float>());
    }
    c.width = std::uint32_t(c.size());
    return c;
  };
  fitting::QuietSolverWarnings();
  for (const bool all_round : {true, false}) {
    const FindResult res = FindHedges(cloud_of(all_round));
    int balls = 0;
    for (const auto& o : res.objects) {
      if ((o.top_center_mm - centre.head<2>()).norm() > r) continue;
      ASSERT_TRUE(o.ball) << (all_round ? "all round: " : "one side: ") << o.verdict << ": " << o.reason;
      ++balls;
      EXPECT_EQ(o.fit.method, "envelope");
      // All round, radial leaves are far the likelier (0.3 nats a point); from one side the two
      // layouts differ only towards the limb and either may win (along the view in 7 of 8 draws),
      // reading the layer within the same bounds.
      if (all_round) {
        EXPECT_EQ(o.fit.Extra("leaves_radial").value_or(-1), 1.0);
      }
      EXPECT_NEAR(o.fit.Extra("leaf_depth_mm").value_or(-1), (1 - flush) * mean_depth, 4.0) << all_round;
      EXPECT_NEAR(o.fit.sphere.radius_mm, r, 6.0) << all_round;
      EXPECT_LT((o.fit.sphere.center_mm - centre).norm(), 6.0) << all_round;
    }
    EXPECT_EQ(balls, 1) << all_round;
  }
}

// Five real Velodyne scans of one calibration sphere (radius "around 0.3 m", its owners say)
// among walls, a floor and the people about the scanner, with default settings. It is one
// sphere, so one radius lies within every scan's 95 % interval: with intervals that took each
// laser's ring for independent points (+-5-14 mm about 286.9-301.2 mm) none did.
TEST(RealData, FindsTheVelodyneSphereWithDefaults) {
  HEDGEFIT_REQUIRE_DATA("sphere_scans/example2/L1_S1.xyz");
  fitting::QuietSolverWarnings();
  double highest_low = -1e9, lowest_high = 1e9;
  for (int i = 1; i <= 5; ++i) {
    // Read as `find` reads it: units guessed, and the scanner placed at the origin by its rings.
    const FindReport rep =
        FindInCloudFile(hedgefit::testing::DataPath("sphere_scans/example2/L1_S" + std::to_string(i) + ".xyz"), 0, {});
    ASSERT_EQ(rep.scale, 1000.0) << "scan " << i << " is in metres";
    EXPECT_NE(rep.viewpoint_source.find("rings"), std::string::npos) << "scan " << i << ": " << rep.viewpoint_source;
    const FindResult& r = rep.result;
    ASSERT_EQ(r.Balls(), 1u) << "scan " << i;
    for (const auto& o : r.objects) {
      if (!o.ball) continue;
      // The five scans' own fits (RANSAC with a hand-made recipe, README's compare) give 279-302 mm.
      EXPECT_NEAR(o.fit.sphere.radius_mm, 300.0, 15.0) << "scan " << i;
      EXPECT_GE(o.indices.size(), 100u) << "scan " << i;
      const auto se = fitting::TotalStdError(o.fit);
      ASSERT_TRUE(se.has_value()) << "scan " << i;
      highest_low = std::max(highest_low, o.fit.sphere.radius_mm - 1.96 * (*se)[3]);
      lowest_high = std::min(lowest_high, o.fit.sphere.radius_mm + 1.96 * (*se)[3]);
    }
  }
  EXPECT_LE(highest_low, lowest_high) << "no radius lies within every scan's 95 % interval";
}

// The same five scans with ten seeds each: the ball search draws its hypotheses at random, and
// the sphere (140-196 points in an object of 7,000 with the walls, its stand and people) was
// missed on 26 of 250 runs with seeds 200-249 and on 4 of these 50 (scans 1, 3, 3 and 5) before
// the search drew three hypotheses per four points and refined those within four times a ball's
// lumpiness (kMaxDraws, kFirstLookLumpiness in scene/finder.cpp). One miss in 50 would be a rate
// several times the 2 in 250 measured since.
TEST(RealData, FindsTheVelodyneSphereWhateverTheSeed) {
  HEDGEFIT_REQUIRE_DATA("sphere_scans/example2/L1_S1.xyz");
  fitting::QuietSolverWarnings();
  for (int i = 1; i <= 5; ++i) {
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      FindOptions o;
      o.seed = seed;
      const FindReport rep =
          FindInCloudFile(hedgefit::testing::DataPath("sphere_scans/example2/L1_S" + std::to_string(i) + ".xyz"), 0, o);
      EXPECT_EQ(rep.result.Balls(), 1u) << "scan " << i << ", seed " << seed;
    }
  }
}

// A 16-beam LiDAR parked by a simulated garden (seed 1), at three places along its drive, with a
// sphere of leaves the beams mostly pass through (60 % of them: a cage, a stand's rim or a
// sparse crown seen as one shell) standing free on the lawn in front of it. Told where it stood,
// the finder refuses that sphere (the lawn shows through it) and keeps every ball it found
// without being told; the scan in its own frame shows its 16 rings, and the same points moved
// into the garden's frame none.
TEST(FindHedges, ASphereTheBeamsPassThroughIsNoBallWhenTheScannerIsKnown) {
  fitting::QuietSolverWarnings();
  for (const double along : {0.3, 0.5, 0.7}) {
    sim::ScanScene scene = sim::RandomScanGarden(1);
    sim::ScanOptions so;
    so.sensor = sim::Sensor::kLidar16;
    const std::vector<Eigen::Vector3d> stations = sim::ScanStations(scene, so);
    so.station = int(std::lround(along * double(stations.size() - 1)));
    const Eigen::Vector3d at = stations[std::size_t(so.station)];
    sim::ScanSphere cage;
    cage.radius_mm = 500, cage.shell_mm = 20, cage.clipped_share = 0.9, cage.gap_share = 0.6;
    // Across the drive from the garden, 4.5 m out, where the lowest beams (-15 degrees) reach the lawn.
    cage.center_mm = Eigen::Vector3d(at.x() + 600, -6000, scene.ground.Height(at.x() + 600, -6000) + 600);
    scene.blobs.push_back(cage);
    const cloud::PointCloud c = sim::ScanGarden(scene, so);
    auto is_cage = [&](const FoundObject& o) { return (o.fit.sphere.center_mm - cage.center_mm).norm() < 150; };
    auto true_balls = [&](const FindResult& r) {
      std::vector<Eigen::Vector3d> found;
      for (const auto& o : r.objects) {
        for (const auto& b : scene.balls) {
          if (o.ball && (o.fit.sphere.center_mm - b.center_mm).norm() < 0.1 * b.radius_mm) found.push_back(b.center_mm);
        }
      }
      return found;
    };
    const FindResult blind = FindHedges(c);
    FindOptions told;
    told.viewpoints_mm = {at};
    const FindResult seen = FindHedges(c, told);
    const auto cage_ball = [&](const FindResult& r) {
      return std::count_if(r.objects.begin(), r.objects.end(), [&](const FoundObject& o) { return o.ball && is_cage(o); });
    };
    // The scene must hold the trap: a shell of leaves is a ball to the finder that does not know
    // where the beams came from.
    std::string why;
    for (const auto& o : blind.objects) {
      if ((o.top_center_mm - cage.center_mm.head<2>()).norm() < 600) why += o.verdict + ": " + o.reason + "; ";
    }
    EXPECT_EQ(cage_ball(blind), 1) << "station " << so.station << ": the cage is no ball even without the station: " << why;
    EXPECT_EQ(cage_ball(seen), 0) << "station " << so.station;
    EXPECT_GE(true_balls(blind).size(), 1u) << "station " << so.station;
    EXPECT_EQ(true_balls(seen), true_balls(blind)) << "station " << so.station << ": a true ball refused as seen through";
    cloud::PointCloud own = c;
    for (auto& p : own.points_mm) p -= at.cast<float>();
    // The rings that hold points: the upper ones see the sky over a lawn, save a crown.
    const int rings = cloud::ScannerRings(own);
    EXPECT_GE(rings, 4) << "station " << so.station;
    EXPECT_LE(rings, 16) << "station " << so.station;
    // The pipeline's stage reads the scan in its own frame as `find` does: the cage no ball.
    pipeline::Registry registry;
    RegisterSceneStages(registry);
    pipeline::Pipeline p =
        pipeline::Pipeline::FromJson(R"([{"type": "segment.hedges"}])", "test", registry, {}, {"cloud"});
    pipeline::Context ctx;
    ctx.Put("cloud", own);
    const pipeline::RunReport run = p.Run(ctx);
    EXPECT_EQ(std::get<std::int64_t>(run.stages.at(0).notes.at("viewpoints")), 1) << "station " << so.station;
    EXPECT_EQ(std::get<std::int64_t>(run.stages.at(0).notes.at("balls")), std::int64_t(true_balls(seen).size()))
        << "station " << so.station;
    EXPECT_EQ(cloud::ScannerRings(c), 0) << "station " << so.station;
  }
}

// The same sphere in another room (SphereCalib's example 3: eight real VLP-16 scans, the sphere on
// a stand), read as `find` reads a file: each scan's rings put the scanner at its origin, and the
// sphere is the one ball of every scan. Without the rays, scan 1's stand (a rim and legs under the
// sphere, 101 points) passed for a dome of r 335 mm. The eight radii must agree within their
// intervals: their chi-square about the weighted mean (each standard error its 95 % half-width
// over 1.96) under its 95 % quantile for 7 degrees of freedom, 14.07. With the intervals widened
// over 8 equal-count height bands (which cut the ball's 7-12 rings across) it was 18.0, radii
// 285.4-307.8 mm; over the scanner's own rings with Student's t (RingJackknifeStdError), 11.2.
TEST(RealData, FindsTheSphereOnItsStandInEveryScanOfAnotherRoom) {
  HEDGEFIT_REQUIRE_DATA("sphere_scans/example3/L1_S1.xyz");
  fitting::QuietSolverWarnings();
  std::vector<double> radius, sd;
  for (int i = 1; i <= 8; ++i) {
    const FindReport rep =
        FindInCloudFile(hedgefit::testing::DataPath("sphere_scans/example3/L1_S" + std::to_string(i) + ".xyz"), 0, {});
    EXPECT_NE(rep.viewpoint_source.find("rings"), std::string::npos) << "scan " << i << ": " << rep.viewpoint_source;
    ASSERT_EQ(rep.result.Balls(), 1u) << "scan " << i;
    for (const auto& o : rep.result.objects) {
      // "Around 0.3 m", its owners say; example 2's test allows the same.
      if (o.ball) {
        EXPECT_NEAR(o.fit.sphere.radius_mm, 300.0, 15.0) << "scan " << i;
        const auto se = fitting::TotalStdError(o.fit);
        ASSERT_TRUE(se.has_value()) << "scan " << i;
        radius.push_back(o.fit.sphere.radius_mm);
        sd.push_back((*se)[3]);
      }
      EXPECT_FALSE(o.topiary && !o.ball) << "scan " << i << ": a room holds no clipped shape, but " << o.verdict;
    }
  }
  double sw = 0, swr = 0;
  for (std::size_t k = 0; k < radius.size(); ++k) sw += 1 / (sd[k] * sd[k]), swr += radius[k] / (sd[k] * sd[k]);
  double chi2 = 0;
  for (std::size_t k = 0; k < radius.size(); ++k) chi2 += std::pow((radius[k] - swr / sw) / sd[k], 2);
  EXPECT_LT(chi2, 14.07) << "the eight scans' radii disagree beyond their intervals (weighted mean " << swr / sw << " mm)";
}

// PCL's test clouds (a table with a mug, people, a lamppost, milk cartons, the bunny, planes):
// none holds a ball.
TEST(RealData, PclTestCloudsHoldNoBall) {
  HEDGEFIT_REQUIRE_DATA("pcl_test/five_people.pcd");
  fitting::QuietSolverWarnings();
  for (const char* name : {"table_scene_mug_stereo_textured.pcd", "five_people.pcd", "lamppost.pcd",
                           "milk_cartoon_all_small_clorox.pcd", "bun0.pcd", "milk_color.pcd", "sac_plane_test.pcd",
                           "noisy_slice_displaced.pcd"}) {
    cloud::PointCloud c = cloud::ReadCloud(hedgefit::testing::DataPath(std::string("pcl_test/") + name));
    const double scale = cloud::GuessScale(c);
    for (auto& p : c.points_mm) p *= float(scale);
    const FindResult r = FindHedges(c);
    EXPECT_EQ(r.Balls(), 0u) << name;
    EXPECT_EQ(r.Topiary(), 0u) << name << ": a clipped shape found by height in a cloud that holds none";
  }
}

// A camera's view of a table (organised, so up is taken as -y) has no ground the finder can fit
// under that up. Its objects are still reported where their points are, with their heights
// unknown (null) and a warning that says why, not a NaN centre and a height of -1e300 (what it
// printed before).
TEST(RealData, NoGroundLeavesHeightsUnknownAndCentresWhereThePointsAre) {
  HEDGEFIT_REQUIRE_DATA("pcl_test/table_scene_mug_stereo_textured.pcd");
  fitting::QuietSolverWarnings();
  const std::string file = hedgefit::testing::DataPath("pcl_test/table_scene_mug_stereo_textured.pcd");
  const FindReport rep = FindInCloudFile(file, 0, FindOptions{});
  ASSERT_EQ(rep.result.ground_points, 0u) << "the case this test is about: no ground fitted under -y";
  ASSERT_FALSE(rep.result.objects.empty());
  std::ostringstream out;
  WriteFindJson(out, {rep});
  const auto j = nlohmann::json::parse(out.str());
  const auto& cloud_json = j["clouds"][0];
  bool warned = false;
  for (const auto& w : cloud_json["warnings"]) warned |= w.get<std::string>().find("no ground could be fitted") != std::string::npos;
  EXPECT_TRUE(warned) << cloud_json["warnings"].dump();
  // The cloud's bounds (info: x -0.456..0.715, y -0.511..0.179, z 0.690..2.593 m): every
  // object's centre lies inside them.
  for (const auto& h : cloud_json["hedges"]) {
    ASSERT_TRUE(h["center_mm"].is_array());
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(h["center_mm"][k].is_number()) << h.dump();
    EXPECT_GT(h["center_mm"][2].get<double>(), 690.0);
    EXPECT_LT(h["center_mm"][2].get<double>(), 2593.0);
    EXPECT_TRUE(h["height_mm"].is_null()) << h.dump();
    EXPECT_TRUE(h["ground_mm"].is_null()) << h.dump();
  }
}

}  // namespace
}  // namespace hedgefit::scene
