// The trim plan on a simulated hedge whose excess over the target is known: a ball of radius
// 500 mm with a bulge (a 25-degree cap standing out to 540 mm), seen from the camera's side,
// with 2 mm of radial noise; the target is the 500 mm sphere.

#include "fitting/trim.hpp"
#include "cloud/cloud_stages.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pipeline/pipeline.hpp"
#include "cloud/point_cloud.hpp"
#include "pipeline/registry.hpp"
#include "fitting/fitting_stages.hpp"

namespace hedgefit::fitting {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

constexpr double kR = 500, kBulgeR = 540, kBulgeDeg = 25, kNoise = 2;

struct Hedge {
  Eigen::Vector3d center{100, -50, 2500}, bulge_axis;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> true_depth;  // noise-free radius minus the target radius
  double seen_cos = 0.2;           // directions with d . (camera - c) / |camera - c| > 0.2 are seen
};

Hedge MakeHedge(std::size_t n, unsigned seed) {
  Hedge h;
  const Eigen::Vector3d to_camera = (-h.center).normalized();
  h.bulge_axis = (to_camera + Eigen::Vector3d(0, -0.3, 0)).normalized();  // towards the camera, a little up
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, 1);
  while (h.points.size() < n) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    if (d.dot(to_camera) <= h.seen_cos) continue;
    const double r = d.dot(h.bulge_axis) > std::cos(kBulgeDeg * M_PI / 180) ? kBulgeR : kR;
    h.points.push_back(h.center + d * (r + kNoise * g(rng)));
    h.true_depth.push_back(r - kR);
  }
  return h;
}

TEST(Trim, CutDepthsShareAndVolumeOfAKnownBulge) {
  const Hedge h = MakeHedge(200000, 3);
  Sphere target{h.center, kR};
  const TrimPlan plan = PlanTrim(h.points, target);
  ASSERT_EQ(plan.depth_mm.size(), h.points.size());
  // Each point's depth is its true excess plus its own radial noise: within 4.5 sigma of the
  // truth for all but a handful of 200000 points (|z| > 4.5 has probability 7e-6).
  int far = 0;
  double bulge_sum = 0;
  std::size_t bulge_points = 0;
  for (std::size_t i = 0; i < h.points.size(); ++i) {
    far += std::abs(plan.depth_mm[i] - h.true_depth[i]) > 4.5 * kNoise;
    if (h.true_depth[i] > 0) bulge_sum += plan.depth_mm[i], ++bulge_points;
  }
  EXPECT_LE(far, 10);
  // Points to cut: the bulge's (depth 40 mm), none of the rest (0 +- 2 mm, tolerance 5 mm =
  // 2.5 sigma, so about 0.6 % of them by noise alone).
  const double rest = double(h.points.size() - bulge_points);
  EXPECT_NEAR(double(plan.points_to_cut), double(bulge_points) + 0.0062 * rest, 0.003 * rest);
  // The cut points' depths: 40 mm +- the noise; the median within a few hundredths (plus the
  // 0.6 % of noise points near 5 mm, which pull it down by ~0.1 mm), the 99th percentile at
  // 40 + 2.33 sigma.
  EXPECT_NEAR(bulge_sum / double(bulge_points), kBulgeR - kR, 0.05);
  EXPECT_NEAR(plan.cut_p50_mm, kBulgeR - kR, 0.3);
  EXPECT_NEAR(plan.cut_p99_mm, kBulgeR - kR + 2.33 * kNoise, 0.5);
  EXPECT_GT(plan.cut_max_mm, kBulgeR - kR + 3 * kNoise);
  // Share and volume against the geometry: the bulge covers 2 pi (1 - cos 25 deg) sr of the
  // 2 pi (1 - 0.2) sr seen; its volume is that solid angle times (540^3 - 500^3) / 3. The
  // issue's bar is 10 %; the bins on the bulge's rim (a median of two radii) and the bins on
  // the edge of the seen part (counted half) are each right only on average, at ~1.4 degrees
  // (about 20 points per bin) a few per cent.
  const double bulge_sr = 2 * M_PI * (1 - std::cos(kBulgeDeg * M_PI / 180)), seen_sr = 2 * M_PI * (1 - h.seen_cos);
  EXPECT_NEAR(plan.seen_share, seen_sr / (4 * M_PI), 0.02);
  EXPECT_GT(plan.bin_deg, 0.5);  // automatic: about 20 points per bin
  EXPECT_LT(plan.bin_deg, 3.0);
  EXPECT_NEAR(plan.cut_share, bulge_sr / seen_sr, 0.1 * bulge_sr / seen_sr);
  const double volume_l = bulge_sr * (std::pow(kBulgeR, 3) - std::pow(kR, 3)) / 3 * 1e-6;
  EXPECT_NEAR(plan.volume_seen_l, volume_l, 0.1 * volume_l);
  EXPECT_NEAR(plan.volume_all_round_l, plan.volume_seen_l / plan.seen_share, 1e-9);
}

TEST(Trim, NothingToCutInsideTheTargetAndBadTargetsAreRefused) {
  const Hedge h = MakeHedge(50000, 5);
  // A target 60 mm larger than the bulge: every depth is negative, nothing to cut.
  const TrimPlan plan = PlanTrim(h.points, Sphere{h.center, 600});
  EXPECT_EQ(plan.points_to_cut, 0u);
  EXPECT_EQ(plan.cut_share, 0.0);
  EXPECT_EQ(plan.volume_seen_l, 0.0);
  EXPECT_EQ(plan.cut_max_mm, 0.0);
  EXPECT_THROW(PlanTrim(h.points, Sphere{h.center, 0}), Error);
  EXPECT_THROW(PlanTrim(h.points, Sphere{Eigen::Vector3d(NAN, 0, 0), 500}), Error);
  TrimOptions o;
  o.bin_deg = 0.05;  // 0 is automatic; below 0.1 degrees is refused
  EXPECT_THROW(PlanTrim(h.points, Sphere{h.center, 500}, o), Error);
}

// The stage: a fit centres the target, the cut depths become a field, and a pipeline without
// a fit or a radius is refused before it runs.
TEST(Trim, StageCentresOnTheFitAndWritesTheField) {
  pipeline::Registry reg;
  cloud::RegisterCloudStages(reg);
  RegisterFittingStages(reg);
  const Hedge h = MakeHedge(20000, 7);
  cloud::PointCloud c;
  for (const auto& p : h.points) c.points_mm.push_back(p.cast<float>());
  c.Flatten();
  pipeline::Context ctx;
  ctx.Put("cloud", c);
  pipeline::Pipeline p = pipeline::Pipeline::FromJson(
      R"([{"type": "fitters.ransac_geometric", "distance_threshold": 8}, {"type": "filters.trim_depth", "radius": 500}])",
      "p", reg, {}, {"cloud"});
  p.Run(ctx);
  const auto& plans = ctx.Get<std::vector<TrimPlan>>("trim_plans");
  ASSERT_EQ(plans.size(), 1u);
  // RANSAC keeps the 500 mm ball (most points) and drops the bulge: the centre within a
  // millimetre, so the bulge is still ~40 mm proud.
  EXPECT_LT((plans[0].target.center_mm - h.center).norm(), 1.0);
  EXPECT_NEAR(plans[0].cut_p50_mm, kBulgeR - kR, 1.5);
  const auto& field = ctx.Get<cloud::PointCloud>("cloud").fields.at("cut_depth");
  EXPECT_EQ(field.size(), h.points.size());
  EXPECT_THROW(pipeline::Pipeline::FromJson(R"([{"type": "filters.trim_depth", "radius": 500}])", "p", reg, {}, {"cloud"}),
               Error);  // no fit and no centre
  EXPECT_THROW(pipeline::Pipeline::FromJson(R"([{"type": "filters.trim_depth"}])", "p", reg, {}, {"cloud"}), Error);
}

// A leafy hedge seen all round but for its top and bottom (as a ring of captures sees it): a third
// of the points on the envelope (clipped leaves), the rest an exponential depth (mean 15 mm)
// below it, plus 1 mm of noise. The envelope is what the shears cut to.
TEST(Trim, ALeafyHedgesVolumeIsToItsEnvelopeAndTheUnseenRestIsBounded) {
  constexpr double kEnvelope = 500, kTarget = 460, kLeafMean = 15, kShare = 1.0 / 3, kSeenBand = 0.8;
  std::mt19937 rng(8);
  std::normal_distribution<double> g(0, 1);
  std::exponential_distribution<double> leaf(1 / kLeafMean);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Eigen::Vector3d> pts;
  while (pts.size() < 150000) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    if (std::abs(d.y()) > kSeenBand) continue;  // the top and bottom caps: unseen
    const double depth = u(rng) < kShare ? 0.0 : leaf(rng);
    pts.push_back((kEnvelope - depth + g(rng)) * d);
  }
  const Sphere target{Eigen::Vector3d::Zero(), kTarget};
  const double shell = (std::pow(kEnvelope, 3) - std::pow(kTarget, 3)) / 3;  // per steradian
  const double seen_sr = 4 * M_PI * kSeenBand;                                // |cos| < 0.8: 80 % of the sphere
  TrimOptions leafy;
  leafy.clipped_share = kShare;
  leafy.bin_deg = 6;
  const TrimPlan plan = PlanTrim(pts, target, leafy, -Eigen::Vector3d::UnitY());
  // Over the seen part (edge bins count half, so the plan's own seen share is the reference):
  // the envelope's volume within 5 %; the bins' radii are quantiles of ~100 points each.
  EXPECT_NEAR(plan.seen_share, kSeenBand, 0.05);
  EXPECT_NEAR(plan.volume_seen_l, shell * 4 * M_PI * plan.seen_share * 1e-6, 0.05 * shell * seen_sr * 1e-6);
  // The median (a bare surface's rule) reads the leaves' middle: well under the envelope's volume
  // (the median depth is ~0.4 of the mean leaf, 6 mm here: about 15 % less).
  TrimOptions bare = leafy;
  bare.clipped_share = 1;
  EXPECT_LT(PlanTrim(pts, target, bare, -Eigen::Vector3d::UnitY()).volume_seen_l, 0.9 * plan.volume_seen_l);
  // The unseen caps are marked, not extrapolated: bins there hold no points, and the bound (each
  // unseen direction as far out as the farthest seen bin) is at least what they truly hold.
  int unseen_top = 0;
  for (const TrimBin& b : plan.bins) unseen_top += (!b.seen && b.direction.y() < -0.9) ? 1 : 0;
  EXPECT_GT(unseen_top, 0);
  for (const TrimBin& b : plan.bins) {
    if (std::abs(b.direction.y()) < 0.7) {
      EXPECT_TRUE(b.seen);
    }
  }
  const double unseen_truth_l = shell * 4 * M_PI * (1 - plan.seen_share) * 1e-6;
  EXPECT_GE(plan.volume_unseen_max_l, unseen_truth_l);
  EXPECT_LT(plan.volume_unseen_max_l, 1.5 * unseen_truth_l);  // the farthest bin: the envelope plus its noise
}

}  // namespace
}  // namespace hedgefit::fitting

namespace hedgefit::fitting {
namespace {

// A clipped oblate spheroid as the target (semi-axes 400 x 300 x 250 mm, turned 30 degrees about
// the vertical z), and a hedge grown 10 % past it all round: every point lies 1.1 times the
// target's radius along its ray, so its cut depth is exactly 0.1 of that radius, and the
// volume to cut is (1.1^3 - 1) of the shape's 4/3 pi abc, less the bins' discretisation.
TEST(Trim, AClippedSpheroidTargetGivesDepthsAlongItsRays) {
  const Eigen::Vector3d c(1000, -2000, 300), axes(400, 300, 250);
  const double heading = 30 * M_PI / 180;
  const Eigen::Vector3d along(std::cos(heading), std::sin(heading), 0), across(-std::sin(heading), std::cos(heading), 0);
  auto radius = [&](const Eigen::Vector3d& u) {
    const double a = u.dot(along) / axes.x(), b = u.dot(across) / axes.y(), z = u.z() / axes.z();
    return 1 / std::sqrt(a * a + b * b + z * z);
  };
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  std::vector<Eigen::Vector3d> pts;
  std::vector<double> truth;
  for (int i = 0; i < 40000; ++i) {
    Eigen::Vector3d u(n(rng), n(rng), n(rng));
    u.normalize();
    pts.push_back(c + 1.1 * radius(u) * u);
    truth.push_back(0.1 * radius(u));
  }
  TrimOptions o;
  o.axes_mm = axes;
  o.heading_deg = 30;
  o.bin_deg = 5;
  const TrimPlan plan = PlanTrim(pts, Sphere{c, 1}, o, Eigen::Vector3d::UnitZ());
  double worst = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) worst = std::max(worst, std::abs(plan.depth_mm[i] - truth[i]));
  EXPECT_LT(worst, 1e-3);  // exact along the ray, float storage aside
  EXPECT_EQ(plan.points_to_cut, pts.size());
  const double volume_l = (std::pow(1.1, 3) - 1) * 4.0 / 3.0 * M_PI * axes.prod() * 1e-6;
  // The bins read the surface at their centre's direction; over 5-degree bins of a shape whose
  // radius changes by up to 1.2 % per degree, the sum is within 2 %.
  EXPECT_NEAR(plan.volume_seen_l, volume_l, 0.02 * volume_l);
  EXPECT_NEAR(plan.seen_share, 1.0, 0.01);
  EXPECT_NEAR(plan.target.radius_mm, std::cbrt(axes.prod()), 1e-9);
  // A shape target with a non-positive semi-axis is refused, naming the option.
  o.axes_mm = Eigen::Vector3d(400, 0, 250);
  EXPECT_THROW(PlanTrim(pts, Sphere{c, 1}, o, Eigen::Vector3d::UnitZ()), Error);
}

// A clipped box (half-sides 400 x 250 x 300 mm, turned 30 degrees), a drum (radius 350 mm,
// half-height 300 mm) and a cone (base radius 350 mm, 900 mm tall) as targets, each with a hedge
// grown 10 % past it along every ray from its centre, as above: the cut depth is exactly 0.1 of
// the target's radius along the ray, and the volume (1.1^3 - 1) of the box's 8abc, the drum's
// 2 pi R^2 h or the cone's pi R^2 H / 3. Their radius along a ray has kinks at their edges, where
// a bin's centre reads its cell less well than on a smooth shape; over 3-degree bins the sum is
// still within 2 %.
TEST(Trim, ABoxADrumAndAConeAsTargetsGiveDepthsAlongTheirRays) {
  const Eigen::Vector3d c(-500, 800, 300);
  const double heading = 30 * M_PI / 180;
  const Eigen::Vector3d along(std::cos(heading), std::sin(heading), 0), across(-std::sin(heading), std::cos(heading), 0);
  struct Case {
    std::string shape;
    Eigen::Vector3d axes;
    double volume_mm3;
  };
  const std::vector<Case> cases = {{"cuboid", {400, 250, 300}, 8 * 400.0 * 250 * 300},
                                   {"cylinder", {350, 350, 300}, 2 * M_PI * 350.0 * 350 * 300},
                                   {"cone", {350, 350, 450}, 2 * M_PI / 3 * 350.0 * 350 * 450}};
  for (const auto& k : cases) {
    auto radius = [&](const Eigen::Vector3d& u) {
      const double a = u.dot(along) / k.axes.x(), b = u.dot(across) / k.axes.y(), z = u.z() / k.axes.z();
      // A cone's side, in units of its semi-axes: rho + w / 2 = 1 / 2 (base radius 1 at w = -1, apex at w = 1).
      if (k.shape == "cone") return 1 / std::max(2 * std::hypot(a, b) + z, -z);
      return k.shape == "cuboid" ? 1 / std::max({std::abs(a), std::abs(b), std::abs(z)}) : 1 / std::max(std::hypot(a, b), std::abs(z));
    };
    std::mt19937 rng(7);
    std::normal_distribution<double> n(0, 1);
    std::vector<Eigen::Vector3d> pts;
    std::vector<double> truth;
    for (int i = 0; i < 60000; ++i) {
      Eigen::Vector3d u(n(rng), n(rng), n(rng));
      u.normalize();
      pts.push_back(c + 1.1 * radius(u) * u);
      truth.push_back(0.1 * radius(u));
    }
    TrimOptions o;
    o.axes_mm = k.axes;
    o.heading_deg = 30;
    o.shape = k.shape;
    o.bin_deg = 3;
    const TrimPlan plan = PlanTrim(pts, Sphere{c, 1}, o, Eigen::Vector3d::UnitZ());
    double worst = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) worst = std::max(worst, std::abs(plan.depth_mm[i] - truth[i]));
    EXPECT_LT(worst, 1e-3) << k.shape;  // exact along the ray, float storage aside
    const double volume_l = (std::pow(1.1, 3) - 1) * k.volume_mm3 * 1e-6;
    EXPECT_NEAR(plan.volume_seen_l, volume_l, 0.02 * volume_l) << k.shape;
    EXPECT_NEAR(4 * M_PI / 3 * std::pow(plan.target.radius_mm, 3), k.volume_mm3, 1e-6 * k.volume_mm3) << k.shape;
    EXPECT_EQ(plan.target_shape, k.shape);
  }
  // A drum whose two radii differ, or a shape nobody clips, is refused, naming the option.
  TrimOptions o;
  o.axes_mm = Eigen::Vector3d(350, 300, 300);
  o.shape = "cylinder";
  EXPECT_THROW(PlanTrim({c + Eigen::Vector3d(400, 0, 0)}, Sphere{c, 1}, o, Eigen::Vector3d::UnitZ()), Error);
  o.shape = "pyramid";
  o.axes_mm = Eigen::Vector3d(350, 350, 300);
  EXPECT_THROW(PlanTrim({c + Eigen::Vector3d(400, 0, 0)}, Sphere{c, 1}, o, Eigen::Vector3d::UnitZ()), Error);
}

// A cone clipped 20 mm wider at its base than its target (base radius 350 against 330 mm, both
// 900 mm tall from the same lawn), seen on its side only (a sensor never sees the base), densely
// (every 5 mm) with 3 mm of noise. The volume to cut over the directions the side is seen in is
// 11.81 L (the side's 89.4 % of the sphere of directions, by a million random rays). Each bin
// reads the target's radius at its centre, which across the rim and about the apex is coarse: over
// 4-degree bins the seen volume is within 10 %, less the edge bins' uncounted halves (about 8 % of
// the seen directions here). Over bins several times larger the rim's jump counts as depth (a
// sparser cloud's automatic bins read twice the volume): `bin_deg` small on pointed shapes.
TEST(Trim, AConeSeenOnItsSideReadsItsVolume) {
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0, 3);
  std::vector<Eigen::Vector3d> pts;
  const double A = 350, H = 900;
  for (double z = 3; z < H; z += 5) {
    const double r = A * (1 - z / H);
    for (double t = 0; t < 2 * M_PI; t += 5 / std::max(r, 5.0)) {
      pts.emplace_back(r * std::cos(t) + n(rng), r * std::sin(t) + n(rng), z + n(rng));
    }
  }
  TrimOptions o;
  o.axes_mm = Eigen::Vector3d(330, 330, 450);
  o.shape = "cone";
  o.bin_deg = 4;
  const TrimPlan plan = PlanTrim(pts, Sphere{Eigen::Vector3d(0, 0, 450), 1}, o, Eigen::Vector3d::UnitZ());
  EXPECT_LT(plan.seen_share, 0.894);  // the side's share at most (the edge bins count half, the apex is sparse)
  EXPECT_NEAR(plan.volume_seen_l / plan.seen_share, 11.81 / 0.894, 0.10 * 11.81 / 0.894);
  EXPECT_TRUE(plan.warnings.empty()) << plan.warnings.front();
  // 15-degree bins straddle the rim and the apex: the volume reads far off (about 1.7 times),
  // and the plan says so, its binning estimate the size of the error it makes (within 2 times).
  o.bin_deg = 15;
  const TrimPlan coarse = PlanTrim(pts, Sphere{Eigen::Vector3d(0, 0, 450), 1}, o, Eigen::Vector3d::UnitZ());
  const double error_l = std::abs(coarse.volume_seen_l - 11.81 / 0.894 * coarse.seen_share);
  EXPECT_GT(error_l, 0.3 * coarse.volume_seen_l);
  ASSERT_EQ(coarse.warnings.size(), 1u);
  EXPECT_NE(coarse.warnings[0].find("bin_deg"), std::string::npos) << coarse.warnings[0];
  EXPECT_GT(coarse.volume_binning_l, 0.5 * error_l);
  EXPECT_LT(coarse.volume_binning_l, 2 * error_l);
}

}  // namespace
}  // namespace hedgefit::fitting
