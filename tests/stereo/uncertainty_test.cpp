// Calibration uncertainty where the truth is known: board corners projected through the
// simulated paper rig with Gaussian noise of known size, calibrated again and again, one noise
// draw per repetition (seeds 1000..1029). The covariance hedgefit states must match the spread
// the repetitions show, and the sphere intervals built on it must hold the truth about 95 %
// of the time without being wide.

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include <cmath>

#include "fitting/geometric_fit.hpp"
#include "fitting/uncertainty.hpp"
#include "stereo/calibration.hpp"
#include "stereo/rig_uncertainty.hpp"
#include "sim/simulator.hpp"

namespace hedgefit::stereo {
using namespace hedgefit::sim;  // the test data's renderer
namespace {

constexpr int kTrials = 30;
constexpr double kCornerNoisePx = 0.1;  // about what the rendered lab boards give (0.05-0.1 px RMS)

// 14 board poses 0.9-1.5 m away, tilted and spread over the view (as the calibration test's).
std::vector<std::pair<cv::Vec3d, cv::Vec3d>> BoardPoses() {
  std::vector<std::pair<cv::Vec3d, cv::Vec3d>> poses;
  for (int i = 0; i < 14; ++i) {
    const cv::Vec3d rvec(((i % 4) - 1.5) * 0.25, (((i / 4) % 4) - 1.5) * 0.3, ((i % 3) - 1) * 0.15);
    cv::Matx33d R;
    cv::Rodrigues(rvec, R);
    const double z = 900 + 150 * ((i * 7) % 5);
    const cv::Vec3d centre((i % 4 - 1.5) * 0.2 * z + 70, ((i / 4) % 4 - 1.5) * 0.14 * z, z);
    poses.emplace_back(rvec, centre - R * cv::Vec3d(165, 150, 0));
  }
  return poses;
}

struct Trial {
  StereoRig rig;
  cv::Vec<double, kRigParameters> theta;
};

class RepeatedCalibration : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new SimRig(PaperRig(0.5));
    trials_ = new std::vector<Trial>();
    BoardSpec spec;
    spec.inner_corners = cv::Size(12, 11);
    spec.square_mm = 30;
    const std::vector<cv::Point3f> board = BoardCorners(spec);
    CalibrationOptions o;
    o.board = spec;
    o.reject_factor = 0;  // every pair, every time: the spread is the noise's alone
    const auto poses = BoardPoses();
    for (int t = 0; t < kTrials; ++t) {
      cv::RNG rng(1000 + t);
      std::vector<PairCorners> pairs;
      for (const auto& [rvec, tvec] : poses) {
        PairCorners pc;
        cv::projectPoints(board, rvec, tvec, truth_->left.K, truth_->left.dist, pc.left_px);
        cv::Matx33d Rb;
        cv::Rodrigues(rvec, Rb);
        cv::Vec3d rr;
        cv::Rodrigues(truth_->R * Rb, rr);
        cv::projectPoints(board, rr, truth_->R * tvec + truth_->T, truth_->right.K, truth_->right.dist, pc.right_px);
        for (auto* v : {&pc.left_px, &pc.right_px}) {
          for (auto& p : *v) p += cv::Point2f(float(rng.gaussian(kCornerNoisePx)), float(rng.gaussian(kCornerNoisePx)));
        }
        pairs.push_back(pc);
      }
      Trial tr;
      tr.rig = CalibrateFromCorners(pairs, truth_->left.size, o);
      tr.theta = RigParameters(tr.rig);
      trials_->push_back(tr);
    }
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete trials_;
  }
  static SimRig* truth_;
  static std::vector<Trial>* trials_;
};
SimRig* RepeatedCalibration::truth_ = nullptr;
std::vector<Trial>* RepeatedCalibration::trials_ = nullptr;

// The stated standard deviation of each parameter against the spread over the repetitions.
// With 30 repetitions a sample standard deviation is within 13 % (one standard error,
// 1/sqrt(2 x 29)) of the true one, so the ratio must lie within three of those: 0.6..1.45.
TEST_F(RepeatedCalibration, StatedDeviationsMatchTheSpread) {
  const auto& names = RigParameterNames();
  int checked = 0;
  for (int k = 0; k < kRigParameters; ++k) {
    double mean = 0, stated = 0;
    for (const auto& t : *trials_) {
      mean += t.theta[k];
      stated += RigStdDevs(t.rig)[std::size_t(k)];
    }
    mean /= kTrials;
    stated /= kTrials;
    if (stated == 0) continue;  // held fixed by the model (k4..k6)
    double var = 0;
    for (const auto& t : *trials_) var += (t.theta[k] - mean) * (t.theta[k] - mean);
    const double spread = std::sqrt(var / (kTrials - 1));
    EXPECT_GT(stated / spread, 0.6) << names[std::size_t(k)] << ": stated " << stated << ", spread " << spread;
    EXPECT_LT(stated / spread, 1.45) << names[std::size_t(k)] << ": stated " << stated << ", spread " << spread;
    ++checked;
  }
  EXPECT_EQ(checked, 2 * 9 + 6);
}

// The truth lies within 1.96 stated standard deviations of the calibrated value about 95 % of
// the time. 30 x 24 cases, correlated within a repetition: accept 88-99 %.
TEST_F(RepeatedCalibration, TruthWithinTheStatedIntervals) {
  StereoRig truth_rig = RigFromSimulation(*truth_);
  const auto truth = RigParameters(truth_rig);
  int inside = 0, cases = 0;
  for (const auto& t : *trials_) {
    const auto sd = RigStdDevs(t.rig);
    for (int k = 0; k < kRigParameters; ++k) {
      if (sd[std::size_t(k)] == 0) continue;
      ++cases;
      inside += std::abs(t.theta[k] - truth[k]) <= 1.96 * sd[std::size_t(k)];
    }
  }
  const double share = double(inside) / cases;
  EXPECT_GT(share, 0.88) << inside << " of " << cases;
  EXPECT_LT(share, 0.99) << inside << " of " << cases;
}

// A hedge of radius 300 mm at 2.3 m, measured through each calibrated rig: the pixels the true
// rig sees, triangulated with the calibrated one, plus 1 mm of independent point noise (the
// matcher's). Its 95 % intervals (points and rig) must hold the true centre and radius in about
// 95 % of the 120 (repetition, coordinate) cases, and the stated standard error must not exceed
// 1.5 times the errors' actual RMS (the issue allows intervals up to 3 times the spread).
TEST_F(RepeatedCalibration, SphereIntervalsHoldTheTruth) {
  const StereoRig truth_rig = RigFromSimulation(*truth_);
  const Eigen::Vector3d centre(50, -30, 2300);
  const double radius = 300;
  // The cap the left camera sees: directions within 70 degrees of the camera.
  std::vector<Eigen::Vector3d> surface;
  cv::RNG rng(7);
  while (surface.size() < 6000) {
    Eigen::Vector3d d(rng.gaussian(1), rng.gaussian(1), rng.gaussian(1));
    d.normalize();
    if (d.dot(-centre.normalized()) > std::cos(70 * CV_PI / 180)) surface.push_back(centre + radius * d);
  }
  int inside = 0, cases = 0;
  double stated2 = 0, error2 = 0;
  for (std::size_t t = 0; t < trials_->size(); ++t) {
    const StereoRig& rig = (*trials_)[t].rig;
    std::vector<Eigen::Vector3d> measured;
    Retriangulate(truth_rig, rig, surface, &measured);
    cv::RNG noise(50 + t);
    for (auto& p : measured) p += Eigen::Vector3d(noise.gaussian(1.0), noise.gaussian(1.0), noise.gaussian(1.0));
    fitting::SphereFitResult f = fitting::FitSphereGeometric(measured);
    ASSERT_TRUE(f.converged);
    const cloud::PointPerturbation perturbation = RigPerturbation(rig, 32, 1);
    fitting::AddUncertainty(measured, &perturbation, &f);
    ASSERT_TRUE(f.rig_std_error_mm.has_value());
    const Eigen::Vector4d total = *fitting::TotalStdError(f);
    const Eigen::Vector4d error(f.sphere.center_mm.x() - centre.x(), f.sphere.center_mm.y() - centre.y(),
                                f.sphere.center_mm.z() - centre.z(), f.sphere.radius_mm - radius);
    for (int k = 0; k < 4; ++k) {
      ++cases;
      inside += std::abs(error[k]) <= 1.96 * total[k];
      stated2 += total[k] * total[k];
      error2 += error[k] * error[k];
    }
  }
  const double share = double(inside) / cases;
  std::printf("sphere: truth inside the 95 %% interval in %d of %d cases; stated standard error %.2f mm RMS, actual "
              "error %.2f mm RMS\n",
              inside, cases, std::sqrt(stated2 / cases), std::sqrt(error2 / cases));
  EXPECT_GT(share, 0.88) << inside << " of " << cases;
  EXPECT_LT(std::sqrt(stated2 / error2), 1.5) << "stated RMS " << std::sqrt(stated2 / cases) << " mm, actual "
                                              << std::sqrt(error2 / cases) << " mm";
}

// Rigs drawn from a calibration's covariance reproduce it, correlations included (2000 draws:
// a correlation's standard error is under 0.025, a standard deviation's under 2 %), and the
// drawing leaves the calibrated rig as it was.
TEST_F(RepeatedCalibration, SampledRigsReproduceTheCovariance) {
  const StereoRig& rig = (*trials_)[0].rig;
  const cv::Mat R_before = rig.R.clone();
  const std::vector<StereoRig> samples = SampleRigs(rig, 2000, 3);
  EXPECT_EQ(cv::norm(rig.R - R_before), 0.0);
  std::vector<cv::Vec<double, kRigParameters>> theta;
  for (const auto& r : samples) theta.push_back(RigParameters(r));
  const cv::Mat& C = rig.covariance;
  // focal lengths, principal points against the rotation, baseline: what moves a hedge.
  for (auto [a, b] : std::vector<std::pair<int, int>>{{0, 12}, {2, 25}, {14, 25}, {3, 24}, {2, 14}, {0, 27}}) {
    double ma = 0, mb = 0;
    for (const auto& t : theta) {
      ma += t[a];
      mb += t[b];
    }
    ma /= double(theta.size());
    mb /= double(theta.size());
    double sab = 0, saa = 0, sbb = 0;
    for (const auto& t : theta) {
      sab += (t[a] - ma) * (t[b] - mb);
      saa += (t[a] - ma) * (t[a] - ma);
      sbb += (t[b] - mb) * (t[b] - mb);
    }
    const double stated = C.at<double>(a, b) / std::sqrt(C.at<double>(a, a) * C.at<double>(b, b));
    EXPECT_NEAR(sab / std::sqrt(saa * sbb), stated, 0.1) << a << ", " << b;
    EXPECT_NEAR(std::sqrt(saa / double(theta.size())) / std::sqrt(C.at<double>(a, a)), 1.0, 0.06) << a;
  }
}

// Errors that neighbouring points share: a cap of a 300 mm sphere at 2.3 m with 1 mm of
// independent noise, plus a radial offset shared by all points of a patch (60 random patches,
// N(0, 2 mm) each), as a matcher's windows and smoothing make. The independent-noise formula
// counts 4000 independent points where there are about 60 independent patches, and misses. The
// jackknife's 16 groups leave it 15 degrees of freedom, for which +-1.96 estimated deviations
// hold 93 %; the shares of 160 cases (correlated within a repetition) scatter by about 3 %, so
// it must hold the truth in at least 80 %, where the formula alone holds it in under 60 %.
TEST(BlockJackknife, CountsErrorsNeighboursShare) {
  const Eigen::Vector3d centre(50, -30, 2300);
  const double radius = 300;
  const Eigen::Vector3d axis = -centre.normalized();
  auto on_cap = [&](cv::RNG& rng) {
    for (;;) {
      Eigen::Vector3d d(rng.gaussian(1), rng.gaussian(1), rng.gaussian(1));
      d.normalize();
      if (d.dot(axis) >= std::cos(70 * CV_PI / 180)) return d;
    }
  };
  int inside_jack = 0, inside_scatter = 0, cases = 0;
  for (int t = 0; t < 40; ++t) {
    cv::RNG rng(300 + t);
    std::vector<Eigen::Vector3d> cells;
    std::vector<double> offsets;
    for (int c = 0; c < 60; ++c) {
      cells.push_back(on_cap(rng));
      offsets.push_back(rng.gaussian(2.0));
    }
    std::vector<Eigen::Vector3d> pts;
    while (pts.size() < 4000) {
      const Eigen::Vector3d d = on_cap(rng);
      std::size_t nearest = 0;
      for (std::size_t c = 1; c < cells.size(); ++c) {
        if (d.dot(cells[c]) > d.dot(cells[nearest])) nearest = c;
      }
      pts.push_back(centre + (radius + offsets[nearest] + rng.gaussian(1.0)) * d);
    }
    const fitting::SphereFitResult f = fitting::FitSphereGeometric(pts);
    ASSERT_TRUE(f.converged && f.std_error_mm);
    const auto jack = fitting::BlockJackknifeStdError(fitting::SupportingPoints(pts, f.sphere), f.sphere);
    ASSERT_TRUE(jack.has_value());
    const Eigen::Vector4d error(f.sphere.center_mm.x() - centre.x(), f.sphere.center_mm.y() - centre.y(),
                                f.sphere.center_mm.z() - centre.z(), f.sphere.radius_mm - radius);
    for (int k = 0; k < 4; ++k) {
      ++cases;
      inside_jack += std::abs(error[k]) <= 1.96 * std::max((*jack)[k], (*f.std_error_mm)[k]);
      inside_scatter += std::abs(error[k]) <= 1.96 * (*f.std_error_mm)[k];
    }
  }
  std::printf("block jackknife: %d of %d inside; independent-noise formula: %d of %d\n", inside_jack, cases,
              inside_scatter, cases);
  EXPECT_GE(inside_jack, 0.80 * cases);
  EXPECT_LT(inside_scatter, 0.6 * cases);
}

// A 16-laser scanner at the origin (lasers 2 degrees apart from -15 degrees up, a point every
// 0.2 degrees over the 40 degrees about azimuth `az0`) scanning a ball: each laser's own range
// offset (6 mm, the spread of a Velodyne's per-laser calibration) moves its whole ring, beside
// 5 mm of noise per point.
std::vector<Eigen::Vector3d> ScanBallByRings(cv::RNG& rng, const Eigen::Vector3d& centre, double radius, double az0) {
  std::vector<Eigen::Vector3d> pts;
  for (int ring = 0; ring < 16; ++ring) {
    const double el = (-15 + 2 * ring) * CV_PI / 180, offset = rng.gaussian(6.0);
    for (double az_deg = -20; az_deg <= 20; az_deg += 0.2) {
      const double az = az0 + az_deg * CV_PI / 180;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      // The ray's first meeting with the sphere, if any.
      const double b = d.dot(centre), disc = b * b - (centre.squaredNorm() - radius * radius);
      if (disc <= 0) continue;
      pts.push_back((b - std::sqrt(disc) + offset + rng.gaussian(5.0)) * d);
    }
  }
  return pts;
}

// A ball 2.6 m from a 16-laser scanner (lasers 2 degrees apart, a point every 0.2 degrees): each
// laser's own range offset (6 mm, the spread of a Velodyne's per-laser calibration) moves its
// whole ring, beside 5 mm of noise per point. The ball holds six or seven rings, so their offsets
// weigh on the centre's range and height as six or seven errors, not as its several hundred
// points'. The patches of BlockJackknifeStdError cut across the rings and count them as
// independent; a jackknife over horizontal bands removes a ring (or most of one) at a time. Over
// 400 such balls the fit's own and the patches' 95 % intervals held the range 72 % and the height
// 65 % of the time, with the bands 92 and 89 % (8 groups: Student's t with 7 degrees of freedom
// puts 1.96 at about 91 %). Here, 40 balls: at least 88 % of all 160 coordinates with the
// bands; the range and height without them at most 80 %.
TEST(BandJackknife, AScannersRingsAreCounted) {
  const Eigen::Vector3d centre(2600, 400, -200);
  const double radius = 300;
  int inside_bands = 0, cases = 0, ring_cases = 0, ring_inside_before = 0;
  for (int t = 0; t < 40; ++t) {
    cv::RNG rng(500 + t);
    const std::vector<Eigen::Vector3d> pts = ScanBallByRings(rng, centre, radius, 0.0);
    const fitting::SphereFitResult f = fitting::FitSphereGeometric(pts);
    ASSERT_TRUE(f.converged && f.std_error_mm);
    const auto support = fitting::SupportingPoints(pts, f.sphere);
    const auto patches = fitting::BlockJackknifeStdError(support, f.sphere);
    const auto bands = fitting::BandJackknifeStdError(support, f.sphere, Eigen::Vector3d::UnitZ());
    ASSERT_TRUE(patches.has_value() && bands.has_value());
    const Eigen::Vector4d error(f.sphere.center_mm.x() - centre.x(), f.sphere.center_mm.y() - centre.y(),
                                f.sphere.center_mm.z() - centre.z(), f.sphere.radius_mm - radius);
    for (int k = 0; k < 4; ++k) {
      const double before = std::max((*patches)[k], (*f.std_error_mm)[k]);
      ++cases;
      inside_bands += std::abs(error[k]) <= 1.96 * std::max(before, (*bands)[k]);
      if (k == 0 || k == 2) ++ring_cases, ring_inside_before += std::abs(error[k]) <= 1.96 * before;
    }
  }
  std::printf("with the bands: %d of %d inside; the range and height without them: %d of %d\n", inside_bands, cases,
              ring_inside_before, ring_cases);
  EXPECT_GE(inside_bands, 0.88 * cases);
  EXPECT_LE(ring_inside_before, 0.80 * ring_cases);
}

// The same scanner and balls, now at 1.8-3.2 m and turned about the scanner, so that a ball holds
// 5 to 10 rings of unequal counts (few points at its top and bottom). A jackknife over the rings
// themselves, found from the points' elevations about the scanner, deletes one laser's offset at
// a time; with Student's t for its few degrees of freedom its 95 % intervals should hold about
// 95 % of coordinates. Equal-count bands cut the rings across. Over 300 balls: at least 93.1 % of
// the 1200 coordinates inside the rings' intervals (95 % less 3 standard errors of a share of
// 1200), and more than inside the bands'. Here 96.7 % with Student's t, 92.3 % with 1.96 (the
// t is what passes), 91.4 % with the bands. A camera's cloud (elevations spread evenly) has no rings.
TEST(RingJackknife, AScannersOwnRingsAreTheGroups) {
  const double radius = 300;
  int inside_rings = 0, inside_bands = 0, cases = 0;
  for (int t = 0; t < 300; ++t) {
    cv::RNG rng(900 + t);
    const double range = rng.uniform(1800.0, 3200.0), az0 = rng.uniform(-CV_PI, CV_PI);
    const Eigen::Vector3d centre(range * std::cos(az0), range * std::sin(az0), rng.uniform(-400.0, 100.0));
    const std::vector<Eigen::Vector3d> pts = ScanBallByRings(rng, centre, radius, az0);
    const fitting::SphereFitResult f = fitting::FitSphereGeometric(pts);
    ASSERT_TRUE(f.converged && f.std_error_mm);
    const auto support = fitting::SupportingPoints(pts, f.sphere);
    const auto rings =
        fitting::RingJackknifeStdError(support, f.sphere, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
    const auto bands = fitting::BandJackknifeStdError(support, f.sphere, Eigen::Vector3d::UnitZ());
    ASSERT_TRUE(rings.has_value() && bands.has_value()) << "ball " << t;
    const Eigen::Vector4d error(f.sphere.center_mm.x() - centre.x(), f.sphere.center_mm.y() - centre.y(),
                                f.sphere.center_mm.z() - centre.z(), f.sphere.radius_mm - radius);
    for (int k = 0; k < 4; ++k) {
      ++cases;
      inside_rings += std::abs(error[k]) <= 1.96 * std::max((*rings)[k], (*f.std_error_mm)[k]);
      inside_bands += std::abs(error[k]) <= 1.96 * std::max((*bands)[k], (*f.std_error_mm)[k]);
    }
    if (t == 0) {
      // Seen from a camera 2 m off the scanner's axis the same points hold no rings.
      EXPECT_FALSE(fitting::RingJackknifeStdError(support, f.sphere, Eigen::Vector3d(0, 2000, 1500),
                                                  Eigen::Vector3d::UnitZ())
                       .has_value());
    }
  }
  std::printf("with the rings: %d of %d inside; with the bands: %d of %d\n", inside_rings, cases, inside_bands, cases);
  EXPECT_GE(inside_rings, 0.931 * cases);
  EXPECT_GT(inside_rings, inside_bands);
}

// Student's t quantiles: the table's ends and the series beyond it.
TEST(RingJackknife, StudentsQuantiles) {
  EXPECT_NEAR(fitting::StudentT95(1), 12.706, 1e-3);
  EXPECT_NEAR(fitting::StudentT95(6), 2.447, 1e-3);
  EXPECT_NEAR(fitting::StudentT95(30), 2.042, 1e-3);
  EXPECT_NEAR(fitting::StudentT95(40), 2.021, 2e-3);   // tables: 2.021
  EXPECT_NEAR(fitting::StudentT95(120), 1.980, 2e-3);  // tables: 1.980
  EXPECT_TRUE(std::isinf(fitting::StudentT95(0)));
}

// A ball on a lawn: RANSAC's sphere rests on a tenth of the cloud. The points that support it
// are the ball's, not a band around the lawn's median residual, so its standard errors are the
// ball's (a few tenths of a mm for 2000 points with 2 mm of noise), not metres.
TEST(SupportingPoints, AMajorityOfOtherPointsDoesNotCount) {
  const Eigen::Vector3d centre(100, 300, 2500);
  const double radius = 500;
  cv::RNG rng(7);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 2000; ++i) {
    Eigen::Vector3d d(rng.gaussian(1), rng.gaussian(1), -std::abs(rng.gaussian(1)));
    d.normalize();
    pts.push_back(centre + (radius + rng.gaussian(2.0)) * d);
  }
  const std::size_t ball = pts.size();
  for (int i = 0; i < 18000; ++i) {  // the lawn: a plane 800 mm below the centre, 4 m x 4 m
    pts.emplace_back(rng.uniform(-2000.0, 2000.0), centre.y() + 800 + rng.gaussian(2.0), rng.uniform(1500.0, 5500.0));
  }
  const fitting::Sphere truth{centre, radius};
  const std::vector<Eigen::Vector3d> support = fitting::SupportingPoints(pts, truth);
  // The ball's points within 3 sigma (99.7 %), and no lawn point but those that happen to lie
  // within the window of the surface (the lawn passes 300 mm below the ball's foot: none).
  EXPECT_GE(support.size(), std::size_t(0.99 * double(ball)));
  EXPECT_LE(support.size(), ball);
  const auto jack = fitting::BlockJackknifeStdError(support, truth);
  ASSERT_TRUE(jack.has_value());
  for (int k = 0; k < 4; ++k) EXPECT_LT((*jack)[k], 2.0) << k;
}

// A sphere whose radius' 95 % interval is wider than the radius itself is not pinned by its
// points, however small its residuals (RANSAC's pick of 205 points of PCL's lamppost: r 4.2 m +-
// 55 km): the fit says so (not_a_ball). The same points with a method's own standard error of a
// few mm are a ball. The points lie on the sphere (2 mm of noise), so only the interval decides.
TEST(AddUncertainty, ARadiusThePointsDoNotPinIsNoBall) {
  cv::RNG rng(11);
  const fitting::Sphere sphere{{0, 0, 5000}, 2000};
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 400; ++i) {
    Eigen::Vector3d d(rng.gaussian(1), rng.gaussian(1), -std::abs(rng.gaussian(1)));
    pts.push_back(sphere.center_mm + (sphere.radius_mm + rng.gaussian(2.0)) * d.normalized());
  }
  for (const double se_r : {1100.0, 3.0}) {  // 1.96 x 1100 > 2000 > 1.96 x 3
    fitting::SphereFitResult f;
    f.converged = true;
    f.sphere = sphere;
    f.std_error_mm = Eigen::Vector4d(3, 3, 3, se_r);
    f.std_error_own = true;  // the method's own: no jackknife over it
    fitting::AddUncertainty(pts, nullptr, &f);
    ASSERT_EQ(f.not_a_ball.has_value(), se_r > 1000) << se_r;
    if (f.not_a_ball) {
      EXPECT_NE(f.not_a_ball->find("do not pin a sphere"), std::string::npos) << *f.not_a_ball;
    }
  }
}

// With the rig it came from, re-triangulation gives the points back.
TEST(Retriangulate, NominalRigReturnsThePoints) {
  const StereoRig rig = RigFromSimulation(PaperRig(0.5));
  const std::vector<Eigen::Vector3d> in = {{0, 0, 2000}, {-400, 250, 1500}, {300, -200, 3000}};
  std::vector<Eigen::Vector3d> out;
  Retriangulate(rig, rig, in, &out);
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) EXPECT_LT((out[i] - in[i]).norm(), 1e-3) << i;  // mm
}

}  // namespace
}  // namespace hedgefit::stereo
