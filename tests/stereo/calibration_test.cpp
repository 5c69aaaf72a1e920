// Stereo calibration: from simulated boards it recovers the simulated rig and rectifies
// rows to within a tenth of a pixel; on OpenCV's real chessboard pairs it reaches the
// stereo RMS and baseline the issue sets; bad inputs give clear messages.

#include "stereo/calibration.hpp"

#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pipeline/error.hpp"
#include "sim/camera_model.hpp"
#include "sim/simulator.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::stereo {
using namespace hedgefit::sim;  // the test data's renderer
namespace {

// Simulated paper rig at half size; 14 board poses 0.9-1.5 m away, tilted, spread over
// the view, rendered with 4x4 anti-aliasing and a 0.6 px blur.
class SimulatedCalibration : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    rig_ = new SimRig(PaperRig(0.5));
    // One directory per process: ctest runs each test of this suite as its own process, in
    // parallel, and they would otherwise read each other's half-written images.
    const auto dir = std::filesystem::temp_directory_path() /
                     ("hedgefit_test_simulated_calibration_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    RenderOptions ro;
    ro.supersample = 4;
    ro.blur_sigma_px = 0.6;
    std::vector<std::pair<std::string, std::string>> files;
    for (int i = 0; i < 14; ++i) {
      BoardScene b;
      cv::Matx33d R;
      cv::Rodrigues(cv::Vec3d(((i % 4) - 1.5) * 0.25, (((i / 4) % 4) - 1.5) * 0.3, ((i % 3) - 1) * 0.15), R);
      b.rotation = R;
      const double z = 900 + 150 * ((i * 7) % 5);
      const cv::Vec3d centre((i % 4 - 1.5) * 0.2 * z + 70, ((i / 4) % 4 - 1.5) * 0.14 * z, z);
      b.translation = centre - R * cv::Vec3d(165, 150, 0);
      const std::string l = (dir / ("l" + std::to_string(i) + ".png")).string();
      const std::string r = (dir / ("r" + std::to_string(i) + ".png")).string();
      cv::imwrite(l, RenderBoard(*rig_, false, b, ro));
      cv::imwrite(r, RenderBoard(*rig_, true, b, ro));
      files.emplace_back(l, r);
    }
    BoardSpec spec;
    spec.inner_corners = cv::Size(12, 11);
    spec.square_mm = 30;
    corners_ = new std::vector<PairCorners>(DetectBoards(files, spec, &size_));
  }
  static void TearDownTestSuite() {
    delete rig_;
    delete corners_;
  }
  static SimRig* rig_;
  static std::vector<PairCorners>* corners_;
  static cv::Size size_;
};
SimRig* SimulatedCalibration::rig_ = nullptr;
std::vector<PairCorners>* SimulatedCalibration::corners_ = nullptr;
cv::Size SimulatedCalibration::size_;

// Corner noise is ~0.1 px (the RMS below), spread over 14 x 132 corners: focal lengths
// come back within 0.3 %, principal points within 1.5 px, the baseline within 0.3 %
// (and T within 1 mm) and the rotation between the cameras within 0.05 degrees.
TEST_F(SimulatedCalibration, RecoversTheSimulatedRig) {
  for (const auto& c : *corners_) ASSERT_TRUE(c.status.empty()) << c.left << ": " << c.status;
  CalibrationOptions o;
  o.board.inner_corners = cv::Size(12, 11);
  o.board.square_mm = 30;
  const StereoRig rig = CalibrateFromCorners(*corners_, size_, o);
  EXPECT_LT(rig.rms_stereo_px, 0.2);
  const auto check_camera = [](const cv::Mat& K, const SimCamera& truth, const char* name) {
    EXPECT_NEAR(K.at<double>(0, 0) / truth.K(0, 0), 1.0, 0.003) << name;
    EXPECT_NEAR(K.at<double>(1, 1) / truth.K(1, 1), 1.0, 0.003) << name;
    EXPECT_NEAR(K.at<double>(0, 2), truth.K(0, 2), 1.5) << name;
    EXPECT_NEAR(K.at<double>(1, 2), truth.K(1, 2), 1.5) << name;
  };
  check_camera(rig.K1, rig_->left, "left");
  check_camera(rig.K2, rig_->right, "right");
  EXPECT_NEAR(rig.D1.at<double>(0), rig_->left.dist[0], 0.01);  // k1 of -0.05
  EXPECT_NEAR(rig.baseline_mm / cv::norm(rig_->T), 1.0, 0.003);
  EXPECT_LT(cv::norm(rig.T - cv::Mat(rig_->T)), 1.0);  // mm, of a 140 mm baseline
  cv::Mat dR = rig.R * cv::Mat(rig_->R).t(), rvec;
  cv::Rodrigues(dR, rvec);
  EXPECT_LT(cv::norm(rvec) * 180 / CV_PI, 0.05);
}

// After rectification the same corner has the same row in both images: mean |dy| < 0.1 px.
TEST_F(SimulatedCalibration, RectifiedCornersShareRows) {
  CalibrationOptions o;
  o.board.inner_corners = cv::Size(12, 11);
  o.board.square_mm = 30;
  const StereoRig rig = CalibrateFromCorners(*corners_, size_, o);
  double sum = 0;
  std::size_t n = 0;
  for (const auto& c : *corners_) {
    std::vector<cv::Point2f> l, r;
    cv::undistortPoints(c.left_px, l, rig.K1, rig.D1, rig.R1, rig.P1);
    cv::undistortPoints(c.right_px, r, rig.K2, rig.D2, rig.R2, rig.P2);
    for (std::size_t i = 0; i < l.size(); ++i) {
      sum += std::abs(l[i].y - r[i].y);
      ++n;
    }
  }
  EXPECT_LT(sum / double(n), 0.1);
}

// Corners of a board seen by a Bayer camera (CameraModel's defaults: RGGB mosaic, bilinear
// demosaicing, shot and read noise) are refined on the green channel, which demosaicing leaves
// the least wrong (green is sampled at every other pixel, red and blue at one in four). The same
// colour images converted to grey must give clearly worse corners: the zipper of red and blue at
// the squares' edges moves a grey corner. On the full-size lab boards of both renderers green
// cut the error by 19-37 % (README), on these half-size boards by 19 %. The two RMS are each
// known to ~2 % (4 x 2 x 132 corners), so without the green channel their ratio is 1.00 +- 0.03
// and fails the 0.9 asked; with it, 0.81 passes.
TEST(BayerCalibration, CornersAreRefinedOnTheGreenChannel) {
  const SimRig truth = PaperRig(0.5);
  const auto dir = hedgefit::testing::ScratchDir();
  RenderOptions ro;
  ro.supersample = 3;
  ro.blur_sigma_px = 0.5;  // as the lab bench renders its boards
  const CameraModel camera;
  std::vector<std::pair<std::string, std::string>> colour, grey;
  std::vector<BoardScene> boards;
  for (int i = 0; i < 4; ++i) {
    BoardScene b;
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(((i % 2) - 0.5) * 0.4, ((i / 2) - 0.5) * 0.5, 0.1 * (i - 1.5)), R);
    b.rotation = R;
    const double z = 1000 + 150 * i;
    b.translation = cv::Vec3d(((i % 2) - 0.5) * 0.25 * z + 70, ((i / 2) - 0.5) * 0.15 * z, z) - R * cv::Vec3d(165, 150, 0);
    boards.push_back(b);
    for (int view = 0; view < 2; ++view) {
      const cv::Mat image = ApplyCameraModel(RenderBoard(truth, view == 1, b, ro), camera, view == 1, 1 + i);
      cv::Mat g;
      cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
      const std::string stem = (dir / ((view ? "r" : "l") + std::to_string(i))).string();
      ASSERT_TRUE(cv::imwrite(stem + "_colour.png", image) && cv::imwrite(stem + "_grey.png", g));
    }
    const std::string l = (dir / ("l" + std::to_string(i))).string(), r = (dir / ("r" + std::to_string(i))).string();
    colour.emplace_back(l + "_colour.png", r + "_colour.png");
    grey.emplace_back(l + "_grey.png", r + "_grey.png");
  }
  BoardSpec spec;
  spec.inner_corners = cv::Size(12, 11);
  spec.square_mm = 30;
  // RMS distance of the corners found to the board's corners projected through the true rig.
  const auto rms = [&](const std::vector<PairCorners>& found) {
    const std::vector<cv::Point3f> object = BoardCorners(spec);
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < found.size(); ++i) {
      EXPECT_TRUE(found[i].status.empty()) << found[i].left << ": " << found[i].status;
      if (!found[i].status.empty()) continue;
      for (int view = 0; view < 2; ++view) {
        const SimCamera& cam = view ? truth.right : truth.left;
        cv::Matx33d R = boards[i].rotation;
        cv::Vec3d t = boards[i].translation;
        if (view) R = truth.R * R, t = truth.R * t + truth.T;
        cv::Vec3d rvec;
        cv::Rodrigues(R, rvec);
        std::vector<cv::Point2f> want;
        cv::projectPoints(object, rvec, t, cam.K, cam.dist, want);
        const auto& got = view ? found[i].right_px : found[i].left_px;
        // The detector may start from either end of the board (12 x 11 corners: a 180-degree
        // ambiguity): the closer order.
        double same = 0, reversed = 0;
        for (std::size_t k = 0; k < want.size(); ++k) {
          same += cv::norm(got[k] - want[k]) * cv::norm(got[k] - want[k]);
          reversed += cv::norm(got[want.size() - 1 - k] - want[k]) * cv::norm(got[want.size() - 1 - k] - want[k]);
        }
        sum += std::min(same, reversed);
        n += want.size();
      }
    }
    return n ? std::sqrt(sum / double(n)) : 1e9;
  };
  cv::Size size;
  const double on_green = rms(DetectBoards(colour, spec, &size));
  const double on_grey = rms(DetectBoards(grey, spec, &size));
  EXPECT_LT(on_green, 0.9 * on_grey) << "green " << on_green << " px, grey " << on_grey << " px";
}

// A ChArUco board (8 x 6 squares of 60 mm, 45 mm 4x4 markers) in 16 poses, four of them half out of
// the view towards the image corners, where a chessboard is not found at all. Every pair must be
// used, the half-seen ones with only their visible corners, and the rig recovered as well as the
// chessboard's (same tolerances as RecoversTheSimulatedRig: ~0.1 px corner noise).
TEST(CharucoCalibration, PartlySeenBoardsCountAndRecoverTheRig) {
  const SimRig truth = PaperRig(0.5);
  BoardSpec spec;
  spec.type = BoardType::kCharuco;
  spec.inner_corners = cv::Size(7, 5);
  spec.square_mm = 60;
  spec.marker_mm = 45;
  spec.dictionary = "4x4_50";
  const auto dir = hedgefit::testing::ScratchDir();
  RenderOptions ro;
  ro.supersample = 4;
  ro.blur_sigma_px = 0.6;
  std::vector<std::pair<std::string, std::string>> files;
  for (int i = 0; i < 16; ++i) {
    BoardScene b;
    b.squares = cv::Size(8, 6);
    b.square_mm = 60;
    b.margin_mm = 30;
    b.texture = CharucoImage(spec, 60);
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(((i % 4) - 1.5) * 0.2, (((i / 4) % 4) - 1.5) * 0.25, ((i % 3) - 1) * 0.15), R);
    b.rotation = R;
    const double z = 750 + 80 * ((i * 7) % 5);
    // Poses 12..15 put the board's centre at an image corner: about half of it is out of view.
    const double reach = i >= 12 ? 0.62 : 0.18;
    const cv::Vec3d centre((i % 2 ? 1 : -1) * reach * z + 70, ((i / 2) % 2 ? 1 : -1) * reach * 0.62 * z, z);
    b.translation = centre - R * cv::Vec3d(180, 120, 0);
    const std::string l = (dir / ("cl" + std::to_string(i) + ".png")).string();
    const std::string r = (dir / ("cr" + std::to_string(i) + ".png")).string();
    cv::imwrite(l, RenderBoard(truth, false, b, ro));
    cv::imwrite(r, RenderBoard(truth, true, b, ro));
    files.emplace_back(l, r);
  }
  cv::Size size;
  const auto corners = DetectBoards(files, spec, &size);
  int found = 0, partial = 0;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    EXPECT_TRUE(corners[i].status.empty()) << i << ": " << corners[i].status;
    found += corners[i].status.empty();
    partial += corners[i].status.empty() && corners[i].ids.size() < 35;
  }
  EXPECT_EQ(found, 16);
  EXPECT_GE(partial, 4);
  CalibrationOptions o;
  o.board = spec;
  const StereoRig rig = CalibrateFromCorners(corners, size, o);
  EXPECT_LT(rig.rms_stereo_px, 0.2);
  for (const auto& [K, cam] : {std::pair<cv::Mat, SimCamera>{rig.K1, truth.left}, {rig.K2, truth.right}}) {
    EXPECT_NEAR(K.at<double>(0, 0) / cam.K(0, 0), 1.0, 0.003);
    EXPECT_NEAR(K.at<double>(0, 2), cam.K(0, 2), 1.5);
    EXPECT_NEAR(K.at<double>(1, 2), cam.K(1, 2), 1.5);
  }
  EXPECT_NEAR(rig.baseline_mm / cv::norm(truth.T), 1.0, 0.003);
  std::printf("ChArUco: %d of 16 pairs partly seen; stereo RMS %.3f px; fx %+.3f %%, cx %+.2f px, cy %+.2f px (left); "
              "baseline %+.3f mm\n",
              partial, rig.rms_stereo_px, 100 * (rig.K1.at<double>(0, 0) / truth.left.K(0, 0) - 1),
              rig.K1.at<double>(0, 2) - truth.left.K(0, 2), rig.K1.at<double>(1, 2) - truth.left.K(1, 2),
              rig.baseline_mm - cv::norm(truth.T));
}

// OpenCV's own chessboard pairs: stereoCalibrate with default flags reaches 0.44 px;
// hedgefit must reach at least that, and a baseline of 3.34 +- 0.05 squares.
TEST(RealCalibration, OpenCvChessboardPairs) {
  HEDGEFIT_REQUIRE_DATA("calib_chessboard/left01.jpg");
  std::vector<std::pair<std::string, std::string>> pairs;
  for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    char l[64], r[64];
    std::snprintf(l, sizeof(l), "calib_chessboard/left%02d.jpg", i);
    std::snprintf(r, sizeof(r), "calib_chessboard/right%02d.jpg", i);
    pairs.emplace_back(hedgefit::testing::DataPath(l), hedgefit::testing::DataPath(r));
  }
  CalibrationOptions o;  // 9 x 6 inner corners, unit squares
  cv::Size size;
  const auto corners = DetectBoards(pairs, o.board, &size);
  EXPECT_EQ(size, cv::Size(640, 480));
  const StereoRig rig = CalibrateFromCorners(corners, size, o);
  EXPECT_LE(rig.rms_stereo_px, 0.44);
  EXPECT_NEAR(rig.baseline_mm, 3.34, 0.05);
  int used = 0;
  for (const auto& p : rig.pairs) used += p.used;
  EXPECT_GE(used, 10);

  // The rig survives a YAML round trip, readable by plain cv::FileStorage too, whatever the
  // calibration said about a pair it did not use (OpenCV writes most of these unquoted).
  StereoRig with_reports = rig;
  for (const std::string status :
       {"board (9x6 inner corners) not found in left image", "cannot read right image /data/b 1.png",
        "left is 640x480 but right is 120x100", "images are 320x240, the first pair's are 640x480",
        "rejected: RMS 0.912 px > 3.0 x median 0.201 px",
        "ChArUco board: 5 corners seen in both images (left 7, right 6); need 8"}) {
    PairReport rep;
    rep.left = "a.png", rep.right = "b.png", rep.status = status;
    with_reports.pairs.push_back(rep);
  }
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string path = (dir / "rig.yaml").string();
  WriteRig(path, with_reports);
  const StereoRig back = ReadRig(path);
  EXPECT_LT(cv::norm(back.K1 - rig.K1), 1e-9);
  EXPECT_LT(cv::norm(back.T - rig.T), 1e-9);
  // The parameters' covariance travels with the rig: every free parameter has a variance.
  ASSERT_EQ(rig.covariance.rows, kRigParameters);
  EXPECT_LT(cv::norm(back.covariance - rig.covariance), 1e-9 * cv::norm(rig.covariance));
  const std::vector<double> sd = RigStdDevs(back);
  for (int k : {0, 1, 2, 3, 4, 5, 8, 12, 14, 24, 27}) EXPECT_GT(sd[std::size_t(k)], 0) << RigParameterNames()[std::size_t(k)];
  EXPECT_EQ(sd[9], 0);  // k4: not in the default model
  cv::FileStorage fs(path, cv::FileStorage::READ);
  cv::Mat q;
  fs["Q"] >> q;
  EXPECT_EQ(q.rows, 4);
}

TEST(CalibrationErrors, BadInputsAreNamed) {
  HEDGEFIT_REQUIRE_DATA("calib_chessboard/left01.jpg");
  const std::string l = hedgefit::testing::DataPath("calib_chessboard/left01.jpg");
  const std::string r = hedgefit::testing::DataPath("calib_chessboard/right01.jpg");
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string small = (dir / "small.png").string();
  cv::imwrite(small, cv::Mat(100, 120, CV_8UC1, cv::Scalar(128)));
  BoardSpec board;
  cv::Size size;
  const auto c = DetectBoards({{l, r}, {l, "missing.png"}, {l, small}}, board, &size);
  EXPECT_TRUE(c[0].status.empty()) << c[0].status;
  EXPECT_EQ(c[1].status, "cannot read right image missing.png: no such image file; check the path");
  EXPECT_EQ(c[2].status, "left is 640x480 but right is 120x100");
  BoardSpec wrong;
  wrong.inner_corners = cv::Size(8, 5);
  const auto w = DetectBoards({{l, r}}, wrong, &size);
  EXPECT_EQ(w[0].status, "board (8x5 inner corners) not found in left image");
  CalibrationOptions o;
  o.board = wrong;
  try {
    CalibrateFromCorners(w, size, o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "only 0 of 1 pairs are usable (need 3); check --board (inner corners, e.g. 9x6) and the images");
  }
}

}  // namespace
}  // namespace hedgefit::stereo
