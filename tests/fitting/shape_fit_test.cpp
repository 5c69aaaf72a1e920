// The clipped-shape fit through the method table (fitters.shape, `compare --methods shape`): an
// oblate topiary in a camera's frame (up = -y) comes back with its axes and centre in that frame.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "fitting/methods.hpp"
#include "fitting/shape_fit.hpp"
#include "pipeline/stage.hpp"

namespace hedgefit::fitting {
namespace {

TEST(ShapeMethod, AnOblateTopiaryInACamerasFrame) {
  // Semi-axes 350 (horizontal, round) x 220 (vertical), its centre 60 mm above the lawn at y = 0
  // (y is down), seen from above and the sides to the lawn, 3 mm noise.
  const Eigen::Vector3d center(150, -60, 2400);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 3);
  std::vector<Eigen::Vector3d> pts;
  for (double t = 0; t < M_PI / 2; t += 0.02) {
    for (double p = 0; p < 2 * M_PI; p += 0.02) {
      const double h = 220 * std::cos(t);                   // height above the centre
      const double r = 350 * std::sin(t);                   // horizontal distance from the axis
      pts.emplace_back(center.x() + r * std::cos(p), center.y() - h + noise(rng), center.z() + r * std::sin(p));
    }
  }
  // The sides below the equator, down to the lawn (60 mm below the centre).
  for (double w = 0; w < 60; w += 6) {
    const double r = 350 * std::sqrt(1 - (w / 220) * (w / 220));
    for (double p = 0; p < 2 * M_PI; p += 0.02) {
      pts.emplace_back(center.x() + r * std::cos(p) + noise(rng), center.y() + w, center.z() + r * std::sin(p));
    }
  }
  const SphereFitResult r = RunFitMethod("shape", pts, {{"up", pipeline::OptionValue(std::string("-y"))}});
  ASSERT_TRUE(r.converged) << r.message;
  const auto it = std::find_if(r.extras.begin(), r.extras.end(), [](const auto& e) { return e.first == "axes_mm"; });
  ASSERT_NE(it, r.extras.end());
  ASSERT_EQ(it->second.size(), 3u);
  const std::vector<double>* axes = &it->second;
  // 3 mm noise on thousands of points pins the axes to well under 1 %; the radial residual's
  // first-order error on a flattened shape adds a little: 1 %.
  EXPECT_NEAR((*axes)[0], 350, 3.5);
  EXPECT_NEAR((*axes)[1], 350, 3.5);
  EXPECT_NEAR((*axes)[2], 220, 2.2);
  EXPECT_LT((r.sphere.center_mm - center).norm(), 3.0);
  EXPECT_NE(r.message.find("oblate"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace hedgefit::fitting
