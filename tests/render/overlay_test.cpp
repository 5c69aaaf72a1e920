// The operator's overlay: a sphere's projected outline lies on the silhouette that the
// simulator's ray caster (an independent projection) renders for the same sphere, and the
// drawing marks those pixels.

#include "render/overlay.hpp"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "stereo/rectification.hpp"
#include "sim/simulator.hpp"

namespace hedgefit::render {
using namespace hedgefit::sim;  // the test data's renderer
namespace {

TEST(Overlay, OutlineFollowsTheRenderedSilhouette) {
  const sim::SimRig sim = sim::PaperRig(0.5);
  const stereo::StereoRig rig = sim::RigFromSimulation(sim);
  sim::SphereScene scene;
  scene.center = cv::Vec3d(70, 50, 2300);
  sim::RenderOptions lo;
  lo.labels = true;
  lo.supersample = 3;
  const cv::Mat truth = stereo::RectifyLeftMask(rig, sim::RenderSphere(sim, false, scene, lo) == sim::kLabelSphere);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(truth.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  ASSERT_EQ(contours.size(), 1u);
  fitting::Sphere s;
  s.center_mm = Eigen::Vector3d(70, 50, 2300);
  s.radius_mm = scene.radius;
  const std::vector<cv::Point2d> outline = SphereOutline(rig, s);
  ASSERT_EQ(outline.size(), 180u);
  // The contour runs through the outermost mask pixels' centres, half a pixel inside the
  // silhouette; nearest-neighbour rectification moves it by up to 0.71 px (diagonally); a
  // label pixel is the sphere's only when most of its supersamples are (up to 0.5 px): every
  // outline point within 2 px of it, on average within 1 px.
  double sum = 0, worst = 0;
  for (const auto& p : outline) {
    double best = 1e9;
    for (const auto& q : contours[0]) best = std::min(best, std::hypot(p.x - q.x, p.y - q.y));
    sum += best;
    worst = std::max(worst, best);
  }
  EXPECT_LT(sum / double(outline.size()), 1.0);
  EXPECT_LT(worst, 2.0);
  // A sphere 10 % larger does not fit the silhouette: the test can tell.
  s.radius_mm *= 1.1;
  double off = 0;
  for (const auto& p : SphereOutline(rig, s)) {
    double best = 1e9;
    for (const auto& q : contours[0]) best = std::min(best, std::hypot(p.x - q.x, p.y - q.y));
    off += best;
  }
  EXPECT_GT(off / 180.0, 3.0);
  // Drawn: the outline's pixels take the first fit's colour.
  s.radius_mm = scene.radius;
  const cv::Mat grey(rig.image_size, CV_8UC3, cv::Scalar(128, 128, 128));
  const cv::Mat picture = DrawOverlay(grey, rig, truth, {SphereOverlay{"geometric", s, false, false}}, 2);
  const auto c = OverlayColor(0);
  const cv::Vec3b want(cv::saturate_cast<uchar>(255 * c[2]), cv::saturate_cast<uchar>(255 * c[1]),
                       cv::saturate_cast<uchar>(255 * c[0]));
  int hits = 0;
  for (const auto& p : outline) {
    const cv::Vec3b got = picture.at<cv::Vec3b>(cvRound(p.y), cvRound(p.x));
    if (cv::norm(cv::Vec3i(got) - cv::Vec3i(want)) < 40) ++hits;
  }
  EXPECT_GT(hits, 150);
  // The legend says what magenta is (its first line, in magenta) and names the fit (its second
  // line, in the fit's colour), each line of text at least 10 px tall (a 14 px font).
  auto ink_rows = [&](const cv::Mat& img, int y0, int y1, const cv::Vec3b& colour) {
    int top = y1, bottom = y0 - 1;
    for (int y = y0; y < y1; ++y) {
      for (int x = 0; x < img.cols / 2; ++x) {
        if (cv::norm(cv::Vec3i(img.at<cv::Vec3b>(y, x)) - cv::Vec3i(colour)) < 60) top = std::min(top, y), bottom = std::max(bottom, y);
      }
    }
    return bottom >= top ? bottom - top + 1 : 0;
  };
  EXPECT_GE(ink_rows(picture, 0, 40, cv::Vec3b(255, 0, 255)), 10) << "no magenta legend line for the mask";
  EXPECT_GE(ink_rows(picture, 30, 80, want), 10) << "no legend line for the fit";
  // Dashed, as a fit told not a ball is drawn: about half of the outline, spread all round it.
  const cv::Mat dashed = DrawOverlay(grey, rig, truth, {SphereOverlay{"geometric", s, false, true}}, 2);
  int dashed_hits = 0, quarters[4] = {0, 0, 0, 0};
  for (std::size_t k = 0; k < outline.size(); ++k) {
    const cv::Vec3b got = dashed.at<cv::Vec3b>(cvRound(outline[k].y), cvRound(outline[k].x));
    if (cv::norm(cv::Vec3i(got) - cv::Vec3i(want)) < 40) ++dashed_hits, ++quarters[4 * k / outline.size()];
  }
  EXPECT_GT(dashed_hits, int(0.3 * double(outline.size())));
  EXPECT_LT(dashed_hits, int(0.75 * double(outline.size())));
  for (int q : quarters) EXPECT_GT(q, 5);
  // Behind the camera or around it: nothing to draw.
  s.center_mm = Eigen::Vector3d(0, 0, 100);
  EXPECT_TRUE(SphereOutline(rig, s).empty());
}

}  // namespace
}  // namespace hedgefit::render
