// Every capture checks its rig against its own images (stereo.rig_check): the drifted-rig suite
// on a rendered lab capture whose exact rig is known.

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "bench/rig_drift.hpp"
#include "sim/rig_drift.hpp"
#include "sim/single_scene.hpp"
#include "stereo/rectification.hpp"
#include "stereo/rig.hpp"
#include "stereo/row_check.hpp"
#include "tests/test_data.hpp"

namespace {

using hedgefit::sim::RigDrift;

// One full-size lab capture (the paper's rig, a 300 mm sphere 2.3 m away, hedgefit's renderer),
// with its exact rig as rig.yaml.
std::string LabCapture(const std::filesystem::path& dir) {
  hedgefit::sim::SphereScene scene;
  scene.center = {70, 50, 2300};
  scene.radius = 300;
  hedgefit::sim::RenderOptions options;
  options.blur_sigma_px = 0.5;
  hedgefit::sim::WriteSphereCapture(dir.string(), hedgefit::sim::PaperRig(1.0), scene, options,
                                    hedgefit::sim::CameraModel(), false, 1);
  return (dir / "sphere_left.png").string();
}

RigDrift Drift(const std::string& name, void (*set)(RigDrift&)) {
  RigDrift d;
  d.name = name;
  set(d);
  return d;
}

// The rows measured on a pair whose rig is exact are the measurement's own noise: a few
// hundredths of a pixel per cell (the refinement's 9 x 9 windows settle to 0.02-0.05 px), so
// 0.15 px anywhere would be a wrong measurement. A drift that moves the right camera's rows by a
// known amount reads as that amount: a principal point moved 1.5 px down moves every row 1.5 px
// (to within 0.2 px: the rectification rotates the cameras by a little of it too).
TEST(RigCheck, RowsReadZeroOnTheExactRigAndTheDriftWhereItMovesThem) {
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string left = LabCapture(dir);
  const auto rig = hedgefit::stereo::ReadRig((dir / "rig.yaml").string());
  auto rows_of = [&](const hedgefit::stereo::StereoRig& r) {
    cv::Mat l = cv::imread(left), rt = cv::imread((dir / "sphere_right.png").string()), lr, rr;
    hedgefit::stereo::RectifyPair(r, l, rt, &lr, &rr);
    return hedgefit::stereo::MeasureRowsSparse(lr, rr, 57, 640);
  };
  const auto exact = rows_of(rig);
  ASSERT_GE(exact.cells, 20) << "a textured lab scene speaks in most of its 48 cells";
  EXPECT_LT(exact.max_abs_px, 0.15);
  EXPECT_LT(exact.plane_max_px, 0.15);
  const auto moved = rows_of(hedgefit::sim::DriftRig(rig, Drift("cy", [](RigDrift& d) { d.right_cy_px = 1.5; })));
  EXPECT_NEAR(std::abs(moved.plane.offset_px), 1.5, 0.2);
}

// The suite on the capture: the exact rig draws no warning and every result of a drift that
// moves the rows more than 0.5 px apart is inside its (widened) interval or said to be unusable.
// The nominal rig of the issue (f 933.3, c at the centre, 140 mm) and the cameras' files swapped
// put the centre 100-300 mm off: both must be unusable, not widened.
TEST(RigCheck, NoDriftThatMovesTheRowsGivesAResultOutsideItsIntervalUnsaid) {
  const auto dir = hedgefit::testing::ScratchDir();
  hedgefit::bench::DriftOptions o;
  o.lefts = {LabCapture(dir)};
  o.rig = (dir / "rig.yaml").string();
  o.drifts = {Drift("calibrated", [](RigDrift&) {}), Drift("pitch", [](RigDrift& d) { d.pitch_deg = 0.05; }),
              Drift("roll", [](RigDrift& d) { d.roll_deg = 0.1; }),
              Drift("cy", [](RigDrift& d) { d.right_cy_px = 1.0; }),
              Drift("focal", [](RigDrift& d) { d.right_focal = 0.005; }),
              Drift("distortion", [](RigDrift& d) { d.no_distortion = true; }),
              Drift("swapped", [](RigDrift& d) { d.swapped = true; }),
              Drift("nominal", [](RigDrift& d) { d.nominal = true; })};
  const auto rows = hedgefit::bench::RunRigDrift(o);
  ASSERT_EQ(rows.size(), o.drifts.size());
  for (const auto& r : rows) {
    SCOPED_TRACE(r.drift + ": " + r.verdict + " " + r.message);
    if (r.drift == "calibrated") {
      EXPECT_EQ(r.verdict, "ok");
      EXPECT_TRUE(r.inside);
      continue;
    }
    if (r.rows_px > 0.5) {
      EXPECT_TRUE(r.inside || r.said);
    }
    if (r.drift == "swapped" || r.drift == "nominal") {
      EXPECT_TRUE(r.verdict == "unusable" || r.verdict == "refused");
    }
  }
}

}  // namespace

namespace {

// A brick wall as a camera sees it: 58 x 24 px bricks with 3 px mortar, each course offset by
// half a brick, every brick alike (as a procedural texture renders them). Below it, gravel:
// random blobs that repeat nowhere.
cv::Mat WallOverGravel(cv::Size size, int wall_rows) {
  cv::Mat img(size, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < wall_rows; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const int course = y / 24, offset = (course % 2) * 29;
      const bool mortar = y % 24 < 3 || (x + offset) % 58 < 3;
      img.at<unsigned char>(y, x) = mortar ? 200 : 110;
    }
  }
  cv::Mat gravel(size.height - wall_rows, size.width, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(gravel, cv::RNG::UNIFORM, 40, 220);
  cv::GaussianBlur(gravel, gravel, cv::Size(0, 0), 2.0);
  cv::normalize(gravel, gravel, 30, 230, cv::NORM_MINMAX);
  gravel.copyTo(img(cv::Rect(0, wall_rows, size.width, size.height - wall_rows)));
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.7);
  return img;
}

}  // namespace

// A periodic texture tracks to the next brick over as readily as to its match, and the next
// brick over sits on a slightly different row in a real view (perspective): POV-Ray's lab wall
// read rows 1 px apart on its exact rig that way. The pair here is the wall and the gravel 33 px
// apart on every row, the rows exactly agreeing; tracking starts from a hedge's 65 px, nearer the
// wall's next brick (33 + 58 = 91 px) than its match. Every sample kept must be a true match
// (within 1 px of 33: the refinement's and tracking's own spread is a few tenths), and the
// gravel, which repeats nowhere, must still speak.
TEST(RigCheck, APeriodicWallGivesNoSampleAtTheWrongBrick) {
  const cv::Size size(960, 600);
  const cv::Mat left = WallOverGravel(cv::Size(size.width + 33, size.height), 360);
  const cv::Mat l = left(cv::Rect(0, 0, size.width, size.height)).clone();
  const cv::Mat r = left(cv::Rect(33, 0, size.width, size.height)).clone();  // x_right = x_left - 33
  const auto rows = hedgefit::stereo::MeasureRowsSparse(l, r, 65, 320, cv::Mat(), 1200);
  int gravel = 0;
  for (const auto& s : rows.samples) {
    EXPECT_NEAR(-s.dx, 33, 1.0) << "a sample at (" << s.x << ", " << s.y << ") matched " << -s.dx << " px away";
    gravel += s.y > 380;
  }
  EXPECT_GE(gravel, 50) << "the gravel, which repeats nowhere, is measured";
  EXPECT_LT(rows.max_abs_px, 0.15);
}

// The plane through the rows is judged where it was measured and where it is used, not at the
// frame's far corners (POV-Ray's lab at 2.6 m: only the ground spoke, and its plane extrapolated
// to the top corners read 1.05 px on the calibrated rig). A plane of 1.2 px from the top edge to
// the bottom one is 0.2 px over a band measured at y 300-400 (under the 0.5 px tolerance) and
// 0.6 px over a hedge at the top of the frame (over it). Exact arithmetic: 1e-9.
TEST(RigCheck, ThePlaneIsJudgedWhereItWasMeasuredAndOverTheHedge) {
  hedgefit::stereo::RowAgreement rows;
  rows.size = cv::Size(800, 600);
  rows.plane.samples = 50;
  rows.plane.offset_px = 0;
  rows.plane.slope_y_px = 1.2;                    // -0.6 px at the top edge, +0.6 px at the bottom
  rows.spoken = cv::Rect(0, 300, 800, 100);       // the band that was measured: y 300..400
  EXPECT_NEAR(rows.PlaneMaxOver(cv::Rect()), 0.2, 1e-9);                       // at y = 400
  EXPECT_NEAR(rows.PlaneMaxOver(cv::Rect(300, 350, 100, 40)), 0.2, 1e-9);      // a hedge in the band
  EXPECT_NEAR(rows.PlaneMaxOver(cv::Rect(300, 0, 100, 100)), 0.6, 1e-9);       // a hedge at the top
  EXPECT_NEAR(rows.plane.MaxAbs(rows.size), 0.6, 1e-9);  // what the whole frame's corners said before
}

// A stream's rolling check (stereo.rig_check's `rolling`): the first frame measures every cell,
// as one capture alone does; each later frame re-measures a quarter of the cells. On the exact
// rig every frame reads the noise (0.15 px, as above) over as many cells as the full check. When
// the right camera is knocked 3 px down between frames, its rows are 3 px apart wherever they are
// measured again: after the four frames that refresh every cell the pool reads the knock alone
// (within the 0.2 px the rectification's share of it leaves, as above), and from the first frame
// after the knock the worst cell already reads it (over unusable_px, 2 px).
TEST(RigCheck, ARollingCheckReadsTheFrameAndAKnockWithinItsPeriod) {
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string left = LabCapture(dir);
  const auto rig = hedgefit::stereo::ReadRig((dir / "rig.yaml").string());
  const cv::Mat l = cv::imread(left), r = cv::imread((dir / "sphere_right.png").string());
  cv::Mat lr, rr;
  hedgefit::stereo::RectifyPair(rig, l, r, &lr, &rr);
  const auto full = hedgefit::stereo::MeasureRowsSparse(lr, rr, 57, 640, cv::Mat(), 1200);
  hedgefit::stereo::RowPool pool;
  for (int frame = 0; frame < 5; ++frame) {
    const auto rows = hedgefit::stereo::MeasureRowsRolling(lr, rr, 57, 640, 1200, 4, &pool);
    SCOPED_TRACE(frame);
    EXPECT_EQ(rows.cells, full.cells);
    EXPECT_LT(rows.max_abs_px, 0.15);
  }
  const auto knocked = hedgefit::sim::DriftRig(rig, Drift("cy", [](RigDrift& d) { d.right_cy_px = 3.0; }));
  cv::Mat lk, rk;
  hedgefit::stereo::RectifyPair(knocked, l, r, &lk, &rk);
  // The knocked rig's rectification of the same images: the rows read with the calibrated rig's
  // pool, as a stream's frames after a knock would be.
  for (int frame = 0; frame < 4; ++frame) {
    const auto rows = hedgefit::stereo::MeasureRowsRolling(lk, rk, 57, 640, 1200, 4, &pool);
    SCOPED_TRACE(frame);
    EXPECT_GT(rows.max_abs_px, 2.0);
    if (frame == 3) {
      EXPECT_NEAR(std::abs(rows.plane.offset_px), 3.0, 0.2);
    }
  }
}

namespace {

// A rectified pair that is flat grey but for `boxes` of random texture shifted 40 px between the
// views (a hedge at one depth): a garden of smooth lawn and sky, as far as the corners go.
std::pair<cv::Mat, cv::Mat> TexturedBoxes(const std::vector<cv::Rect>& boxes) {
  cv::Mat left(400, 640, CV_8UC1, cv::Scalar(128)), right = left.clone();
  cv::RNG rng(5);
  for (const cv::Rect& b : boxes) {
    cv::Mat tex(b.size(), CV_8UC1);
    rng.fill(tex, cv::RNG::UNIFORM, 0, 255);
    cv::GaussianBlur(tex, tex, cv::Size(3, 3), 0.8);
    tex.copyTo(left(b));
    tex.copyTo(right(b - cv::Point(40, 0)));
  }
  return {left, right};
}

const hedgefit::pipeline::OptionValue* Field(const hedgefit::pipeline::InputCheck& c, const std::string& key) {
  for (const auto& [k, v] : c.fields) {
    if (k == key) return &v;
  }
  return nullptr;
}

}  // namespace

// A capture whose frame has too little texture for the check (one textured box: one or two of
// the 48 cells) is "unchecked", with the reason in the hedge's fields, even when the hedge's own
// rows agree: they cannot show a roll or a focal length that does not fit away from the hedge.
// The same hedge in a frame textured all over is "ok", so the verdict comes from the frame's
// texture, not from the hedge.
TEST(RigCheck, AFrameWithTooLittleTextureIsUncheckedAndSaysWhy) {
  hedgefit::stereo::StereoRig rig;
  rig.P1 = (cv::Mat_<double>(3, 4) << 500, 0, 320, 0, 0, 500, 200, 0, 0, 0, 1, 0);
  hedgefit::stereo::HedgeMatch hedge;
  hedge.id = 1;
  hedge.pixels = hedge.measured = 80 * 80;
  hedge.vertical.samples = 40;  // the refinement measured the hedge's rows: 0.03 px apart
  hedge.vertical_max_px = 0.03;
  cv::Mat labels(400, 640, CV_32S, cv::Scalar(0));
  labels(cv::Rect(300, 160, 80, 80)).setTo(1);
  const hedgefit::stereo::RigCheckOptions options;
  const auto [bl, br] = TexturedBoxes({cv::Rect(300, 160, 80, 80)});
  const auto smooth = hedgefit::stereo::CheckCaptureRig(bl, br, rig, {hedge}, labels, cv::Mat(), 40, options);
  ASSERT_LT(smooth.rows.cells, 3) << "the test needs a frame the check cannot measure";
  EXPECT_EQ(smooth.verdict, "unchecked");
  const auto& check = smooth.checks.at(1);
  const auto* verdict = Field(check, "rig_check");
  ASSERT_NE(verdict, nullptr);
  EXPECT_EQ(std::get<std::string>(*verdict), "unchecked");
  const auto* reason = Field(check, "rig_check_reason");
  ASSERT_NE(reason, nullptr);
  EXPECT_NE(std::get<std::string>(*reason).find("too few textured places"), std::string::npos);
  EXPECT_TRUE(check.unusable.empty()) << "nothing showed the rig wrong: unchecked, not unusable";

  const auto [fl, fr] = TexturedBoxes({cv::Rect(40, 0, 600, 400)});
  const auto textured = hedgefit::stereo::CheckCaptureRig(fl, fr, rig, {hedge}, labels, cv::Mat(), 40, options);
  ASSERT_GE(textured.rows.cells, 3);
  EXPECT_EQ(textured.verdict, "ok");
  EXPECT_EQ(Field(textured.checks.at(1), "rig_check_reason"), nullptr);
}

// A hedge of which too few pixels matched is unusable either way, but the reason depends on the
// frame: where the frame's rows were measured and agree, the rig fits and the views are a pair,
// so the reason names the hedge's own surface (glossy leaves) and not the rig; where they were
// not measured, the rig stays among the causes.
TEST(RigCheck, AHedgeThatBarelyMatchedBlamesTheRigOnlyWhenTheRowsCouldNotSay) {
  hedgefit::stereo::StereoRig rig;
  rig.P1 = (cv::Mat_<double>(3, 4) << 500, 0, 320, 0, 0, 500, 200, 0, 0, 0, 1, 0);
  hedgefit::stereo::HedgeMatch hedge;
  hedge.id = 1;
  hedge.pixels = 80 * 80;
  hedge.measured = 80 * 80 * 3 / 10;  // 30 %, under the 40 % asked for
  hedge.vertical.samples = 40;
  hedge.vertical_max_px = 0.03;
  cv::Mat labels(400, 640, CV_32S, cv::Scalar(0));
  labels(cv::Rect(300, 160, 80, 80)).setTo(1);
  const hedgefit::stereo::RigCheckOptions options;
  ASSERT_GT(options.min_matched_share, 0.3);
  const auto [fl, fr] = TexturedBoxes({cv::Rect(40, 0, 600, 400)});
  const auto textured = hedgefit::stereo::CheckCaptureRig(fl, fr, rig, {hedge}, labels, cv::Mat(), 40, options);
  ASSERT_GE(textured.rows.cells, 3) << "the test needs a frame the check can measure";
  EXPECT_EQ(textured.verdict, "unusable");
  const std::string& fits = textured.checks.at(1).unusable;
  EXPECT_NE(fits.find("so the rig fits"), std::string::npos) << fits;
  EXPECT_NE(fits.find("glossy leaves"), std::string::npos) << fits;
  EXPECT_EQ(fits.find("does not fit"), std::string::npos) << fits;

  const auto [bl, br] = TexturedBoxes({cv::Rect(300, 160, 80, 80)});
  const auto smooth = hedgefit::stereo::CheckCaptureRig(bl, br, rig, {hedge}, labels, cv::Mat(), 40, options);
  ASSERT_LT(smooth.rows.cells, 3);
  EXPECT_EQ(smooth.verdict, "unusable");
  EXPECT_NE(smooth.checks.at(1).unusable.find("the rig does not fit these cameras"), std::string::npos)
      << smooth.checks.at(1).unusable;
}

// The twin test's correlation (internal::CorrCoeffNormed) against the definition, summed in
// double: the template's and each window's means taken out, the products over the root of both
// sums of squares. The direct sums are exact in float for a 15 x 15 template of 8-bit values, so
// only the result's rounding to float remains (|r| <= 1: under 1e-7; 1e-6 allows for the double
// arithmetic of both sides). OpenCV's own TM_CCOEFF_NORMED, through a DFT, agrees only to a few
// thousandths on such strips, so it is held to 0.01 here: the guards for flat windows are its.
TEST(RigCheck, TheTwinTestsCorrelationIsTheNormedCoefficientExactly) {
  cv::RNG rng(7);
  cv::Mat texture(120, 200, CV_8U);
  rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.5);  // leaves' scale of texture, not white noise
  texture(cv::Rect(150, 80, 40, 30)).setTo(90);              // a flat patch: windows with no variance
  int compared = 0, flat_windows = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int x = rng.uniform(0, 200 - 95), y = rng.uniform(0, 120 - 17);
    const cv::Mat strip = texture(cv::Rect(x, y, 95, 17));
    cv::Mat tpl = texture(cv::Rect(rng.uniform(0, 200 - 15), rng.uniform(0, 120 - 15), 15, 15)).clone();
    if (trial == 0) tpl = cv::Mat(15, 15, CV_8U, cv::Scalar(128));  // a flat template: 1 everywhere
    const cv::Mat got = hedgefit::stereo::internal::CorrCoeffNormed(strip, tpl);
    cv::Mat opencv;
    cv::matchTemplate(strip, tpl, opencv, cv::TM_CCOEFF_NORMED);
    ASSERT_EQ(got.size(), opencv.size());
    ASSERT_EQ(got.type(), CV_32F);
    cv::Mat t;
    tpl.convertTo(t, CV_64F);
    t -= cv::mean(t)[0];
    const double tt = t.dot(t);
    for (int r = 0; r < got.rows; ++r) {
      for (int c = 0; c < got.cols; ++c) {
        cv::Mat w;
        strip(cv::Rect(c, r, tpl.cols, tpl.rows)).convertTo(w, CV_64F);
        w -= cv::mean(w)[0];
        const double ww = w.dot(w);
        double expected = 0;
        if (tt == 0) {
          expected = 1;
        } else if (ww == 0) {
          expected = 0;
          ++flat_windows;
        } else {
          expected = t.dot(w) / std::sqrt(tt * ww);
        }
        ASSERT_NEAR(got.at<float>(r, c), expected, 1e-6) << "trial " << trial << " at " << r << ", " << c;
        ASSERT_NEAR(got.at<float>(r, c), opencv.at<float>(r, c), 0.01) << "trial " << trial << " at " << r << ", " << c;
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 60 * 3 * 81);
  EXPECT_GT(flat_windows, 0) << "the flat patch was not reached: the guard is untested";
}
