// The outline: on a rendered sphere (hedgefit's ray caster, anti-aliased, both cameras of the
// paper's rig), the rays stereo::MeasureOutlines finds about a start sphere a few mm off graze
// the true sphere to a fraction of a pixel, in both views; another hedge beyond the outline and
// the ground at the sphere's foot leave their stretch out.

#include "stereo/outline.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "sim/simulator.hpp"
#include "stereo/rectification.hpp"

namespace hedgefit::stereo {
namespace {

// Each ray's distance from the true centre less the true radius, in px at its tangent point.
std::vector<double> ErrorsPx(const std::vector<cloud::TangentRay>& rays, const Eigen::Vector3d& c, double r, int view) {
  std::vector<double> e;
  for (const auto& ray : rays) {
    if (ray.view != view) continue;
    const Eigen::Vector3d w = c - ray.origin_mm;
    const double along = w.dot(ray.direction);
    e.push_back(((w - along * ray.direction).norm() - r) * ray.focal_px / along);
  }
  return e;
}

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

TEST(Outline, RaysGrazeARenderedSphereInBothViews) {
  const sim::SimRig simrig = sim::PaperRig(0.5);
  const StereoRig rig = sim::RigFromSimulation(simrig);
  sim::SphereScene scene;
  scene.center = cv::Vec3d(80, -40, 2300);
  scene.radius = 400;
  sim::RenderOptions ro;
  ro.supersample = 3;
  ro.noise_sigma = 1.0;
  cv::Mat l, r;
  RectifyPair(rig, sim::RenderSphere(simrig, false, scene, ro), sim::RenderSphere(simrig, true, scene, ro), &l, &r);
  const Eigen::Vector3d c(80, -40, 2300);
  // The start: 4 mm too small and 3 mm off to one side (a front-only fit's error on a leafy
  // ball; 1-2 px here, inside the 6 px searched).
  const std::map<int, Eigen::Vector4d> start = {{0, Eigen::Vector4d(83, -40, 2300, 396)}};
  std::map<int, OutlineStats> stats;
  const cloud::HedgeOutlines out = MeasureOutlines(l, r, cv::Mat(), rig, start, std::nullopt, &stats);
  ASSERT_EQ(out.count(0), 1u);
  for (int view : {0, 1}) {
    const std::vector<double> e = ErrorsPx(out.at(0), c, 400, view);
    // Most of the outline is found (the floor at the sphere's foot and the frame take a little).
    EXPECT_GT(e.size(), std::size_t(0.7 * 2 * M_PI * 400 * 466.65 / 2300)) << "view " << view;
    // A smooth sphere's edge, anti-aliased: its median within 0.15 px of the truth (the start
    // was 1-2 px off, so the test can tell), and 90 % of the rays within 0.5 px.
    EXPECT_LT(std::abs(Median(e)), 0.15) << "view " << view;
    std::vector<double> a;
    for (double x : e) a.push_back(std::abs(x));
    std::sort(a.begin(), a.end());
    EXPECT_LT(a[a.size() * 9 / 10], 0.5) << "view " << view;
  }
  EXPECT_EQ(stats.at(0).left, std::size_t(std::count_if(out.at(0).begin(), out.at(0).end(),
                                                         [](const cloud::TangentRay& t) { return t.view == 0; })));
}

TEST(Outline, AnotherHedgeBeyondAndTheGroundAtTheFootAreLeftOut) {
  const sim::SimRig simrig = sim::PaperRig(0.5);
  const StereoRig rig = sim::RigFromSimulation(simrig);
  sim::SphereScene scene;
  scene.center = cv::Vec3d(0, 0, 2300);
  scene.radius = 400;
  cv::Mat l, r;
  RectifyPair(rig, sim::RenderSphere(simrig, false, scene), sim::RenderSphere(simrig, true, scene), &l, &r);
  const std::map<int, Eigen::Vector4d> start = {{1, Eigen::Vector4d(0, 0, 2300, 400)}};
  const std::size_t all = MeasureOutlines(l, r, cv::Mat(), rig, start).at(1).size();
  // Hedge 2 fills the right half of the image beyond the sphere's outline: the right half of
  // the outline is not this hedge's (in the left view, whose labels these are).
  cv::Mat labels(l.size(), CV_32S, cv::Scalar(0));
  labels(cv::Rect(l.cols / 2, 0, l.cols - l.cols / 2, l.rows)).setTo(2);
  const std::size_t beside = MeasureOutlines(l, r, labels, rig, start).at(1).size();
  EXPECT_LT(beside, all * 4 / 5);
  EXPECT_GT(beside, all / 2);
  // A ground plane through the sphere's lowest point (y = 400 mm, y down): the foot's stretch,
  // where the ray past the outline meets the ground within a radius, is left out.
  const std::size_t grounded =
      MeasureOutlines(l, r, cv::Mat(), rig, start, cv::Vec4d(0, -1, 0, 400)).at(1).size();
  EXPECT_LT(grounded, all * 19 / 20);
  EXPECT_GT(grounded, all / 2);
}

}  // namespace
}  // namespace hedgefit::stereo
