// The simulator's geometry against OpenCV's own projection: rendered board corners land
// where cv::projectPoints puts them (sub-pixel), and the rendered sphere's outline
// matches the projected silhouette, in both cameras.

#include "sim/simulator.hpp"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pipeline/error.hpp"
#include "stereo/calibration.hpp"
#include "sim/camera_model.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::stereo {
using namespace hedgefit::sim;  // the test data's renderer
namespace {

std::vector<cv::Point2d> Project(const SimRig& rig, bool right, const std::vector<cv::Point3d>& world) {
  const SimCamera& cam = right ? rig.right : rig.left;
  cv::Vec3d rvec(0, 0, 0), tvec(0, 0, 0);
  if (right) {
    cv::Rodrigues(cv::Mat(rig.R), rvec);
    tvec = rig.T;
  }
  std::vector<cv::Point2d> px;
  cv::projectPoints(world, rvec, tvec, cv::Mat(cam.K), cv::Mat(cam.dist), px);
  return px;
}

// Anti-aliased with 4x4 rays per pixel and a 0.6 px blur, corners found by OpenCV's
// detector refine to within a few hundredths of a pixel of the true projection; 0.1 px
// mean and 0.3 px max leave room for the detector, not for a geometric error (a wrong
// distortion sign or a half-pixel offset moves them by 0.5 px or more).
TEST(Simulator, BoardCornersLandWhereOpenCvProjectsThem) {
  const SimRig rig = PaperRig(0.5);
  BoardScene board;
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(0.3, -0.25, 0.1), R);
  board.rotation = R;
  board.translation = cv::Vec3d(-200, -150, 1100);
  RenderOptions ro;
  ro.supersample = 4;
  ro.blur_sigma_px = 0.6;
  const auto dir = hedgefit::testing::ScratchDir();
  for (bool right : {false, true}) {
    const std::string path = (dir / (right ? "r.png" : "l.png")).string();
    ASSERT_TRUE(cv::imwrite(path, RenderBoard(rig, right, board, ro)));
    BoardSpec spec;
    spec.inner_corners = cv::Size(12, 11);
    spec.square_mm = 30;
    cv::Size size;
    const auto found = DetectBoards({{path, path}}, spec, &size);
    ASSERT_TRUE(found[0].status.empty()) << found[0].status;
    const auto truth = Project(rig, right, BoardInnerCornersWorld(board));
    double sum = 0, worst = 0;
    for (const auto& c : found[0].left_px) {
      double best = 1e9;  // the detector may start from either end of the board
      for (const auto& t : truth) best = std::min(best, std::hypot(c.x - t.x, c.y - t.y));
      sum += best;
      worst = std::max(worst, best);
    }
    EXPECT_LT(sum / double(found[0].left_px.size()), 0.1) << (right ? "right" : "left");
    EXPECT_LT(worst, 0.3) << (right ? "right" : "left");
  }
}

// The sphere's silhouette is where viewing rays graze it: the circle of tangency seen
// from each camera centre. Pixels 1.5 px inside its projection must be sphere, 1.5 px
// outside must not (the label image samples one ray per pixel centre).
TEST(Simulator, SphereOutlineMatchesProjectedSilhouette) {
  const SimRig rig = PaperRig(0.5);
  SphereScene scene;
  scene.center = cv::Vec3d(150, 80, 2300);
  scene.radius = 300;
  RenderOptions ro;
  ro.labels = true;
  for (bool right : {false, true}) {
    const cv::Mat labels = RenderSphere(rig, right, scene, ro);
    cv::Vec3d eye(0, 0, 0);
    if (right) eye = -(rig.R.t() * rig.T);
    const cv::Vec3d axis = scene.center - eye;
    const double dist = cv::norm(axis);
    const cv::Vec3d w = axis / dist;
    const cv::Vec3d u0 = cv::normalize(w.cross(cv::Vec3d(0, 1, 0))), v0 = w.cross(u0);
    // Tangent circle: centre c - r^2/d w, radius r sqrt(1 - r^2/d^2).
    const double rc = scene.radius * std::sqrt(1 - scene.radius * scene.radius / (dist * dist));
    const cv::Vec3d cc = scene.center - (scene.radius * scene.radius / dist) * w;
    std::vector<cv::Point3d> rim;
    for (int k = 0; k < 72; ++k) {
      const double a = k * 2 * CV_PI / 72;
      const cv::Vec3d p = cc + rc * (std::cos(a) * u0 + std::sin(a) * v0);
      rim.emplace_back(p[0], p[1], p[2]);
    }
    const auto px = Project(rig, right, rim);
    const auto centre = Project(rig, right, {cv::Point3d(scene.center[0], scene.center[1], scene.center[2])})[0];
    int checked = 0;
    for (const auto& p : px) {
      const cv::Point2d out = p - centre;
      const cv::Point2d dir = out * (1.0 / std::hypot(out.x, out.y));
      const cv::Point2d in_pt = p - 1.5 * dir, out_pt = p + 1.5 * dir;
      const auto label_at = [&](const cv::Point2d& q) {
        return labels.at<std::uint8_t>(static_cast<int>(std::lround(q.y)), static_cast<int>(std::lround(q.x)));
      };
      EXPECT_EQ(label_at(in_pt), kLabelSphere) << "inside " << in_pt;
      EXPECT_NE(label_at(out_pt), kLabelSphere) << "outside " << out_pt;
      ++checked;
    }
    EXPECT_EQ(checked, 72);
  }
}

TEST(Simulator, PairOfColourImagesHasTheRigsSize) {
  const SimRig rig = PaperRig(0.25);
  const cv::Mat img = RenderSphere(rig, true, SphereScene{}, RenderOptions{});
  EXPECT_EQ(img.cols, 480);
  EXPECT_EQ(img.rows, 300);
  EXPECT_EQ(img.type(), CV_8UC3);
}

// The camera model: Ideal() changes nothing; the Bayer mosaic and OpenCV's demosaicing give a
// flat colour back (a swapped pattern would swap red and blue); the noise has the variance
// asked for and is independent between the cameras; vignetting darkens the corners by the
// factor asked for.
TEST(CameraModel, IdealBayerNoiseAndVignetting) {
  const cv::Mat flat(240, 320, CV_8UC3, cv::Scalar(50, 120, 200));  // B, G, R
  EXPECT_EQ(cv::norm(ApplyCameraModel(flat, CameraModel::Ideal(), false, 1), flat, cv::NORM_INF), 0.0);
  CameraModel bayer = CameraModel::Ideal();
  bayer.bayer = true;
  const cv::Mat demosaiced = ApplyCameraModel(flat, bayer, false, 1);
  const cv::Scalar inner = cv::mean(demosaiced(cv::Rect(4, 4, 312, 232)));
  EXPECT_NEAR(inner[0], 50, 1.0);
  EXPECT_NEAR(inner[1], 120, 1.0);
  EXPECT_NEAR(inner[2], 200, 1.0);
  CameraModel noisy = CameraModel::Ideal();
  noisy.read_noise = 2.0;
  const cv::Mat grey(240, 320, CV_8UC3, cv::Scalar(100, 100, 100));
  cv::Mat l, r;
  ApplyCameraModel(grey, noisy, false, 3).convertTo(l, CV_64FC3, 1, -100);
  ApplyCameraModel(grey, noisy, true, 3).convertTo(r, CV_64FC3, 1, -100);
  // 230400 samples: the sample sd of N(0, 2) rounded to integers (sd sqrt(4 + 1/12) = 2.02)
  // is within 1 % of that; the correlation of independent fields is within ~0.01 of zero.
  cv::Scalar mean_l, sd_l;
  cv::meanStdDev(l.reshape(1), mean_l, sd_l);
  EXPECT_NEAR(sd_l[0], std::sqrt(4 + 1.0 / 12), 0.03);
  EXPECT_NEAR(l.dot(r) / (l.total() * 3) / (sd_l[0] * sd_l[0]), 0.0, 0.01);
  CameraModel vignette = CameraModel::Ideal();
  vignette.vignetting = 0.25;
  const cv::Mat v = ApplyCameraModel(grey, vignette, false, 1);
  EXPECT_NEAR(v.at<cv::Vec3b>(0, 0)[1], 75, 1);       // the corner: 1 - 0.25
  EXPECT_NEAR(v.at<cv::Vec3b>(120, 160)[1], 100, 1);  // the centre
}

// WithoutEffect switches off exactly the effect it names: the real camera without all of them is
// the ideal one (the image comes back unchanged), without the noise it is deterministic (two seeds
// give the same image) but still not ideal, and a name it does not know is refused, naming it.
TEST(CameraModel, WithoutEffectSwitchesOffOneEffect) {
  cv::Mat image(120, 160, CV_8UC3);
  cv::randu(image, cv::Scalar::all(30), cv::Scalar::all(220));
  CameraModel none;
  for (const char* e : kCameraEffects) none = WithoutEffect(none, e, "test");
  EXPECT_EQ(cv::norm(ApplyCameraModel(image, none, true, 5), image, cv::NORM_INF), 0.0);
  const CameraModel quiet = WithoutEffect(CameraModel(), "noise", "test");
  const cv::Mat a = ApplyCameraModel(image, quiet, true, 5), b = ApplyCameraModel(image, quiet, true, 6);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, image, cv::NORM_INF), 10.0);  // gains, white balance, vignetting and Bayer remain
  EXPECT_FALSE(WithoutEffect(CameraModel(), "bayer", "test").bayer);
  EXPECT_EQ(WithoutEffect(CameraModel(), "vignetting", "test").vignetting, 0.0);
  const CameraModel same = WithoutEffect(CameraModel(), "gains", "test");
  EXPECT_EQ(same.gain_left, same.gain_right);
  EXPECT_EQ(same.white_right, cv::Vec3d(1, 1, 1));
  try {
    WithoutEffect(CameraModel(), "bayr", "--camera-without");
    ADD_FAILURE() << "an unknown effect was accepted";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "--camera-without: no camera effect 'bayr'; use gains, vignetting, bayer, noise, jpeg");
  }
}

}  // namespace
}  // namespace hedgefit::stereo
