// The ellipsoid fit tells a ball from a dome on caps a camera sees: axes recovered on a
// flattened hedge, equal axes on a ball, invariant to where the hedge stands.

#include "fitting/ellipsoid_fit.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "pipeline/error.hpp"
#include "fitting/methods.hpp"
#include "tests/fitting/synthetic.hpp"

namespace hedgefit::fitting {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

// Points of an axis-aligned ellipsoid (semi-axes a along x, b along y = down, c along z) on the
// side facing a camera at the origin, within `half_angle_deg` of the view axis, with noise.
std::vector<Eigen::Vector3d> SpheroidCap(const Eigen::Vector3d& centre, double a, double b, double c, std::size_t n,
                                         double sigma, std::mt19937_64& rng) {
  const auto dirs = hedgefit::testing::Cap(Eigen::Vector3d::Zero(), 1.0, 75, (-centre).normalized(), n, 0.0, rng);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Eigen::Vector3d> pts;
  for (const auto& u : dirs) {
    const Eigen::Vector3d p = centre + Eigen::Vector3d(a * u.x(), b * u.y(), c * u.z());
    pts.push_back(p + noise(rng) * p.normalized());
  }
  return pts;
}

TEST(EllipsoidFit, DomeAndBallAreToldApart) {
  std::mt19937_64 rng(21);
  // A dome: 500 mm wide, 400 mm tall (semi-axes), 2.2 m away, 1.5 mm noise.
  const Eigen::Vector3d centre(100, 50, 2200);
  const EllipsoidFit dome = FitEllipsoid(SpheroidCap(centre, 500, 400, 500, 20000, 1.5, rng));
  ASSERT_TRUE(dome.converged) << dome.message;
  // The vertical and horizontal axes lie in the image plane and are well seen: within 1 %.
  // (The depth axis is seen only from the front; it enters through the horizontal mean.)
  EXPECT_NEAR(dome.vertical_axis_mm, 400, 4.0);
  EXPECT_NEAR(dome.horizontal_axis_mm, 500, 10.0);
  EXPECT_LT((dome.center_mm - centre).norm(), 10.0);
  EXPECT_LT(dome.rms_mm, 2.0);  // the noise (1.5 mm) and no model error
  // A ball: the same fit gives (nearly) equal axes.
  const EllipsoidFit ball = FitEllipsoid(SpheroidCap(centre, 450, 450, 450, 20000, 1.5, rng));
  ASSERT_TRUE(ball.converged) << ball.message;
  EXPECT_NEAR(ball.vertical_axis_mm / ball.horizontal_axis_mm, 1.0, 0.02);
  EXPECT_GT(dome.horizontal_axis_mm / dome.vertical_axis_mm, 1.2);  // 500 / 400 = 1.25
}

TEST(EllipsoidFit, MovesWithTheHedge) {
  std::mt19937_64 rng(22);
  const auto pts = SpheroidCap(Eigen::Vector3d(0, 0, 2400), 520, 430, 520, 8000, 1.0, rng);
  const EllipsoidFit a = FitEllipsoid(pts);
  std::vector<Eigen::Vector3d> moved;
  const Eigen::Vector3d t(300, -200, 150);
  for (const auto& p : pts) moved.push_back(p + t);
  const EllipsoidFit b = FitEllipsoid(moved);
  ASSERT_TRUE(a.converged && b.converged);
  EXPECT_LT((b.center_mm - (a.center_mm + t)).norm(), 1e-6);
  EXPECT_LT((b.axes_mm - a.axes_mm).norm(), 1e-6);
  // Through the method table: the axes are reported beside the sphere.
  const SphereFitResult r = RunFitMethod("ellipsoid", pts);
  ASSERT_TRUE(r.converged && r.Extra("axes_mm") && r.Extra("vertical_axis_mm"));
  EXPECT_NEAR(*r.Extra("vertical_axis_mm"), 430, 5.0);
  EXPECT_EQ(FitEllipsoid({Eigen::Vector3d(0, 0, 1)}).converged, false);
}

// Points of a leafy spheroid as a camera at the origin sees it: the cap within 60 degrees of the
// view axis, each point an exponential leaf depth (mean `leaf_mm`) inside the surface plus noise.
std::vector<Eigen::Vector3d> LeafySpheroidCap(const Eigen::Vector3d& centre, double a, double b, double leaf_mm,
                                              std::size_t n, std::mt19937_64& rng) {
  const auto dirs = hedgefit::testing::Cap(Eigen::Vector3d::Zero(), 1.0, 60, (-centre).normalized(), n, 0.0, rng);
  std::exponential_distribution<double> depth(1.0 / leaf_mm);
  std::normal_distribution<double> noise(0.0, 2.0);
  std::vector<Eigen::Vector3d> pts;
  for (const auto& u : dirs) {
    // y is down: the vertical semi-axis b lies along y.
    const Eigen::Vector3d s = centre + Eigen::Vector3d(a * u.x(), b * u.y(), a * u.z());
    const Eigen::Vector3d radial = (s - centre).normalized();
    pts.push_back(s - (depth(rng) + noise(rng)) * radial);
  }
  return pts;
}

// On the cap a camera sees of a leafy hedge (12 mm mean leaf depth, 60 degrees), the spheroid
// tells a dome from a ball where the general ellipsoid's depth axis wanders: the leaf layer
// shrinks both semi-axes alike, so their ratio stays.
TEST(SpheroidFit, DomeAndBallAreToldApartOnLeafyCaps) {
  std::mt19937_64 rng(31);
  const Eigen::Vector3d centre(150, 200, 2400);
  const EllipsoidFit dome = FitSpheroid(LeafySpheroidCap(centre, 550, 450, 12, 20000, rng));
  ASSERT_TRUE(dome.converged) << dome.message;
  const EllipsoidFit ball = FitSpheroid(LeafySpheroidCap(centre, 500, 500, 12, 20000, rng));
  ASSERT_TRUE(ball.converged) << ball.message;
  // 20000 points: the ratio's scatter is well under 1 %; the leaf layer (12 mm of ~500) biases
  // each axis by a similar ~2 %, which cancels in the ratio to within 2 %.
  EXPECT_NEAR(dome.vertical_axis_mm / dome.horizontal_axis_mm, 450.0 / 550.0, 0.02);
  EXPECT_NEAR(ball.vertical_axis_mm / ball.horizontal_axis_mm, 1.0, 0.02);
  EXPECT_LT((ball.center_mm - centre).norm(), 25.0);  // pushed back by the leaf layer, ~1-2 leaf depths
  // The general ellipsoid on the same ball: the spheroid's ratio is the better of the two.
  const EllipsoidFit general = FitEllipsoid(LeafySpheroidCap(centre, 500, 500, 12, 20000, rng));
  if (general.converged) {
    EXPECT_LE(std::abs(ball.vertical_axis_mm / ball.horizontal_axis_mm - 1.0),
              std::abs(general.axes_mm.minCoeff() / general.axes_mm.maxCoeff() - 1.0) + 1e-9);
  }
  // Options: the vertical must be a direction.
  SpheroidFitOptions bad;
  bad.up = Eigen::Vector3d::Zero();
  EXPECT_THROW(bad.Check(), Error);
  // Through the method table, by name.
  const SphereFitResult r = RunFitMethod("spheroid", LeafySpheroidCap(centre, 550, 450, 12, 5000, rng));
  ASSERT_TRUE(r.converged && r.Extra("vertical_axis_mm") && r.Extra("horizontal_axis_mm"));
  EXPECT_LT(*r.Extra("vertical_axis_mm"), *r.Extra("horizontal_axis_mm"));
}

}  // namespace
}  // namespace hedgefit::fitting
