// Off-screen rendering checked from the pixels: size, background, the sphere's colour
// inside its outline computed from the camera the renderer used, the colour bar, and
// identical output on a second run. Runs without a display (hedgefit starts Xvfb).

#include "render/render.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <fstream>
#include <iterator>

#include "pipeline/error.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::render {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

constexpr int kW = 320, kH = 240;

// A ring of grey points around a red sphere at 2 m: the sphere's middle is clear of points.
cloud::PointCloud Ring() {
  cloud::PointCloud c;
  for (int i = 0; i < 360; ++i) {
    const double a = i * CV_PI / 180;
    c.points_mm.emplace_back(float(420 * std::cos(a)), float(420 * std::sin(a)), 2000.f);
    c.colors.push_back({128, 128, 128});
  }
  c.Flatten();
  return c;
}

std::vector<SphereOverlay> RedSphere() {
  SphereOverlay s;
  s.label = "fit";
  s.sphere.center_mm = Eigen::Vector3d(0, 0, 2000);
  s.sphere.radius_mm = 200;
  return {s};  // overlay 0 is drawn red (OverlayColor(0))
}

// Pinhole projection with the renderer's own camera for the front view: VTK's view angle
// is vertical, f = (H/2) / tan(angle/2); screen up is the camera's view-up.
cv::Point2d ProjectFront(const Eigen::Vector3d& p, const std::array<double, 6>& bounds) {
  const CameraSetup cam = CameraFor(View::kFront, bounds);
  const Eigen::Vector3d pos(cam.position[0], cam.position[1], cam.position[2]);
  const Eigen::Vector3d fwd = (Eigen::Vector3d(cam.focal_point[0], cam.focal_point[1], cam.focal_point[2]) - pos).normalized();
  Eigen::Vector3d up(cam.view_up[0], cam.view_up[1], cam.view_up[2]);
  up = (up - up.dot(fwd) * fwd).normalized();
  const Eigen::Vector3d right = fwd.cross(up);
  const double f = (kH / 2.0) / std::tan(cam.view_angle_deg * CV_PI / 360.0);
  const Eigen::Vector3d d = p - pos;
  return {kW / 2.0 + f * d.dot(right) / d.dot(fwd), kH / 2.0 - f * d.dot(up) / d.dot(fwd)};
}

bool Reddish(const cv::Vec3b& bgr) { return bgr[2] > 80 && bgr[2] > 1.8 * bgr[1] && bgr[2] > 1.8 * bgr[0]; }

RenderOptions Small() {
  RenderOptions o;
  o.width = kW;
  o.height = kH;
  o.sphere_opacity = 1.0;
  return o;
}

TEST(Render, SizeBackgroundAndSphereInsideItsProjectedOutline) {
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string path = (dir / "r.png").string();
  RenderToPng(Ring(), RedSphere(), Small(), path);
  const cv::Mat img = cv::imread(path);
  ASSERT_EQ(img.cols, kW);
  ASSERT_EQ(img.rows, kH);
  EXPECT_EQ(img.at<cv::Vec3b>(kH - 3, 2), cv::Vec3b(255, 255, 255));  // background where nothing is
  // Scene bounds as the renderer computes them: the ring and the sphere.
  const std::array<double, 6> bounds = {-420, 420, -420, 420, 1800, 2200};
  const cv::Point2d c = ProjectFront(Eigen::Vector3d(0, 0, 2000), bounds);
  const cv::Point2d edge = ProjectFront(Eigen::Vector3d(200, 0, 2000), bounds);
  const double r_px = std::hypot(edge.x - c.x, edge.y - c.y);
  ASSERT_GT(r_px, 15);  // the sphere is big enough on screen to sample
  int inside = 0;
  for (int k = 0; k < 16; ++k) {
    const double a = k * CV_PI / 8;
    const cv::Point2d in(c.x + 0.7 * r_px * std::cos(a), c.y + 0.7 * r_px * std::sin(a));
    inside += Reddish(img.at<cv::Vec3b>(int(std::lround(in.y)), int(std::lround(in.x))));
    // Just outside the outline (and inside the ring): background.
    const cv::Point2d out(c.x + 1.25 * r_px * std::cos(a), c.y + 1.25 * r_px * std::sin(a));
    EXPECT_EQ(img.at<cv::Vec3b>(int(std::lround(out.y)), int(std::lround(out.x))), cv::Vec3b(255, 255, 255)) << k;
  }
  EXPECT_EQ(inside, 16);
  EXPECT_TRUE(Reddish(img.at<cv::Vec3b>(int(std::lround(c.y)), int(std::lround(c.x)))));
}

// The scalar bar sits at the right of the first view: with distance colouring it holds
// the diverging map's blues and reds; with the points' own colours that area is empty.
TEST(Render, ColourBarOnlyWhenColouringByDistance) {
  const auto dir = hedgefit::testing::ScratchDir();
  auto bar_colours = [&](ColorMode mode) {
    RenderOptions o = Small();
    o.color = mode;
    const std::string path = (dir / "bar.png").string();
    RenderToPng(Ring(), RedSphere(), o, path);
    const cv::Mat img = cv::imread(path);
    int blue = 0, red = 0;
    for (int y = int(0.2 * kH); y < int(0.85 * kH); ++y) {
      for (int x = int(0.80 * kW); x < int(0.85 * kW); ++x) {  // the bar: its left 30 % of 0.80-0.95
        const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
        blue += p[0] > p[2] + 40;
        red += p[2] > p[0] + 40;
      }
    }
    return std::make_pair(blue, red);
  };
  const auto with_bar = bar_colours(ColorMode::kDistance);
  EXPECT_GT(with_bar.first, 20);
  EXPECT_GT(with_bar.second, 20);
  const auto without = bar_colours(ColorMode::kOwn);
  EXPECT_EQ(without.first + without.second, 0);
}

TEST(Render, SameInputSameBytes) {
  const auto dir = hedgefit::testing::ScratchDir();
  RenderOptions o = Small();
  o.views = {View::kFront, View::kSide, View::kTop, View::kIso};
  o.color = ColorMode::kDepth;
  RenderToPng(Ring(), RedSphere(), o, (dir / "a.png").string());
  RenderToPng(Ring(), RedSphere(), o, (dir / "b.png").string());
  auto bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string a = bytes(dir / "a.png"), b = bytes(dir / "b.png");
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, b);
  EXPECT_EQ(cv::imread((dir / "a.png").string()).cols, 2 * kW);  // 4 views tile 2 x 2
}

TEST(Render, BadOptionsAndPathsAreNamed) {
  RenderOptions o = Small();
  o.width = 4;
  EXPECT_THROW(RenderToPng(Ring(), RedSphere(), o, "x.png"), Error);
  EXPECT_THROW(RenderToPng(Ring(), RedSphere(), Small(), "/no/such/dir/x.png"), Error);
  RenderOptions d = Small();
  d.color = ColorMode::kDistance;
  EXPECT_THROW(RenderToPng(Ring(), {}, d, "x.png"), Error);  // distance needs a sphere
  EXPECT_THROW(ParseView("below"), Error);
}

// Where text was drawn in `region`: how many pixels are ink (black text: every channel dark; with
// `coloured`, any channel far from the white background), and how many rows they span (a glyph of
// a 14 px font spans at least 10; the old colour bar title spanned 5).
std::pair<int, int> TextIn(const cv::Mat& img, cv::Rect region, bool coloured = false) {
  region &= cv::Rect(0, 0, img.cols, img.rows);
  int count = 0, top = region.br().y, bottom = region.y - 1;
  for (int y = region.y; y < region.br().y; ++y) {
    for (int x = region.x; x < region.br().x; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      if (coloured ? std::min({p[0], p[1], p[2]}) < 160 : std::max({p[0], p[1], p[2]}) < 120) {
        ++count;
        top = std::min(top, y);
        bottom = std::max(bottom, y);
      }
    }
  }
  return {count, bottom >= top ? bottom - top + 1 : 0};
}

// At the default size every text reads: the colour bar's two-line title with its unit, each view's
// name, and the legend's entries are drawn, and tall enough to read (at least 14 px fonts).
TEST(Render, TextReadsAtTheDefaultSize) {
  const auto dir = hedgefit::testing::ScratchDir();
  RenderOptions o;  // the default size, 1024 x 768 per view
  o.color = ColorMode::kDistance;
  o.views = {View::kFront, View::kSide};
  const std::string path = (dir / "text.png").string();
  RenderToPng(Ring(), RedSphere(), o, path);
  const cv::Mat img = cv::imread(path);
  ASSERT_EQ(img.cols, 2 * o.width);
  const int w = o.width, h = o.height;
  // Above the bar: "signed distance" / "(mm)" (the bar's top label, "978.5", is lower).
  const auto title = TextIn(img, cv::Rect(int(0.80 * w), 0, int(0.2 * w), int(0.17 * h)));
  EXPECT_GT(title.first, 60);
  EXPECT_GE(title.second, 24) << "the bar's title: two lines of text at least 12 px tall each";
  // Each view's name at its bottom right.
  for (int view = 0; view < 2; ++view) {
    const auto label = TextIn(img, cv::Rect(view * w + int(0.6 * w), int(0.93 * h), int(0.39 * w), int(0.07 * h)));
    EXPECT_GT(label.first, 40) << "view " << view;
    EXPECT_GE(label.second, 10) << "view " << view;
  }
  // The legend's one entry at the top left.
  const auto legend = TextIn(img, cv::Rect(0, 0, int(0.6 * w), 40), true);
  EXPECT_GT(legend.first, 60);
  EXPECT_GE(legend.second, 10);
}

}  // namespace
}  // namespace hedgefit::render

namespace hedgefit::render {
namespace {

// A clipped shape's fit (fitters.shape) is drawn as its shape: the overlay takes its semi-axes,
// heading and up from the fit's extras; any other fit stays a sphere.
TEST(Overlay, AShapeFitIsDrawnAsItsShape) {
  fitting::SphereFitResult f;
  f.method = "shape";
  f.converged = true;
  f.sphere = fitting::Sphere{Eigen::Vector3d(1, 2, 3), 250};
  f.SetExtra("axes_mm", {400, 260, 220});
  f.SetExtra("heading_deg", {30});
  f.SetExtra("up", {0, -1, 0});
  const SphereOverlay o = OverlayOf(f, "shape");
  EXPECT_EQ(o.axes_mm, Eigen::Vector3d(400, 260, 220));
  EXPECT_DOUBLE_EQ(o.heading_deg, 30);
  EXPECT_EQ(o.up, Eigen::Vector3d(0, -1, 0));
  EXPECT_FALSE(o.dashed);
  f.method = "geometric";
  EXPECT_EQ(OverlayOf(f, "geometric").axes_mm, Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace hedgefit::render
