// Algebraic and geometric sphere fits on synthetic spheres with exact truth.

#include "fitting/algebraic_fit.hpp"

#include <gtest/gtest.h>

#include "fitting/geometric_fit.hpp"
#include "tests/fitting/synthetic.hpp"

namespace hedgefit::fitting {
namespace {

using hedgefit::testing::Cap;

const AlgebraicMethod kMethods[] = {AlgebraicMethod::kKasa, AlgebraicMethod::kPratt, AlgebraicMethod::kTaubin,
                                    AlgebraicMethod::kHyper};

SphereFitResult Fit(AlgebraicMethod m, const std::vector<Eigen::Vector3d>& pts) {
  AlgebraicFitOptions o;
  o.method = m;
  return FitSphereAlgebraic(pts, o);
}

// Noise-free points lie exactly on the sphere, so every fit must return it up to
// double rounding amplified by the cap's conditioning: 1e-6 relative is the spec.
TEST(Exactness, NoiseFreeCapsGiveTheTrueSphere) {
  std::mt19937_64 rng(1);
  const Eigen::Vector3d center(120.0, -80.0, 2300.0);
  for (double half_angle : {10.0, 30.0, 60.0, 90.0, 180.0}) {
    const auto pts = Cap(center, 300.0, half_angle, Eigen::Vector3d(0.1, 0.2, -1.0), 500, 0.0, rng);
    std::vector<SphereFitResult> fits;
    for (AlgebraicMethod m : kMethods) fits.push_back(Fit(m, pts));
    fits.push_back(FitSphereGeometric(pts));
    for (const auto& f : fits) {
      ASSERT_TRUE(f.converged) << f.method << " " << f.message;
      EXPECT_NEAR(f.sphere.radius_mm, 300.0, 300.0 * 1e-6) << f.method << " cap " << half_angle;
      EXPECT_NEAR((f.sphere.center_mm - center).norm(), 0.0, 300.0 * 1e-6) << f.method << " cap " << half_angle;
      EXPECT_LT(f.rms_mm, 1e-6) << f.method;
    }
  }
}

// fit(R p + t) = R fit(p) + t: the fits do not depend on the frame. Far from the origin
// (|c| ~ 1e4 mm) they stay as precise, because they centre the data first.
TEST(Invariance, RigidMotionsMoveTheFitWithThePoints) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto pts = Cap(Eigen::Vector3d(0, 0, 0), 300.0, 60.0, Eigen::Vector3d(0, 0, -1), 400, 3.0, rng);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Matrix3d R = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    const Eigen::Vector3d t = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * 1e4;
    std::vector<Eigen::Vector3d> moved;
    for (const auto& p : pts) moved.push_back(R * p + t);
    for (AlgebraicMethod m : kMethods) {
      const SphereFitResult a = Fit(m, pts), b = Fit(m, moved);
      ASSERT_TRUE(a.converged && b.converged);
      // Same problem in another frame: agreement to rounding of 1e4-sized coordinates.
      EXPECT_NEAR(b.sphere.radius_mm, a.sphere.radius_mm, 1e-7) << MethodName(m);
      EXPECT_NEAR((b.sphere.center_mm - (R * a.sphere.center_mm + t)).norm(), 0.0, 1e-7) << MethodName(m);
    }
    const SphereFitResult a = FitSphereGeometric(pts), b = FitSphereGeometric(moved);
    EXPECT_NEAR(b.sphere.radius_mm, a.sphere.radius_mm, 1e-6);
    EXPECT_NEAR((b.sphere.center_mm - (R * a.sphere.center_mm + t)).norm(), 0.0, 1e-6);
  }
}

// Over seeded trials on noisy 60-degree caps, Kasa's radius is biased low while Hyper
// (no second-order bias) and the geometric fit are not. Noise sigma = 5 mm on r = 300
// mm, 300 points, 200 trials: the per-trial radius spread is about 1.5 mm, so the mean
// over trials is known to ~0.1 mm (standard error); the bounds below are 4 of those.
TEST(Statistics, HyperAndGeometricAreLessBiasedThanKasa) {
  std::mt19937_64 rng(3);
  const int trials = 200;
  double kasa = 0, hyper = 0, geometric = 0, ss_kasa = 0;
  for (int i = 0; i < trials; ++i) {
    const auto pts = Cap(Eigen::Vector3d(50, 20, 2300), 300.0, 60.0, Eigen::Vector3d(0, 0, -1), 300, 5.0, rng);
    const double k = Fit(AlgebraicMethod::kKasa, pts).sphere.radius_mm - 300.0;
    kasa += k;
    ss_kasa += k * k;
    hyper += Fit(AlgebraicMethod::kHyper, pts).sphere.radius_mm - 300.0;
    GeometricFitOptions o;
    o.compute_covariance = false;
    geometric += FitSphereGeometric(pts, o).sphere.radius_mm - 300.0;
  }
  kasa /= trials;
  hyper /= trials;
  geometric /= trials;
  const double spread = std::sqrt(ss_kasa / trials - kasa * kasa);
  const double standard_error = spread / std::sqrt(double(trials));
  // Kasa's bias is real (many standard errors below zero) ...
  EXPECT_LT(kasa, -4 * standard_error) << "kasa bias " << kasa;
  // ... and the better fits' biases are smaller and consistent with zero.
  EXPECT_LT(std::abs(hyper), std::abs(kasa));
  EXPECT_LT(std::abs(geometric), std::abs(kasa));
  EXPECT_LT(std::abs(hyper), 4 * standard_error) << "hyper bias " << hyper;
  EXPECT_LT(std::abs(geometric), 4 * standard_error) << "geometric bias " << geometric;
}

TEST(Degenerate, InputsGiveDocumentedMessages) {
  auto expect = [](const std::vector<Eigen::Vector3d>& pts, const std::string& message) {
    for (AlgebraicMethod m : kMethods) {
      const SphereFitResult r = Fit(m, pts);
      EXPECT_FALSE(r.converged);
      EXPECT_EQ(r.message, message) << MethodName(m);
    }
    const SphereFitResult g = FitSphereGeometric(pts);
    EXPECT_FALSE(g.converged);
    EXPECT_EQ(g.message, message);
  };
  expect({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, "need at least 4 points to fit a sphere, got 3");
  expect({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, std::nan("")}},
         "points contain NaN or Inf; remove them first (filters.nonfinite)");
  expect(std::vector<Eigen::Vector3d>(10, Eigen::Vector3d(5, 5, 2000)), "all points coincide; a sphere is not determined");
  std::vector<Eigen::Vector3d> line, plane;
  for (int i = 0; i < 20; ++i) line.emplace_back(i, 2 * i, 2000 + 3 * i);
  for (int i = 0; i < 20; ++i) plane.emplace_back(i % 5, i / 5, 2000);
  expect(line, "points are collinear; a sphere is not determined");
  expect(plane, "points are coplanar; a sphere is not determined");
}

// The uncertainty's refit (Gauss-Newton from a close start) minimises the same sum as the Ceres
// fit: on a noisy cap less a patch, from the whole cap's sphere, both must reach the same sphere.
// Both stop within ~1e-6 mm of the minimum (their tolerances), far below the 3 mm noise's
// standard error (~0.1 mm), so 1e-5 mm tells a wrong minimum, or a refit that stopped early, from
// rounding.
TEST(Refit, GaussNewtonFromACloseStartReachesTheGeometricFit) {
  std::mt19937_64 rng(4);
  const Eigen::Vector3d center(80.0, -40.0, 2300.0);
  const auto pts = Cap(center, 300.0, 60.0, Eigen::Vector3d(0, 0, -1), 3000, 3.0, rng);
  GeometricFitOptions go;
  go.compute_covariance = false;
  const SphereFitResult whole = FitSphereGeometric(pts, go);
  ASSERT_TRUE(whole.converged) << whole.message;
  std::vector<Eigen::Vector3d> rest;
  for (const auto& p : pts) {
    if (p.x() < center.x() + 100) rest.push_back(p);  // a patch at one side of the cap left out
  }
  const SphereFitResult reference = FitSphereGeometric(rest, go, &whole.sphere);
  ASSERT_TRUE(reference.converged) << reference.message;
  // The patch moves the fit: a refit that did not move would not pass the check below.
  ASSERT_GT((reference.sphere.center_mm - whole.sphere.center_mm).norm(), 0.01);
  const auto refit = RefitSphereGeometric(rest, whole.sphere);
  ASSERT_TRUE(refit.has_value());
  EXPECT_NEAR(refit->radius_mm, reference.sphere.radius_mm, 1e-5);
  EXPECT_NEAR((refit->center_mm - reference.sphere.center_mm).norm(), 0.0, 1e-5);
  // Too few points, or all in one place (a singular system): no sphere.
  EXPECT_FALSE(RefitSphereGeometric({pts[0], pts[1], pts[2]}, whole.sphere).has_value());
  EXPECT_FALSE(RefitSphereGeometric(std::vector<Eigen::Vector3d>(10, pts[0]), whole.sphere).has_value());
}

// The robust refit `find` repeats for each ball hypothesis minimises Ceres' Huber loss: on a cap
// with a fifth of its points thrown 40-150 mm outside (a neighbour's leaves, clutter), from a
// start 30 mm off, it must reach FitSphereGeometric's Huber fit. It stops within 1e-3 mm of a step
// (its tolerance here, as in `find`), Ceres within 1e-6 mm; reweighting converges linearly, so 0.01
// mm separates the same minimum from another one (the plain least squares' lies millimetres out).
TEST(Refit, HuberReweightedLevenbergMarquardtReachesCeresHuberFit) {
  std::mt19937_64 rng(9);
  const Eigen::Vector3d center(-120.0, 60.0, 1800.0);
  auto pts = Cap(center, 450.0, 70.0, Eigen::Vector3d(0, 0, -1), 2000, 3.0, rng);
  std::uniform_real_distribution<double> out(40.0, 150.0);
  for (std::size_t i = 0; i < pts.size(); i += 5) pts[i] = center + (pts[i] - center).normalized() * (450.0 + out(rng));
  GeometricFitOptions go;
  go.loss = RobustLoss::kHuber;
  go.loss_scale_mm = 10.0;
  go.compute_covariance = false;
  Sphere start;
  start.center_mm = center + Eigen::Vector3d(20.0, -15.0, 15.0);
  start.radius_mm = 430.0;
  const SphereFitResult reference = FitSphereGeometric(pts, go, &start);
  ASSERT_TRUE(reference.converged) << reference.message;
  const auto refit = RefitSphereHuber(pts, start, go.loss_scale_mm, 100, 1e-3);
  ASSERT_TRUE(refit.has_value());
  EXPECT_NEAR(refit->radius_mm, reference.sphere.radius_mm, 0.01);
  EXPECT_NEAR((refit->center_mm - reference.sphere.center_mm).norm(), 0.0, 0.01);
  // The loss matters here: least squares on the same points lies well away from the Huber fit.
  const auto plain = RefitSphereGeometric(pts, start);
  ASSERT_TRUE(plain.has_value());
  EXPECT_GT(std::abs(plain->radius_mm - reference.sphere.radius_mm), 1.0);
  // Too few points, or no loss scale: no sphere.
  EXPECT_FALSE(RefitSphereHuber({pts[0], pts[1], pts[2]}, start, 10.0).has_value());
  EXPECT_FALSE(RefitSphereHuber(pts, start, 0.0).has_value());
}

}  // namespace
}  // namespace hedgefit::fitting
