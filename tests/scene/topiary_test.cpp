// Topiary found by height: the shape fits against synthetic shapes with known axes, the watershed
// against touching domes and a hedge row, and the finder against the real garden model of
// TrimBot2020 (Wageningen, the west half) and its annotated map.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <random>
#include <string>

#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"
#include "fitting/methods.hpp"
#include "fitting/shape_fit.hpp"
#include "pipeline/pipeline.hpp"
#include "scene/find_report.hpp"
#include "scene/finder.hpp"
#include "scene/scene_stages.hpp"
#include "scene/topiary.hpp"
#include "sim/scan.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::scene {
namespace {

// The part of a vertical-axis ellipsoid (semi-axes a, b, c; heading in degrees) that a sensor
// above sees: its surface above the ground (z = 0) and above its equator's lower half, sampled
// every `step` mm in the top view, with Gaussian noise along z.
std::vector<Eigen::Vector3d> SeenFromAbove(const Eigen::Vector3d& center, double a, double b, double c, double heading_deg,
                                           double noise_mm, double step, std::mt19937* rng) {
  std::normal_distribution<double> noise(0, noise_mm);
  std::vector<Eigen::Vector3d> out;
  const double th = heading_deg * M_PI / 180;
  for (double u = -a; u <= a; u += step) {
    for (double v = -b; v <= b; v += step) {
      const double q = 1 - (u / a) * (u / a) - (v / b) * (v / b);
      if (q <= 0) continue;
      const double z = center.z() + c * std::sqrt(q);
      if (z <= 0) continue;
      out.emplace_back(center.x() + u * std::cos(th) - v * std::sin(th), center.y() + u * std::sin(th) + v * std::cos(th),
                       z + noise(*rng));
    }
  }
  // Its sides below the equator, down to the ground, as a sensor at an angle sees them.
  for (double t = 0; t < 2 * M_PI; t += step / std::max(a, b)) {
    for (double w = std::max(-c, -center.z()); w < 0; w += step) {
      const double s = std::sqrt(1 - (w / c) * (w / c));
      const double u = a * s * std::cos(t), v = b * s * std::sin(t);
      out.emplace_back(center.x() + u * std::cos(th) - v * std::sin(th) + noise(*rng),
                       center.y() + u * std::sin(th) + v * std::cos(th) + noise(*rng), center.z() + w);
    }
  }
  return out;
}

// The noise is 5 mm on several hundred points: the axes are pinned to well under 1 %; 2 % is the
// issue's target for squat and oblate shapes.
TEST(FitTopiaryShape, AnOblateDomeSeenFromAbove) {
  std::mt19937 rng(1);
  const auto pts = SeenFromAbove({1000, 2000, 80}, 320, 320, 200, 0, 5, 20, &rng);
  const TopiaryShape s = FitTopiaryShape(pts, 0, 5);
  ASSERT_TRUE(s.converged);
  // Its centre is 80 mm above the ground, under 0.8 of its 200 mm vertical semi-axis: cut by it.
  EXPECT_EQ(s.shape, "dome");
  EXPECT_EQ(s.form, "oblate");
  EXPECT_NEAR(s.axes_mm.x(), 320, 0.02 * 320);
  EXPECT_NEAR(s.axes_mm.y(), 320, 0.02 * 320);
  EXPECT_NEAR(s.axes_mm.z(), 200, 0.02 * 200);
  EXPECT_NEAR(s.center_mm.x(), 1000, 5.0);
  EXPECT_NEAR(s.center_mm.y(), 2000, 5.0);
  EXPECT_NEAR(s.top_mm, 280, 6.0);
  EXPECT_LT(s.roughness_mm, 7.5);  // the injected 5 mm, and the radial residual's first-order error
}

TEST(FitTopiaryShape, AnEllipsoidWithItsHeading) {
  std::mt19937 rng(2);
  const auto pts = SeenFromAbove({-500, 300, 260}, 450, 280, 220, 30, 5, 20, &rng);
  const TopiaryShape s = FitTopiaryShape(pts, 0, 5);
  ASSERT_TRUE(s.converged);
  EXPECT_EQ(s.shape, "ellipsoid");
  EXPECT_NEAR(s.axes_mm.x(), 450, 0.02 * 450);
  EXPECT_NEAR(s.axes_mm.y(), 280, 0.02 * 280);
  EXPECT_NEAR(s.axes_mm.z(), 220, 0.02 * 220);
  EXPECT_NEAR(s.heading_deg, 30, 2.0);
}

// Asked for a round footprint (JudgeTopiary asks when a stretched one is not covered), the same
// ellipsoid's points get a circle: a spheroid or a ball, its semi-axis between the two it has
// (a circle through a 450 x 280 mm outline lies within them), never an ellipsoid or a box.
TEST(FitTopiaryShape, ARoundFootprintWhenAsked) {
  std::mt19937 rng(2);
  const auto pts = SeenFromAbove({-500, 300, 260}, 450, 280, 220, 30, 5, 20, &rng);
  const TopiaryShape s = FitTopiaryShape(pts, 0, 5, 0, 800, false, false, 0, true);
  ASSERT_TRUE(s.converged);
  EXPECT_TRUE(s.family == "spheroid" || s.family == "ball") << s.family;
  EXPECT_DOUBLE_EQ(s.axes_mm.x(), s.axes_mm.y());
  EXPECT_GT(s.axes_mm.x(), 280);
  EXPECT_LT(s.axes_mm.x(), 450);
}

TEST(FitTopiaryShape, ABallStandingFreeIsABall) {
  std::mt19937 rng(3);
  const auto pts = SeenFromAbove({0, 0, 500}, 400, 400, 400, 0, 5, 20, &rng);
  const TopiaryShape s = FitTopiaryShape(pts, 0, 5);
  ASSERT_TRUE(s.converged);
  EXPECT_EQ(s.shape, "ball");  // BIC prefers four parameters when the other two add nothing
  EXPECT_NEAR(s.axes_mm.x(), 400, 0.01 * 400);
  EXPECT_NEAR(s.center_mm.z(), 500, 5.0);
}

// The finder asks whether any family is smooth enough (max_spread_mm: its max_roughness times the
// ground's noise), not only the one the criterion prefers. On a free ball the criterion takes the
// ball, and the spheroid and ellipsoid, with more parameters, fit its 5 mm noise a little more
// closely: a bound just under the ball's spread must choose one of them and keep within it; a
// bound none reaches leaves the criterion's choice as it was.
TEST(FitTopiaryShape, TheClassIsChosenAmongTheFamiliesSmoothEnough) {
  std::mt19937 rng(1);
  const auto pts = SeenFromAbove({0, 0, 500}, 400, 400, 400, 0, 5, 20, &rng);
  const TopiaryShape free = FitTopiaryShape(pts, 0, 5);
  ASSERT_TRUE(free.converged);
  ASSERT_EQ(free.family, "ball");
  const double bound = 0.99 * free.roughness_mm;
  const TopiaryShape smooth = FitTopiaryShape(pts, 0, 5, 0, 800, false, false, bound);
  ASSERT_TRUE(smooth.converged);
  EXPECT_NE(smooth.family, "ball");
  EXPECT_LE(smooth.roughness_mm, bound);
  EXPECT_NEAR(smooth.axes_mm.x(), 400, 0.01 * 400);  // the same ball, as a spheroid or ellipsoid
  const TopiaryShape none = FitTopiaryShape(pts, 0, 5, 0, 800, false, false, 0.5 * free.roughness_mm);
  EXPECT_EQ(none.family, "ball");
  EXPECT_DOUBLE_EQ(none.roughness_mm, free.roughness_mm);
}

// A prism standing on the lawn as a sensor above sees it: its flat top and its sides down to the
// lawn (or down to `sides_from` above it: a slab), every `step` mm, with Gaussian noise; a drum
// (radius a) or, with b > 0, a box of half-sides a x b turned by `heading_deg`.
std::vector<Eigen::Vector3d> PrismSeenFromAbove(const Eigen::Vector2d& c, double a, double b, double top, double heading_deg,
                                                double noise_mm, double step, std::mt19937* rng, double sides_from = 0) {
  std::normal_distribution<double> noise(0, noise_mm);
  const double th = heading_deg * M_PI / 180;
  auto at = [&](double u, double v, double z) {
    return Eigen::Vector3d(c.x() + u * std::cos(th) - v * std::sin(th) + noise(*rng),
                           c.y() + u * std::sin(th) + v * std::cos(th) + noise(*rng), z + noise(*rng));
  };
  std::vector<Eigen::Vector3d> out;
  const double hb = b > 0 ? b : a;
  for (double u = -a; u <= a; u += step) {
    for (double v = -hb; v <= hb; v += step) {
      if (b > 0 || u * u + v * v <= a * a) out.push_back(at(u, v, top));
    }
  }
  for (double z = sides_from + step; z < top; z += step) {
    if (b > 0) {
      for (double u = -a; u <= a; u += step) out.push_back(at(u, -b, z)), out.push_back(at(u, b, z));
      for (double v = -b; v <= b; v += step) out.push_back(at(-a, v, z)), out.push_back(at(a, v, z));
    } else {
      for (double t = 0; t < 2 * M_PI; t += step / a) out.push_back(at(a * std::cos(t), a * std::sin(t), z));
    }
  }
  return out;
}

// Topiary is clipped to drums and boxes too (the Wageningen garden's robot was tried on balls,
// cylinders and cuboids). With 5 mm noise on a few thousand points the sides and the top are
// pinned to well under a millimetre; 2 % is the bar. Such points lie 5-10 times farther
// from the best quadric than from their prism.
TEST(FitTopiaryShape, ADrumAndABoxAreTheirOwnShapes) {
  std::mt19937 rng(21);
  const TopiaryShape drum = FitTopiaryShape(PrismSeenFromAbove({100, -50}, 300, 0, 550, 0, 5, 20, &rng), 0, 5);
  ASSERT_TRUE(drum.converged);
  EXPECT_EQ(drum.shape, "cylinder");
  EXPECT_NEAR(drum.axes_mm.x(), 300, 0.02 * 300);
  EXPECT_NEAR(drum.top_mm, 550, 0.02 * 550);
  EXPECT_NEAR(drum.center_mm.x(), 100, 5.0);
  const TopiaryShape box = FitTopiaryShape(PrismSeenFromAbove({0, 0}, 350, 250, 450, 30, 5, 20, &rng), 0, 5);
  ASSERT_TRUE(box.converged);
  EXPECT_EQ(box.shape, "cuboid");
  EXPECT_NEAR(box.axes_mm.x(), 350, 0.02 * 350);
  EXPECT_NEAR(box.axes_mm.y(), 250, 0.02 * 250);
  EXPECT_NEAR(box.top_mm, 450, 0.02 * 450);
  EXPECT_NEAR(box.heading_deg, 30, 2.0);
  EXPECT_LT(box.roughness_mm, 2 * 5.0) << "a box's points lie on it within the noise";
}

// A cone clipped from yew or box (base radius 350 mm on the lawn, apex 900 mm up) as a sensor
// above and around sees it: its slanted side every 20 mm, with 5 mm of noise. As with the drum
// and the box, thousands of points pin the base and the apex to well under a millimetre; 2 % is
// the bar, and the spheroid through the same points lies several times farther from them.
TEST(FitTopiaryShape, AConeIsItsOwnShape) {
  std::mt19937 rng(29);
  std::normal_distribution<double> noise(0, 5);
  const double a = 350, height = 900;
  std::vector<Eigen::Vector3d> pts;
  for (double z = 20; z < height; z += 20) {
    const double r = a * (1 - z / height);
    for (double t = 0; t < 2 * M_PI; t += 20 / std::max(r, 20.0)) {
      pts.emplace_back(-200 + r * std::cos(t) + noise(rng), 150 + r * std::sin(t) + noise(rng), z + noise(rng));
    }
  }
  const TopiaryShape cone = FitTopiaryShape(pts, 0, 5);
  ASSERT_TRUE(cone.converged);
  EXPECT_EQ(cone.shape, "cone");
  EXPECT_NEAR(cone.axes_mm.x(), a, 0.02 * a);
  EXPECT_NEAR(cone.top_mm, height, 0.02 * height);
  EXPECT_NEAR(cone.center_mm.x(), -200, 5.0);
  EXPECT_GT(cone.walls_cone, 0.9);
}

// A bench's seat, a table's top: a slab 800 x 450 mm, 60 mm deep, its top 460 mm above the lawn,
// its points on its top and its edges as densely as the box's above. Its points lie on a box
// standing on the lawn as closely as a box's do, but that box's walls hold none of them half-way
// up (its top and edge fill 1 of 16 sectors' bands at most: none), and a clipped box is leafy
// to the ground. It may be a quadric (the finder's other tests judge those); it is no prism.
TEST(FitTopiaryShape, ASlabIsNoBox) {
  std::mt19937 rng(23);
  const TopiaryShape slab = FitTopiaryShape(PrismSeenFromAbove({0, 0}, 400, 225, 460, 20, 5, 20, &rng, 400), 0, 5);
  ASSERT_TRUE(slab.converged);
  EXPECT_NE(slab.shape, "cuboid");
  EXPECT_NE(slab.shape, "cylinder");
  EXPECT_LT(slab.walls_cuboid, 0.5);
  // The same box with its walls down to the lawn is one.
  const TopiaryShape box = FitTopiaryShape(PrismSeenFromAbove({0, 0}, 400, 225, 460, 20, 5, 20, &rng), 0, 5);
  EXPECT_EQ(box.shape, "cuboid");
  EXPECT_GT(box.walls_cuboid, 0.9);
}

// A flat spheroid (276 x 276 x 144 mm) on a stem, its underside 62 mm above the lawn, as a drone's
// photogrammetry sees it: its surface down to just below its rim (the normal at most 0.2 below
// the horizontal), each point seen from one of 9 stations 6 m up and 3 m apart and moved along
// that station's ray by 12 mm of noise. Seen from above, the footprint is pinned by where the
// points end, but the vertical semi-axis only by the curvature of the rim: the radial distance's
// bias under noise (second order in it) read it 4.1 mm long on average over these 8 draws
// (+2.9 %); refitted on the distance along the normal, 0.4 mm short. The mean of 8 independent
// draws has a standard error of about 0.8 mm (each draw's interval, 4-7 mm, is 1.96 of its own
// standard error); 2.5 mm is three of them. Each interval holds its draw's error but for one in
// 20, so at least 7 of the 8.
TEST(FitTopiaryShape, AFlatSpheroidsHeightIsNotBiasedByNoise) {
  const double a = 276, c = 144, lift = 206, noise = 12;
  double sum = 0;
  int held = 0;
  for (unsigned draw = 1; draw <= 8; ++draw) {
    std::mt19937 rng(draw);
    std::normal_distribution<double> n01(0, 1);
    std::uniform_int_distribution<int> station(-1, 1);
    std::vector<Eigen::Vector3d> pts;
    while (pts.size() < 3000) {
      const Eigen::Vector3d d = Eigen::Vector3d(n01(rng), n01(rng), n01(rng)).normalized();
      const Eigen::Vector3d on(a * d.x(), a * d.y(), c * d.z());
      const Eigen::Vector3d normal = on.cwiseQuotient(Eigen::Vector3d(a * a, a * a, c * c)).normalized();
      if (normal.z() < -0.2) continue;
      const Eigen::Vector3d p = on + Eigen::Vector3d(0, 0, lift);
      const Eigen::Vector3d ray = (p - Eigen::Vector3d(3000.0 * station(rng), 3000.0 * station(rng), 6000)).normalized();
      if (ray.dot(normal) > 0) continue;  // its back, hidden from that station
      pts.push_back(p + noise * n01(rng) * ray);
    }
    const TopiaryShape s = FitTopiaryShape(pts, 0, noise, 0, 800, true, true);
    ASSERT_TRUE(s.converged);
    EXPECT_NEAR(s.axes_mm.x(), a, 0.01 * a) << "draw " << draw;
    sum += s.axes_mm.z();
    held += std::abs(s.axes_mm.z() - c) <= s.axes_ci95_mm.z();
  }
  EXPECT_NEAR(sum / 8, c, 2.5);
  EXPECT_GE(held, 7);
}

// Each point pushed inward along the ellipsoid's normal by a leaf's depth below the clipped
// envelope: none for a share `clipped` (the shears' cut), exponential with mean `mu` for the rest.
void InALeafLayer(std::vector<Eigen::Vector3d>* pts, const Eigen::Vector3d& center, const Eigen::Vector3d& axes,
                  double clipped, double mu, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0, 1);
  std::exponential_distribution<double> depth(1 / mu);
  for (auto& p : *pts) {
    if (u(*rng) < clipped) continue;
    const Eigen::Vector3d d = p - center;
    const Eigen::Vector3d n = d.cwiseQuotient(axes.cwiseProduct(axes)).normalized();
    p -= depth(*rng) * n;
  }
}

// A dome 300 x 300 x 200 mm, its centre 60 mm above the lawn, seen from above with 5 mm noise,
// its points in a leaf layer: half on the cut, the rest 15 mm deep on average.
std::vector<Eigen::Vector3d> LeafyDome() {
  std::mt19937 rng(11);
  const Eigen::Vector3d center(0, 0, 60), axes(300, 300, 200);
  auto pts = SeenFromAbove(center, 300, 300, 200, 0, 5, 12, &rng);
  InALeafLayer(&pts, center, axes, 0.5, 15, &rng);
  return pts;
}

// A clipped dome's points lie in a leaf layer 0-60 mm deep (half of them on the cut, the rest
// 15 mm deep on average) with 5 mm noise: the surface through them is some 7 mm inside the
// envelope. Measured, the axes are the envelope's, to the 2 % the issue asks (4-6 mm here);
// the fit through all the points misses the horizontal semi-axes by more than 4 mm. Without
// the measured fit's trim (kTrimDeviations) the vertical one comes out 5.4 mm (2.7 %) long.
TEST(FitTopiaryShape, TheEnvelopeOfALeafyDomeIsWhereItsOuterLeavesEnd) {
  const auto pts = LeafyDome();
  const TopiaryShape through = FitTopiaryShape(pts, 0, 5, 0, 4000, true, false);
  const TopiaryShape measured = FitTopiaryShape(pts, 0, 5, 0, 4000, true, true);
  ASSERT_TRUE(through.converged && measured.converged);
  EXPECT_LT(through.axes_mm.x(), 300 - 4.0);  // the leaf layer is deeper than the target
  EXPECT_NEAR(measured.axes_mm.x(), 300, 0.02 * 300);
  EXPECT_NEAR(measured.axes_mm.z(), 200, 0.02 * 200);
  EXPECT_NEAR(measured.top_mm, 260, 0.02 * 200);
  // The offset is at most the layer's mean depth (7.5 mm) and some noise: the trimmed fit has
  // already left the deepest leaves out.
  EXPECT_GT(measured.envelope_offset_mm, 1.5);
  EXPECT_LT(measured.envelope_offset_mm, 12.0);
}

// A real shape's leaf layer is not the same all round: a side in the shade grows thicker between
// cuts. Here the leaves of one half (x > 0) lie 25 mm deep on average, a third of them on the cut;
// the other half's 5 mm, two thirds on the cut. The envelope's offset then depends on which part
// of the surface the points come from, and the axes' 95 % intervals must hold it: the block
// jackknife's refits each estimate their own offset. Without that (the surface's intervals
// alone) the truth lay outside them. The intervals stay narrow: 3 % of each axis at most.
TEST(FitTopiaryShape, TheAxesIntervalsHoldAnUnevenLeafLayer) {
  for (unsigned seed : {21u, 22u, 23u}) {
    std::mt19937 rng(seed);
    const Eigen::Vector3d center(0, 0, 60), axes(300, 300, 200);
    auto pts = SeenFromAbove(center, 300, 300, 200, 0, 5, 12, &rng);
    std::vector<Eigen::Vector3d> shaded, sunny;
    for (const auto& p : pts) (p.x() > 0 ? shaded : sunny).push_back(p);
    InALeafLayer(&shaded, center, axes, 1.0 / 3, 25, &rng);
    InALeafLayer(&sunny, center, axes, 2.0 / 3, 5, &rng);
    pts = shaded;
    pts.insert(pts.end(), sunny.begin(), sunny.end());
    const TopiaryShape s = FitTopiaryShape(pts, 0, 5, 0, 4000, true, true);
    ASSERT_TRUE(s.converged);
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(std::abs(s.axes_mm[k] - axes[k]), s.axes_ci95_mm[k]) << "seed " << seed << ", axis " << k;
      EXPECT_LT(s.axes_ci95_mm[k], 0.03 * axes[k]) << "seed " << seed << ", axis " << k;
    }
  }
}

// A drone's noise lies along its steep rays: vertical. A shape's sides, whose normals are level,
// then see little of it along their normal, where the lawn shows all of it. Here a flat spheroid
// 400 x 400 x 220 mm, its centre 60 mm above the lawn, on a 12 mm grid over its top and sides, in
// a leaf layer (half on the cut, the rest 12 mm deep on average) with 8 mm of noise along the
// vertical alone, 8 draws. With the noise held at the lawn's all round, the leaf layer's offset
// came out short and so did the horizontal semi-axes: by 2.75 mm (0.69 %) on average; with the
// noise's horizontal part fitted below the lawn's, by 0.9 mm. The draws' means scatter by about
// 0.3 mm, so 0.4 % (1.6 mm) tells the two apart. Every axis of every draw within the 2 %.
TEST(FitTopiaryShape, NoiseAlongSteepRaysIsNotTakenForLeavesOnTheSides) {
  const Eigen::Vector3d center(0, 0, 60), axes(400, 400, 220);
  double horizontal = 0;
  for (unsigned draw = 0; draw < 8; ++draw) {
    std::mt19937 rng(40 + draw);
    auto pts = SeenFromAbove(center, axes.x(), axes.y(), axes.z(), 0, 0, 12, &rng);
    InALeafLayer(&pts, center, axes, 0.5, 12, &rng);
    std::normal_distribution<double> vertical(0, 8);
    for (auto& p : pts) p.z() += vertical(rng);
    const TopiaryShape s = FitTopiaryShape(pts, 0, 8, 0, 4000, true, true);
    ASSERT_TRUE(s.converged);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.axes_mm[k], axes[k], 0.02 * axes[k]) << "draw " << draw << ", axis " << k;
    horizontal += (s.axes_mm.x() + s.axes_mm.y()) / 2 / 8;
  }
  EXPECT_NEAR(horizontal, axes.x(), 0.004 * axes.x());
}

// compare's fitters.shape knows no lawn, so the leaf layer's model estimates the noise too: the
// same envelope to the same 2 %.
TEST(FitTopiaryShape, TheEnvelopeWithTheNoiseUnknown) {
  const TopiaryShape s = FitTopiaryShape(LeafyDome(), 0, 0, 0, 4000, true, true);
  ASSERT_TRUE(s.converged);
  EXPECT_NEAR(s.axes_mm.x(), 300, 0.02 * 300);
  EXPECT_NEAR(s.axes_mm.z(), 200, 0.02 * 200);
  EXPECT_GT(s.envelope_offset_mm, 1.5);
}

// A bare surface (no leaf layer, 5 mm noise) has no envelope outside it: the offset stays
// within a fraction of the noise.
TEST(FitTopiaryShape, ABareShapeHasNoLeafLayer) {
  std::mt19937 rng(12);
  const auto pts = SeenFromAbove({0, 0, 250}, 320, 260, 210, 20, 5, 12, &rng);
  const TopiaryShape s = FitTopiaryShape(pts, 0, 5, 0, 4000, true, true);
  ASSERT_TRUE(s.converged);
  EXPECT_LT(s.envelope_offset_mm, 2.5);
  EXPECT_NEAR(s.axes_mm.z(), 210, 0.02 * 210);
}

GroundModel FlatGround(double noise_mm) {
  GroundModel g;
  g.origin_mm = {-5000, -5000};
  g.cell_mm = 250;
  g.nx = g.ny = 40;
  g.height_mm.assign(std::size_t(g.nx * g.ny), 0.f);
  g.observed.assign(std::size_t(g.nx * g.ny), 1);
  g.noise_mm = noise_mm;
  return g;
}

// A point put a known distance along a flat ellipsoid's normal is that far outside it: the
// distance is the exact one (the nearest point of the surface), not the radial distance
// projected on the normal, which on this shape is off by up to 4 mm at 40 mm out and 2.7 at
// 25 mm in (second order in the distance). Inside, the offsets stay within the
// smallest radius of curvature (c^2 / a = 38 mm), where the surface point is still the nearest.
TEST(DistanceOutside, IsTheDistanceAlongTheNormal) {
  fitting::ClippedShape s;
  s.family = "ellipsoid";
  s.center_mm = Eigen::Vector3d(400, -250, 120);
  s.axes_mm = Eigen::Vector3d(320, 230, 110);
  s.heading_deg = 35;
  const double th = s.heading_deg * M_PI / 180;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(th, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  double worst = 0;
  for (double lat = -1.4; lat <= 1.41; lat += 0.2) {
    for (double lon = 0; lon < 2 * M_PI; lon += 0.3) {
      const Eigen::Vector3d local(s.axes_mm.x() * std::cos(lat) * std::cos(lon), s.axes_mm.y() * std::cos(lat) * std::sin(lon),
                                  s.axes_mm.z() * std::sin(lat));
      const Eigen::Vector3d normal = turn * local.cwiseQuotient(s.axes_mm.cwiseAbs2()).normalized();
      const Eigen::Vector3d on = s.center_mm + turn * local;
      for (double d : {-25.0, -5.0, 0.0, 5.0, 40.0, 150.0}) {
        worst = std::max(worst, std::abs(fitting::DistanceOutside(s, on + d * normal) - d));
      }
    }
  }
  EXPECT_LT(worst, 1e-6);
}

// Two domes of a bed that touch (their footprints meet) part at the valley between them; a hedge
// row 3 m long with a lumpy ridge stays one object.
TEST(SplitByHeight, TouchingDomesPartAHedgeRowDoesNot) {
  std::mt19937 rng(4);
  std::vector<Eigen::Vector3d> pts = SeenFromAbove({0, 0, 50}, 300, 300, 300, 0, 5, 20, &rng);
  for (const auto& p : SeenFromAbove({600, 0, 50}, 300, 300, 300, 0, 5, 20, &rng)) pts.push_back(p);
  std::normal_distribution<double> lump(0, 15);
  for (double x = -1500; x <= 1500; x += 20) {
    for (double y = -250; y <= 250; y += 20) {
      pts.emplace_back(x, 2000 + y, 600 * std::sqrt(1 - (y / 260) * (y / 260)) + lump(rng));
    }
  }
  std::vector<std::size_t> idx(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) idx[i] = i;
  const auto parts = SplitByHeight(pts, idx, FlatGround(5), 40, TopiaryOptions{});
  std::vector<std::size_t> sizes;
  int domes = 0, rows = 0;
  for (const auto& p : parts) {
    if (p.points.size() < 50) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t i : p.points) mean += pts[i];
    mean /= double(p.points.size());
    if (mean.y() > 1000) ++rows;
    else ++domes;
  }
  EXPECT_EQ(domes, 2);
  EXPECT_EQ(rows, 1);
}

// A dome (semi-axes 300 x 300 x 450 mm, as the real garden's) with a lumpy bank of lower foliage
// against its side (a tree crown's low edge, as at the real garden's sixth topiary): the ridges
// between them stand above merge_saddle of the bank's lumps, so the watershed joins them, and the
// joined object's fitted shape is spread over both, its footprint too thinly held. Peeled off
// lump by lump (FindTopiary, step 5), the dome is found and the bank is not. The bank's points
// by the dome's foot stay in its basin and pull its sides in: 10 mm on the centre and 3 % on the
// axes, against the 5 mm noise's 1 % when it stands alone (FitTopiaryShape's tests).
TEST(FindTopiary, ADomeWithANeighbourLeaningOnItIsTakenApart) {
  std::mt19937 rng(6);
  std::vector<Eigen::Vector3d> pts = SeenFromAbove({0, 0, 0}, 300, 300, 450, 0, 5, 20, &rng);
  const std::size_t dome = pts.size();
  std::normal_distribution<double> lump(0, 25);
  std::uniform_real_distribution<double> pick(0, 1);
  // The neighbour: a lumpy bank of foliage 400 x 900 mm beside the dome, across the line between
  // them (a tree crown's low edge), 300 mm high, a third of it missing (a reconstruction's holes).
  auto in_bank = [](double x, double y, double grow) {
    const double u = (x + 480) / (180 + grow), v = y / (450 + grow);
    return u * u + v * v < 1;
  };
  for (double x = -700; x <= -200; x += 20) {
    for (double y = -500; y <= 500; y += 20) {
      if (!in_bank(x, y, 0) || pick(rng) < 0.15) continue;
      pts.emplace_back(x, y, std::max(0.0, 300 + lump(rng)));
    }
  }
  std::vector<std::size_t> idx(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) idx[i] = i;
  std::normal_distribution<double> lawn_noise(0, 5);
  for (double x = -2500; x <= 2500; x += 20) {
    for (double y = -2500; y <= 2500; y += 20) {
      if (std::hypot(x, y) < 320 || in_bank(x, y, 20)) continue;
      pts.emplace_back(x, y, lawn_noise(rng));
    }
  }
  TopiaryOptions o;
  // The watershed joins them: one object holds points of both, and keeps what it merged.
  bool joined = false;
  for (const auto& part : SplitByHeight(pts, idx, FlatGround(5), 40, o)) {
    const bool both = std::any_of(part.points.begin(), part.points.end(), [&](std::size_t i) { return i < dome; }) &&
                      std::any_of(part.points.begin(), part.points.end(), [&](std::size_t i) { return i >= dome; });
    joined = joined || (both && part.halves.size() == 2);
  }
  ASSERT_TRUE(joined);
  const auto found = FindTopiary(pts, idx, FlatGround(5), 20, o);
  int topiary = 0;
  std::string refused;
  for (const auto& c : found) {
    if (!c.topiary) refused += c.reason + "; ";
    if (!c.topiary) continue;
    ++topiary;
    EXPECT_NEAR(c.shape.center_mm.x(), 0, 10);
    EXPECT_NEAR(c.shape.center_mm.y(), 0, 10);
    EXPECT_NEAR(c.shape.axes_mm.x(), 300, 0.03 * 300);
    EXPECT_NEAR(c.shape.top_mm, 450, 0.03 * 450);
  }
  EXPECT_EQ(topiary, 1) << refused;
}

// The cover is read about the fitted shape, not on a grid fixed to the cloud's axes: the same
// dome, with a hole in its top, turned and moved, covers the same share of its footprint. The
// hole (r 120 mm, off centre) leaves 1 - ((r' - reach) / 240)^2 of the footprint within 0.8 of
// its semi-axes (240 mm) covered, where reach = cell / sqrt(pi) = 22.6 mm for 20 mm spacing and
// r' is where the points about the hole begin: 120-140 mm on a 20 mm lattice, 0.80-0.84. A grid
// fixed to the cloud's axes moved the share by 0.023 from pose to pose here (0.79-0.81); the
// discs move it by under 0.01.
TEST(FindTopiary, TheCoverIsTheSameHoweverTheCloudIsTurnedOrMoved) {
  std::mt19937 rng(11);
  std::vector<Eigen::Vector3d> dome;
  for (const auto& p : SeenFromAbove({0, 0, 0}, 300, 300, 400, 0, 3, 20, &rng)) {
    if (std::hypot(p.x() - 100, p.y()) > 120) dome.push_back(p);
  }
  std::normal_distribution<double> lawn_noise(0, 3);
  std::vector<Eigen::Vector3d> lawn;
  for (double x = -2000; x <= 2000; x += 20) {
    for (double y = -2000; y <= 2000; y += 20) {
      if (std::hypot(x, y) > 320) lawn.emplace_back(x, y, lawn_noise(rng));
    }
  }
  std::vector<double> cover;
  for (const auto& [deg, shift] : std::vector<std::pair<double, Eigen::Vector2d>>{
           {0, {0, 0}}, {17, {0, 0}}, {30, {7.3, -11.1}}, {45, {0, 0}}, {137, {1234.5, -2345.6}}, {200, {3.3, 9.9}}}) {
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    std::vector<Eigen::Vector3d> pts;
    for (const auto& p : dome) pts.push_back(turn * p + Eigen::Vector3d(shift.x(), shift.y(), 0));
    std::vector<std::size_t> idx(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) idx[i] = i;
    for (const auto& p : lawn) pts.push_back(turn * p + Eigen::Vector3d(shift.x(), shift.y(), 0));
    const auto found = FindTopiary(pts, idx, FlatGround(3), 20, TopiaryOptions{});
    ASSERT_EQ(found.size(), 1u) << deg << " deg";
    cover.push_back(found[0].covered);
    EXPECT_NEAR(found[0].covered, 0.82, 0.025) << deg << " deg";
  }
  const auto [lo, hi] = std::minmax_element(cover.begin(), cover.end());
  EXPECT_LT(*hi - *lo, 0.015) << "the cover depends on how the cloud lies: " << ::testing::PrintToString(cover);
}

// A clipped dome seen from above on its lawn, every point on a grid of `step` mm (the cloud's
// spacing), and the finder's verdict on it.
TopiaryCandidate DomeOnItsLawn(double step) {
  std::mt19937 rng(5);
  std::vector<Eigen::Vector3d> pts = SeenFromAbove({0, 0, 0}, 300, 300, 300, 0, 3, step, &rng);
  std::vector<std::size_t> idx(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) idx[i] = i;
  std::normal_distribution<double> lawn_noise(0, 3);
  for (double x = -2000; x <= 2000; x += step) {
    for (double y = -2000; y <= 2000; y += step) {
      if (std::hypot(x, y) > 320) pts.emplace_back(x, y, lawn_noise(rng));
    }
  }
  const auto found = FindTopiary(pts, idx, FlatGround(3), step, TopiaryOptions{});
  EXPECT_EQ(found.size(), 1u) << step << " mm";
  return found.empty() ? TopiaryCandidate{} : found[0];
}

// The cover is counted in cells twice the spacing across, and its lower 95 % bound must reach
// 0.7: a dome 600 mm across sampled every 20 mm holds about 60 cells on the inner 0.8 of its
// footprint and is found; every 80 mm, 4 cells, whose bound cannot pass 4 / (4 + 1.96^2) = 0.51
// even fully covered. Such a dome is not refused either: every other test passes, so it is
// undecided and says what spacing would decide (under 80 mm: about 9 cells fully covered bound
// 0.7, so 80 * sqrt(4 / 9) ~ 53 mm). The real garden's test below has none undecided at its own
// density: its roses and fence plants are refused on their cover's estimate or other tests.
TEST(FindTopiary, TooFewPointsToShowASolidTopIsUndecidedNotRefused) {
  const TopiaryCandidate dense = DomeOnItsLawn(20);
  EXPECT_TRUE(dense.topiary) << dense.reason;
  EXPECT_FALSE(dense.undecided);
  const TopiaryCandidate sparse = DomeOnItsLawn(80);
  EXPECT_FALSE(sparse.topiary);
  EXPECT_TRUE(sparse.undecided) << sparse.reason;
  EXPECT_GE(sparse.covered, 0.7) << sparse.reason;
  EXPECT_GT(sparse.decides_at_spacing_mm, 20);
  EXPECT_LT(sparse.decides_at_spacing_mm, 80);
  EXPECT_NE(sparse.reason.find("would decide"), std::string::npos) << sparse.reason;
}

// A bed scanned by the simulated drone (bench find's aerial sensor, 5 mm noise at 5 m).
cloud::PointCloud FromADrone(const sim::ScanScene& scene, std::uint64_t seed) {
  sim::ScanOptions so;
  so.sensor = sim::Sensor::kAerial;
  so.seed = seed;
  so.noise_mm = 5;
  fitting::QuietSolverWarnings();
  return sim::ScanGarden(scene, so);
}

// A simulated bed of squat topiary (sim::RandomTopiaryBed, seed 1: a tuning seed) seen from
// above only by a drone's photogrammetry: every shape found, as the right family, nothing else
// (the rose between them, the low box hedge row, the post) called topiary.
TEST(FindHedges, EveryTopiaryOfABedSeenFromAbove) {
  const sim::ScanScene scene = sim::RandomTopiaryBed(1);
  const FindResult r = FindHedges(FromADrone(scene, 1));
  std::vector<bool> used(r.objects.size(), false);
  int inside = 0, stated = 0;
  // The bed's free ball is the ball search's.
  for (const auto& b : scene.balls) {
    for (std::size_t k = 0; k < r.objects.size(); ++k) {
      if (r.objects[k].ball && (r.objects[k].fit.sphere.center_mm - b.center_mm).norm() < 0.1 * b.radius_mm) used[k] = true;
    }
  }
  for (const auto& t : scene.topiary) {
    int pick = -1;
    double best = 0.5 * t.axes_mm.y();
    for (std::size_t k = 0; k < r.objects.size(); ++k) {
      if (!r.objects[k].topiary || !r.objects[k].shape || used[k]) continue;
      const double d = (r.objects[k].shape->center_mm.head<2>() - t.center_mm.head<2>()).norm();
      if (d < best) best = d, pick = int(k);
    }
    ASSERT_GE(pick, 0) << "missed the topiary of semi-axes " << t.axes_mm.transpose();
    used[std::size_t(pick)] = true;
    const TopiaryShape& s = *r.objects[std::size_t(pick)].shape;
    // An elliptic one (a != b) is an ellipsoid; a round one a spheroid or a dome.
    EXPECT_EQ(s.family == "ellipsoid", t.axes_mm.x() != t.axes_mm.y()) << s.shape << " for " << t.axes_mm.transpose();
    // The fit follows the mean leaf: beams stop on the envelope for 40-65 % of them, else on
    // average a third of the 15-40 mm leaf layer deep, so the fitted surface lies up to about
    // 0.6 * 40 / 3 = 8 mm inside the envelope, plus the 5 mm noise's share: 10 mm, with 1 % for
    // the radial residual's first-order error on flattened shapes.
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.axes_mm[k], t.axes_mm[k], 10 + 0.01 * t.axes_mm[k]) << "axis " << k;
    for (int k = 0; k < 3; ++k) inside += std::abs(s.axes_mm[k] - t.axes_mm[k]) <= s.axes_ci95_mm[k], ++stated;
    EXPECT_TRUE(s.jackknifed);
  }
  // The stated 95 % intervals (the block jackknife's, where wider) hold most of the truth. The
  // sandwich interval alone held about a third (11 of 30 on the held-back beds 101-102), the
  // jackknifed ones 26 of 30 there. The mean leaf's 1-2 mm bias inside the envelope is in none of
  // them, so not 95 % either: at least 60 %, which the sandwich's third fails.
  EXPECT_GE(inside, 0.6 * stated) << inside << " of " << stated;
  for (std::size_t k = 0; k < r.objects.size(); ++k) {
    EXPECT_FALSE(r.objects[k].topiary && !used[k]) << "object " << r.objects[k].id << " (" << r.objects[k].verdict
                                                   << ") is no topiary of the bed";
  }
}

// Two beds held back until they showed this: a flat spheroid seen from above beside a
// neighbour, read by the ball search as the cap of a ball far larger than it.
//  - Bed 203: a 350 x 350 x 213 mm spheroid stands 41 mm from a dome, whose near side a 444 mm
//    ball fits; the ball kept that crescent and stayed ahead of the spheroid (centre 234 mm off).
//    Each point now goes to the ball whose surface it lies nearer (NearestSurfaces).
//  - Bed 205: a 400 x 400 x 210 mm spheroid touches a dome that is no ball, so no ball's surface
//    claims that dome's near side: it was read as a 560 mm ball (centre 341 mm off). The points a
//    shape found by height lies on now leave the ball before its shape is judged
//    (WithoutNeighboursSides).
// Its axes to 2 %, the target, which the 5 mm noise and its leaf layer allow (the
// simulated beds' mean error is 0.2-0.6 %).
void ExpectTheFlatSpheroidMeasured(std::uint64_t seed, double vertical_mm) {
  SCOPED_TRACE("bed " + std::to_string(seed));
  const sim::ScanScene scene = sim::RandomTopiaryBed(seed);
  const FindResult r = FindHedges(FromADrone(scene, seed));
  const auto flat = std::find_if(scene.topiary.begin(), scene.topiary.end(),
                                 [&](const sim::ScanSpheroid& t) { return std::abs(t.axes_mm.z() - vertical_mm) < 1; });
  ASSERT_NE(flat, scene.topiary.end()) << "the bed no longer holds the flat spheroid";
  const FoundObject* found = nullptr;
  for (const auto& o : r.objects) {
    if (o.topiary && o.shape && (o.shape->center_mm.head<2>() - flat->center_mm.head<2>()).norm() < 100) found = &o;
  }
  ASSERT_NE(found, nullptr) << "no shape within 100 mm of the flat spheroid's centre";
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(found->shape->axes_mm[k], flat->axes_mm[k], 0.02 * flat->axes_mm[k]) << "axis " << k;
}

TEST(FindHedges, AFlatSpheroidBesideADomeIsNoCapOfABall) { ExpectTheFlatSpheroidMeasured(203, 213); }

TEST(FindHedges, AFlatSpheroidTouchingADomeIsNoCapOfABall) { ExpectTheFlatSpheroidMeasured(205, 210); }

// `scene` scanned by `sensor` (5 mm of noise at 5 m) and searched with find's defaults.
FindResult ScanAndFind(const sim::ScanScene& scene, sim::Sensor sensor, std::uint64_t seed) {
  sim::ScanOptions so;
  so.sensor = sensor;
  so.seed = seed;
  so.noise_mm = 5;
  fitting::QuietSolverWarnings();
  return FindHedges(sim::ScanGarden(scene, so));
}

// A dome the lawn cuts just below its equator (centre 85 mm above it), seen by a ring of cameras
// 8-9 m away (a bed's): the upper three quarters of its height, on which it is judged, are its
// upper half alone, whose centre's height and vertical semi-axis trade against each other.
// Measured on those alone, it read 2.5-10.4 mm tall with its centre up to 7.4 mm low over seeds
// 11-16 (two of the first four beyond 2 %); with its sides down to the lawn as well, 0.6-4.5 mm
// tall, within the 2 %. The noise (5 mm at 5 m, about 9 mm here) and the 20 mm leaf layer
// (half the rays stop on the envelope, the rest a third of it deep on average) leave the mean leaf
// 1-4 mm inside the envelope, which the leaf layer's offset mostly takes back: 2 % of 260 mm is
// 5.2 mm.
TEST(FindHedges, ADomeCutNearItsEquatorIsMeasuredWithItsSides) {
  for (std::uint64_t seed : {11u, 12u, 13u, 14u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    sim::ScanScene scene;
    scene.extent_mm = {9000, 7000};
    scene.ground.bump_mm = 0;
    sim::ScanSpheroid dome;
    dome.axes_mm = {340, 340, 260};
    dome.center_mm = {4500, 3500, 85};
    dome.shell_mm = 20;
    dome.clipped_share = 0.5;
    scene.topiary.push_back(dome);
    const FindResult r = ScanAndFind(scene, sim::Sensor::kPhotogrammetry, seed);
    const FoundObject* found = nullptr;
    for (const auto& o : r.objects) {
      if (o.topiary && o.shape && (o.shape->center_mm.head<2>() - dome.center_mm.head<2>()).norm() < 100) found = &o;
    }
    ASSERT_NE(found, nullptr) << "the dome was not found";
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(found->shape->axes_mm[k], dome.axes_mm[k], 0.02 * dome.axes_mm[k]) << "axis " << k;
    EXPECT_NEAR(found->shape->center_mm.z(), dome.center_mm.z(), 0.02 * dome.axes_mm.z());
  }
}

// A box hedge row 3.6 m long with a gap of 80 mm near its end (a dead plant, a path) leaves a
// piece 0.77 m long, as wide and as high as the row, that on its own passes for a clipped box:
// the height model parts the two at the gap. It is the row's end, not topiary. A dome standing
// 80 mm off the row's other end (round: nothing to continue the row in) is still found. Seen
// from the drone, 5 mm of noise at 5 m, seeds 21-28; the piece was called a cuboid before
// RefuseRowEnds, and on seeds 22, 24 and 25 while RefuseRowEnds read the row's fitted shape (the
// row joined to the dome fits one as wide as the dome) instead of the row's points beside it.
TEST(FindHedges, ARowsEndPartedAtAGapIsNotTopiary) {
  for (std::uint64_t seed = 21; seed <= 28; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    sim::ScanScene scene;
    scene.extent_mm = {9000, 7000};
    scene.ground.bump_mm = 0;
    sim::ScanBox row, end;
    row.min_mm = {1500, 5200, -100}, row.max_mm = {5100, 5660, 420};
    end.min_mm = {5180, 5200, -100}, end.max_mm = {5950, 5660, 420};
    row.shell_mm = end.shell_mm = 40;
    scene.boxes = {row, end};
    sim::ScanSpheroid dome;
    dome.axes_mm = {300, 300, 330};
    dome.center_mm = {1120, 5430, 80};
    scene.topiary.push_back(dome);
    const FindResult r = ScanAndFind(scene, sim::Sensor::kAerial, seed);
    bool dome_found = false;
    for (const auto& o : r.objects) {
      if (!o.topiary) continue;
      const Eigen::Vector2d c = o.shape ? o.shape->center_mm.head<2>() : o.fit.sphere.center_mm.head<2>();
      if ((c - dome.center_mm.head<2>()).norm() < 100) {
        dome_found = true;
      } else {
        ADD_FAILURE() << "called topiary at " << c.transpose() << ": " << o.verdict;
      }
    }
    EXPECT_TRUE(dome_found);
  }
}

// A row parted at both ends: the drone's bed of seed 102 (`bench find --beds`, a held-back seed
// that is no longer unseen for false objects, docs/accuracy.md) holds a box hedge row 3.6 m long
// that the height model parts into its two ends and its middle. The middle's shape fit is a round
// one 2.2 m across; a row known by its fitted footprint was then no row, and when find began to
// read its points in an order of its own the west end passed as a cuboid. Known by its points'
// spread, the row refuses its end. Every topiary of the bed is still found (the scoring is the
// bench's: within 3 m of the row's centre, anything else called topiary is a false one).
TEST(FindHedges, ARowWhoseMiddleFitsRoundStillRefusesItsEnds) {
  const sim::ScanScene scene = sim::RandomTopiaryBed(102);
  const FindResult r = ScanAndFind(scene, sim::Sensor::kAerial, 102);
  ASSERT_FALSE(scene.boxes.empty());
  int found = 0;
  for (const auto& o : r.objects) {
    if (!o.topiary) continue;
    const Eigen::Vector2d c = o.shape ? o.shape->center_mm.head<2>() : o.fit.sphere.center_mm.head<2>();
    bool topiary = false, ball = false;
    for (const auto& t : scene.topiary) topiary |= (c - t.center_mm.head<2>()).norm() < 150;
    for (const auto& b : scene.balls) ball |= (c - b.center_mm.head<2>()).norm() < 150;  // the free ball
    found += topiary;
    if (!topiary && !ball) ADD_FAILURE() << "called topiary at " << c.transpose() << ": " << o.verdict;
  }
  EXPECT_EQ(found, int(scene.topiary.size()));
}

// The real garden's topiary that `find` reports within 200 mm (top view) of the map's centres,
// and how many other objects it calls topiary, with the cloud turned by `turn` (the map with it)
// first; *r is the result.
int FoundInTheWestHalf(const Eigen::Matrix3d& turn, int* other, FindResult* r) {
  cloud::PointCloud c = cloud::ReadCloud(hedgefit::testing::DataPath("gardens/wageningen_west/garden_west.ply"));
  const double scale = cloud::GuessScale(c);
  EXPECT_EQ(scale, 1000.0) << "the garden is in metres";
  for (auto& p : c.points_mm) p = (turn.cast<float>() * p) * float(scale);
  fitting::QuietSolverWarnings();
  *r = FindHedges(c);
  std::ifstream in(hedgefit::testing::DataPath("gardens/wageningen_west/objects.json"));
  const auto map = nlohmann::json::parse(in);
  std::vector<Eigen::Vector2d> truth;
  for (const auto& o : map["objects"]) {
    if (o["label"].get<std::string>().rfind("Topiary", 0) == 0) {
      const Eigen::Vector3d at(o["position_m"][0].get<double>(), o["position_m"][1].get<double>(), o["position_m"][2].get<double>());
      truth.push_back(1000 * (turn * at).head<2>());
    }
  }
  EXPECT_EQ(truth.size(), 6u);
  std::vector<bool> used(r->objects.size(), false);
  int found = 0;
  for (const auto& t : truth) {
    for (std::size_t k = 0; k < r->objects.size(); ++k) {
      if (!r->objects[k].topiary || used[k]) continue;
      // In the cloud's frame, as the map is.
      if ((r->objects[k].fit.sphere.center_mm.head<2>() - t).norm() < 200) {
        used[k] = true, ++found;
        break;
      }
    }
  }
  *other = 0;
  for (std::size_t k = 0; k < r->objects.size(); ++k) *other += r->objects[k].topiary && !used[k];
  for (std::size_t k = 0; k < r->objects.size(); ++k) {
    if (!used[k]) r->objects[k].topiary = false;  // what the caller checks next is the map's
  }
  return found;
}

// The real garden: TrimBot2020's model of its Wageningen test garden (west half) and the
// project's own annotated map. The target is all 6 topiary within 200 mm of their
// annotated centres (top view) and at most 1 other object called topiary. The sixth is found only
// once the watershed's join to the foliage beside it is undone (FindTopiary's split).
TEST(RealData, TopiaryOfTheWageningenGardenWestHalf) {
  HEDGEFIT_REQUIRE_DATA("gardens/wageningen_west/garden_west.ply");
  int other = 0;
  FindResult r;
  EXPECT_EQ(FoundInTheWestHalf(Eigen::Matrix3d::Identity(), &other, &r), 6);
  EXPECT_LE(other, 1) << "roses, box hedges, trees, fences or the bench called topiary";
  // At its own density nothing here is too sparse to judge.
  for (const auto& o : r.objects) EXPECT_FALSE(o.undecided) << o.id << ": " << o.reason;
  // Topiary in this garden are squat: 0.35-0.5 m tall, 0.55-0.9 m across (the map's extents).
  for (const auto& o : r.objects) {
    if (!o.topiary) continue;
    ASSERT_TRUE(o.shape.has_value()) << o.id << ": every topiary here is found by height";
    const auto& s = *o.shape;
    EXPECT_GT(2 * s.axes_mm.y(), 400);
    EXPECT_LT(2 * s.axes_mm.x(), 1000);
    EXPECT_GT(s.top_mm, 200);
    EXPECT_LT(s.top_mm, 550);
  }
}

// The same half with its points in another order (a shuffle of the file, as another exporter or
// a filter that sorts would leave it): the cloud's spacing, which the thresholds scale with, was
// read from every 56th point by its place in the file, 24.4, 24.7 or 25.3 mm by the order where
// all points' median is 24.7, and one shuffle lost the topiary at (6.77, -2.44) m. Then the same
// six came back with centres within 1 mm (sums taken in the file's order round apart); now, with
// the points put in an order of their own before any step, the same six to the bit.
TEST(RealData, TheWestHalfInAnotherOrderKeepsItsTopiary) {
  HEDGEFIT_REQUIRE_DATA("gardens/wageningen_west/garden_west.ply");
  const cloud::PointCloud c = cloud::ReadCloud(hedgefit::testing::DataPath("gardens/wageningen_west/garden_west.ply"));
  std::vector<std::size_t> order(c.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  fitting::QuietSolverWarnings();
  auto topiary = [](const cloud::PointCloud& cloud) {
    const double scale = cloud::GuessScale(cloud);
    cloud::PointCloud mm = cloud;
    for (auto& p : mm.points_mm) p *= float(scale);
    std::vector<std::pair<std::string, Eigen::Vector3d>> out;
    for (const auto& o : FindHedges(mm).objects) {
      if (o.topiary && o.shape) out.emplace_back(o.shape->family, o.shape->center_mm);
    }
    return out;
  };
  const auto as_read = topiary(c);
  EXPECT_EQ(as_read.size(), 6u);
  for (const std::uint64_t seed : {1u, 2u}) {
    std::mt19937_64 rng(seed);
    std::shuffle(order.begin(), order.end(), rng);
    cloud::PointCloud shuffled;
    for (const std::size_t i : order) shuffled.points_mm.push_back(c.points_mm[i]);
    shuffled.Flatten();
    const auto again = topiary(shuffled);
    ASSERT_EQ(again.size(), as_read.size()) << "shuffle " << seed;
    for (std::size_t k = 0; k < again.size(); ++k) {
      EXPECT_EQ(again[k].first, as_read[k].first) << "shuffle " << seed << ", topiary " << k + 1;
      EXPECT_EQ(again[k].second, as_read[k].second) << "shuffle " << seed << ", topiary " << k + 1;
    }
  }
}

// The same half turned about the vertical: the height model's grid falls differently on the
// points, and the sparsest topiary (380 points, 60 mm of relief) keeps a few of its neighbour's
// leaves. Turned 200 degrees, an ellipsoid stretched towards them (its footprint 65 % covered)
// lost it, until a stretched footprint the points do not cover gave way to a round one
// (JudgeTopiary); turned 30 degrees it is found either way. Not asserted, as it is still lost:
// turned 137 degrees, or tilted 2 degrees, where the watershed gives it another part (the note of
// 2026-11-30, scripts/find_perturbed.py).
TEST(RealData, TheWestHalfTurnedKeepsItsTopiary) {
  HEDGEFIT_REQUIRE_DATA("gardens/wageningen_west/garden_west.ply");
  const std::vector<std::pair<const char*, Eigen::Matrix3d>> turns = {
      {"turned 30 degrees", Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix()},
      {"turned 200 degrees", Eigen::AngleAxisd(200 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix()}};
  for (const auto& [name, turn] : turns) {
    int other = 0;
    FindResult r;
    EXPECT_EQ(FoundInTheWestHalf(turn, &other, &r), 6) << name;
    EXPECT_LE(other, 1) << name;
  }
}

// The same half turned 5, 15 and 45 degrees: `find` called 1, 3 and 1 balls none of which is in
// the map (a blob by one low fence, pieces along another), their points lying a mean 12-44 %
// of their radii under their envelopes, where a clipped ball's leaves lie within 7.4 % (the
// simulated balls and the real Velodyne sphere: FindOptions::max_leaf_depth). No ball now, and
// the six topiary kept. Turned 10, 55, 75 or 100 degrees, the blob by the one fence (3.0-7.7 %)
// and a piece along the other (9.8 %) passed that test: the next one.
TEST(RealData, TheWestHalfTurnedHoldsNoBallItsLeavesDoNotBound) {
  HEDGEFIT_REQUIRE_DATA("gardens/wageningen_west/garden_west.ply");
  for (const double deg : {5.0, 15.0, 45.0}) {
    int other = 0;
    FindResult r;
    EXPECT_EQ(FoundInTheWestHalf(Eigen::AngleAxisd(deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                                 &other, &r),
              6)
        << deg << " degrees";
    EXPECT_EQ(r.Balls(), 0u) << deg << " degrees";
    EXPECT_EQ(other, 0) << deg << " degrees";
  }
}

// The same half turned 10, 55, 75, 100 and 200 degrees: the blob by the low fence (r 277-281 mm),
// a piece along the other fence (r 216 mm) and, turned 200 degrees, a fence piece read as a dome
// (r 387 mm) were balls whose leaves lie close under their envelopes, but a sensor above saw the
// lawn under them or into them, and nothing on their tops (FindHedges judges a cloud without
// viewpoints as seen from above: rays through a ball's core end on its top). No ball now. Turned
// 100 degrees, a spheroid between two fences is still called topiary and the sparsest topiary is
// lost (the note of 2026-12-02), so that turn asserts the balls alone.
TEST(RealData, TheWestHalfTurnedHoldsNoBallSeenThroughFromAbove) {
  HEDGEFIT_REQUIRE_DATA("gardens/wageningen_west/garden_west.ply");
  for (const double deg : {10.0, 55.0, 75.0, 100.0, 200.0}) {
    int other = 0;
    FindResult r;
    const int found =
        FoundInTheWestHalf(Eigen::AngleAxisd(deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix(), &other, &r);
    EXPECT_EQ(r.Balls(), 0u) << deg << " degrees";
    if (deg == 100.0) continue;
    EXPECT_EQ(found, 6) << deg << " degrees";
    EXPECT_EQ(other, 0) << deg << " degrees";
  }
}

// A simulated bed (sim::RandomTopiaryBed) as `sensor` scans it, with its range noise, and the
// stations it stood at.
struct ScannedBed {
  sim::ScanScene scene;
  cloud::PointCloud cloud;
  std::vector<Eigen::Vector3d> stations;
};
ScannedBed ScanBed(std::uint64_t seed, sim::Sensor sensor, double noise_mm) {
  ScannedBed b{sim::RandomTopiaryBed(seed), {}, {}};
  sim::ScanOptions so;
  so.sensor = sensor;
  so.seed = seed;
  so.noise_mm = noise_mm;
  fitting::QuietSolverWarnings();
  b.cloud = sim::ScanGarden(b.scene, so);
  b.stations = sim::ScanStations(b.scene, so);
  return b;
}

// A bed scanned by a terrestrial scanner from two tripods 2.5 m in front of it, 1.5 m up (3 mm
// of range noise, as bench find's): each top is seen from one side only, the far side hidden by
// its own curvature, and the scanner's lines leave cells of twice the cloud's spacing empty on a
// solid top. Judged from above (no viewpoints) 1-3 of 5 topiary a bed were found on such beds
// (bench find --bed-sensors terrestrial, seeds 101-104: 9 of 21; on these two, 6 of 10). Told where the tripods stood,
// the cover is read over the part of each top facing them on cells sized by its own points:
// every topiary found, and nothing else in the bed (roses, a low box hedge row, a post) called
// one. The axes: the noise is 3 mm and the leaf layer 15-40 mm deep; the bench's held-back
// beds read within 1 % (worst 0.97 %), so 2 %, the target, is the bound. Seeds 31-32
// are neither the tuning beds nor the held-back ones.
TEST(FindHedges, TopiarySeenFromTheSideIsJudgedWhereItFacesTheScanner) {
  for (std::uint64_t seed : {31u, 32u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const ScannedBed bed = ScanBed(seed, sim::Sensor::kTerrestrial, 3);
    const sim::ScanScene& scene = bed.scene;
    const cloud::PointCloud& cloud = bed.cloud;
    FindOptions told;
    told.viewpoints_mm = bed.stations;
    ASSERT_EQ(told.viewpoints_mm.size(), 2u);
    auto found_of = [&](const FindResult& r, std::size_t* other) {
      std::size_t found = 0;
      *other = 0;
      for (const auto& o : r.objects) {
        if (!o.topiary || !o.shape) continue;
        const sim::ScanSpheroid* match = nullptr;
        for (const auto& t : scene.topiary) {
          if ((o.shape->center_mm.head<2>() - t.center_mm.head<2>()).norm() < 100) match = &t;
        }
        if (!match) {
          // The bed's small free ball is a ball, not a false topiary.
          bool ball = false;
          for (const auto& b : scene.balls) ball |= (o.shape->center_mm.head<2>() - b.center_mm.head<2>()).norm() < 100;
          *other += !ball;
          continue;
        }
        ++found;
        for (int k = 0; k < 3; ++k) {
          EXPECT_NEAR(o.shape->axes_mm[k], match->axes_mm[k], 0.02 * match->axes_mm[k]) << "axis " << k;
        }
      }
      return found;
    };
    std::size_t other = 0;
    EXPECT_EQ(found_of(FindHedges(cloud, told), &other), scene.topiary.size());
    EXPECT_EQ(other, 0u);
  }
}

// A 16-beam LiDAR driving past a bed 4.3-4.7 m away, 1.5 m up, sees each topiary's upper part
// from one side, its rays within 15 degrees of the level: they meet the sides face on and graze
// the tops. Its 10 mm of range noise, and how deep each beam goes among the leaves, lie along
// them. Told the stations, the leaf layer reads both along the rays. With the noise held at the
// lawn's about the vertical (the stations not passed to the measuring fit) it read the sides'
// scatter as leaves: over these ten beds (seeds 31-40; 43 topiary measured, 129 semi-axes) the
// semi-axes read +1.1, +1.4 and +2.0 mm long on average, their rms error 3.2 mm, and the 95 %
// intervals held 95 of them (74 %); told, -1.5, -1.2 and -0.6 mm, 2.4 mm and 117 (91 %).
// 10 mm of range noise on a shape's 300-900 points scatters a semi-axis by about 2.5 mm (the
// intervals' typical half-width here, 4.8 mm, over 1.96): an rms of 2.8 mm leaves about a
// millimetre of offset beside it. The intervals hold under 95 %: the far half no station saw is
// pinned by the near half alone (docs/accuracy.md, "Beds seen from the side"); 85 % is asked.
TEST(FindHedges, ALidarsNoiseAndLeavesAreReadAlongItsRays) {
  std::size_t axes = 0, held = 0;
  double squares = 0;
  for (std::uint64_t seed = 31; seed <= 40; ++seed) {
    const ScannedBed bed = ScanBed(seed, sim::Sensor::kLidar16, 10);
    FindOptions told;
    told.viewpoints_mm = bed.stations;
    const FindResult r = FindHedges(bed.cloud, told);
    for (const auto& o : r.objects) {
      if (!o.topiary || !o.shape) continue;
      for (const auto& t : bed.scene.topiary) {
        if ((o.shape->center_mm.head<2>() - t.center_mm.head<2>()).norm() > 100) continue;
        for (int k = 0; k < 3; ++k) {
          const double e = o.shape->axes_mm[k] - t.axes_mm[k];
          squares += e * e, ++axes, held += std::abs(e) <= o.shape->axes_ci95_mm[k];
        }
      }
    }
  }
  ASSERT_GE(axes, 3u * 40);  // 43 of the 49 topiary are measured (a sparse bed's smallest are not found)
  EXPECT_LE(std::sqrt(squares / double(axes)), 2.8);
  EXPECT_GE(double(held), 0.85 * double(axes));
}

// The segment.hedges stage takes the stations as find does (option `viewpoints`, x,y,z each in
// the cloud's frame as read), or a reader's PCD VIEWPOINT: told, the terrestrial bed 32 above has
// every topiary found in a pipeline as by FindHedges told; not told, as judged from above (fewer:
// the far side of each top is hidden). A count that is not three per station is refused by name.
TEST(FindHedges, TheStageTakesTheStations) {
  const ScannedBed bed = ScanBed(32, sim::Sensor::kTerrestrial, 3);
  pipeline::Registry registry;
  RegisterSceneStages(registry);
  auto topiary_of = [&](const nlohmann::json& stage) {
    pipeline::Pipeline p = pipeline::Pipeline::FromJson(nlohmann::json::array({stage}).dump(), "test", registry, {}, {"cloud"});
    pipeline::Context ctx;
    ctx.Put("cloud", bed.cloud);
    const pipeline::RunReport rep = p.Run(ctx);
    return std::get<std::int64_t>(rep.stages.at(0).notes.at("topiary"));
  };
  FindOptions told;
  told.viewpoints_mm = bed.stations;
  const std::int64_t direct = std::int64_t(FindHedges(bed.cloud, told).Topiary());
  const std::int64_t above = std::int64_t(FindHedges(bed.cloud, FindOptions{}).Topiary());
  ASSERT_GT(direct, above) << "the bed must need the stations for this test to mean anything";
  std::vector<double> at;
  for (const auto& v : bed.stations) at.insert(at.end(), {v.x(), v.y(), v.z()});
  EXPECT_EQ(topiary_of({{"type", "segment.hedges"}, {"viewpoints", at}}), direct);
  EXPECT_EQ(topiary_of({{"type", "segment.hedges"}}), above);
  at.pop_back();
  try {
    topiary_of({{"type", "segment.hedges"}, {"viewpoints", at}});
    ADD_FAILURE() << "5 numbers taken as stations";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'viewpoints'"), std::string::npos) << e.what();
  }
}

// A ball or dome the ball search reports over a clipped shape must hold that shape's semi-axes
// within its radius's 95 % interval and the 2 % the axes are asked to (a ball's three semi-axes
// are its radius). On LiDAR bed 31 a 337 x 337 x 265 mm spheroid, seen from the side down to
// about its widest part, fits a dome about the ground (r 362.6 +- 12.2 mm, the centre 90 mm low)
// and an oblate spheroid equally (BIC 974.5 against 972.9), with axes not apart: the points
// tell neither the class nor the size, and it must say so (undecided, both readings in its
// reason) rather than report the dome. Fails with ShapesOfBalls keeping such a dome as a ball.
TEST(FindHedges, ADomeThePointsCannotTellFromASpheroidIsUndecidedNotABall) {
  std::size_t balls_over_shapes = 0, tied = 0;
  for (std::uint64_t seed = 31; seed <= 40; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const ScannedBed bed = ScanBed(seed, sim::Sensor::kLidar16, 10);
    FindOptions told;
    told.viewpoints_mm = bed.stations;
    const FindResult r = FindHedges(bed.cloud, told);
    for (const auto& o : r.objects) {
      for (const auto& t : bed.scene.topiary) {
        const Eigen::Vector2d at = o.ball    ? Eigen::Vector2d(o.fit.sphere.center_mm.head<2>())
                                   : o.shape ? Eigen::Vector2d(o.shape->center_mm.head<2>())
                                             : o.top_center_mm;
        if ((at - t.center_mm.head<2>()).norm() > 100) continue;
        if (o.verdict == "undecided" && o.reason.find("tell neither") != std::string::npos) ++tied;
        if (!o.ball || !o.fit.converged || !o.fit.std_error_mm) continue;
        ++balls_over_shapes;
        const double ci = 1.96 * (*o.fit.std_error_mm)[3];
        for (int k = 0; k < 3; ++k) {
          EXPECT_LE(std::abs(o.fit.sphere.radius_mm - t.axes_mm[k]), ci + 0.02 * t.axes_mm[k])
              << "a " << o.verdict << " of r " << o.fit.sphere.radius_mm << " +- " << ci << " over semi-axis " << k << " of "
              << t.axes_mm[k];
        }
      }
    }
  }
  EXPECT_GE(tied, 1u);  // bed 31's spheroid
}

// The stations as a user gives them: in the file's units and frame. The second bed above (seed
// 32) turned 180 degrees (its scanner to the north) in UTM metres, as a survey exports it, read
// with a global shift; the stations in UTM metres too. They must reach the finder scaled and
// shifted as the points are: left unscaled they would stand 5,700 km to the south, facing the
// tops' hidden sides (3 of 5 found so); as in mm (test above) all 5 topiary are found. (Seed 31
// turned so has all 5 found by the ball search, which no viewpoint touches.)
TEST(FindHedges, ViewpointsAreReadInTheCloudsOwnUnitsAndFrame) {
  const ScannedBed bed = ScanBed(32, sim::Sensor::kTerrestrial, 3);
  const sim::ScanScene& scene = bed.scene;
  const cloud::PointCloud& c = bed.cloud;
  const Eigen::Vector3d utm_m(500000.0, 5700000.0, 50.0);
  const std::string file = (hedgefit::testing::ScratchDir() / "bed.xyz").string();
  {
    std::ofstream out(file);
    char line[96];
    for (const auto& p : c.points_mm) {
      const Eigen::Vector3d q = Eigen::Vector3d(-p.x(), -p.y(), p.z()) / 1000.0 + utm_m;
      out << std::string(line, std::size_t(std::snprintf(line, sizeof(line), "%.4f %.4f %.4f\n", q.x(), q.y(), q.z())));
    }
  }
  std::vector<Eigen::Vector3d> stations;
  for (const auto& v : bed.stations) stations.push_back(Eigen::Vector3d(-v.x(), -v.y(), v.z()) / 1000.0 + utm_m);
  fitting::QuietSolverWarnings();
  const FindReport rep = FindInCloudFile(file, 0, FindOptions{}, nullptr, stations);
  ASSERT_EQ(rep.scale, 1000.0);
  ASSERT_GT(rep.offset_mm.norm(), 5e9);
  EXPECT_EQ(rep.result.viewpoints, 2u);
  EXPECT_EQ(rep.viewpoint_source, "given");
  std::size_t found = 0;
  for (const auto& o : rep.result.objects) {
    if (!o.topiary || !o.shape) continue;
    for (const auto& t : scene.topiary) {
      const Eigen::Vector2d at = o.shape->center_mm.head<2>() + rep.offset_mm.head<2>() - 1000.0 * utm_m.head<2>();
      found += (at + t.center_mm.head<2>()).norm() < 100;  // at the truth turned 180 degrees
    }
  }
  EXPECT_EQ(found, scene.topiary.size());
}

}  // namespace
}  // namespace hedgefit::scene
