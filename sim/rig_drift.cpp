#include "sim/rig_drift.hpp"

#include <opencv2/calib3d.hpp>

#include <cmath>

namespace hedgefit::sim {

namespace {

cv::Mat Rotation(double rx_deg, double ry_deg, double rz_deg) {
  const double k = CV_PI / 180;
  cv::Mat r;
  cv::Rodrigues(cv::Vec3d(rx_deg * k, ry_deg * k, rz_deg * k), r);
  return r;
}

}  // namespace

stereo::StereoRig DriftRig(const stereo::StereoRig& in, const RigDrift& d) {
  if (d.nominal) {
    const double f = in.K1.at<double>(0, 0);
    return stereo::RigForRectifiedPair(in.image_size, f, 0.5 * in.image_size.width, 0.5 * in.image_size.height,
                                       in.baseline_mm);
  }
  stereo::StereoRig r;
  r.image_size = in.image_size;
  r.K1 = in.K1.clone(), r.K2 = in.K2.clone(), r.D1 = in.D1.clone(), r.D2 = in.D2.clone();
  r.R = in.R.clone(), r.T = in.T.clone();
  if (d.swapped) std::swap(r.K1, r.K2), std::swap(r.D1, r.D2);
  if (d.no_distortion) r.D1 = cv::Mat::zeros(r.D1.size(), CV_64F), r.D2 = cv::Mat::zeros(r.D2.size(), CV_64F);
  r.D1 *= d.distortion_scale;
  r.D2 *= d.distortion_scale;
  // x_right = R x_left + T: turning the right camera by Q makes it x_right' = Q (R x_left + T).
  const cv::Mat q = Rotation(d.pitch_deg, d.yaw_deg, d.roll_deg);
  r.R = q * r.R;
  r.T = q * r.T;
  r.T.at<double>(1) += d.ty_mm;
  r.T *= 1 + d.baseline_scale;
  r.K2.at<double>(0, 2) += d.right_cx_px;
  r.K2.at<double>(1, 2) += d.right_cy_px;
  r.K2.at<double>(0, 0) *= 1 + d.right_focal;
  r.K2.at<double>(1, 1) *= 1 + d.right_focal;
  r.baseline_mm = cv::norm(r.T);
  const cv::Mat tx = (cv::Mat_<double>(3, 3) << 0, -r.T.at<double>(2), r.T.at<double>(1), r.T.at<double>(2), 0,
                      -r.T.at<double>(0), -r.T.at<double>(1), r.T.at<double>(0), 0);
  r.E = tx * r.R;
  r.F = r.K2.inv().t() * r.E * r.K1.inv();
  cv::stereoRectify(r.K1, r.D1, r.K2, r.D2, r.image_size, r.R, r.T, r.R1, r.R2, r.P1, r.P2, r.Q,
                    cv::CALIB_ZERO_DISPARITY, 0);
  return r;
}

double RowsApart(const stereo::StereoRig& cameras, const stereo::StereoRig& file) {
  std::vector<cv::Point2f> left;
  for (int j = 0; j <= 10; ++j) {
    for (int i = 0; i <= 16; ++i) {
      left.emplace_back(float(cameras.image_size.width * i / 16.0), float(cameras.image_size.height * j / 10.0));
    }
  }
  std::vector<cv::Point2f> rays;
  cv::undistortPoints(left, rays, cameras.K1, cameras.D1);
  double worst = 0;
  for (const double z : {1500.0, 2500.0, 5000.0}) {
    std::vector<cv::Point3f> points;
    for (const cv::Point2f& r : rays) points.emplace_back(float(r.x * z), float(r.y * z), float(z));
    cv::Mat rvec;
    cv::Rodrigues(cameras.R, rvec);
    std::vector<cv::Point2f> right, left_rect, right_rect;
    cv::projectPoints(points, rvec, cameras.T, cameras.K2, cameras.D2, right);
    cv::undistortPoints(left, left_rect, file.K1, file.D1, file.R1, file.P1);
    cv::undistortPoints(right, right_rect, file.K2, file.D2, file.R2, file.P2);
    for (std::size_t k = 0; k < left.size(); ++k) worst = std::max(worst, double(std::abs(right_rect[k].y - left_rect[k].y)));
  }
  return worst;
}

std::vector<RigDrift> DriftSuite() {
  std::vector<RigDrift> s;
  auto add = [&](const std::string& name, auto set) {
    RigDrift d;
    d.name = name;
    set(d);
    s.push_back(d);
  };
  add("calibrated", [](RigDrift&) {});
  for (double a : {0.02, 0.05, 0.1, 0.2, 0.5}) add("pitch " + std::to_string(a).substr(0, 4) + " deg", [a](RigDrift& d) { d.pitch_deg = a; });
  for (double a : {0.02, 0.05, 0.1, 0.2, 0.5}) add("roll " + std::to_string(a).substr(0, 4) + " deg", [a](RigDrift& d) { d.roll_deg = a; });
  for (double a : {0.05, 0.2}) {
    add("yaw " + std::to_string(a).substr(0, 4) + " deg", [a](RigDrift& d) { d.yaw_deg = a, d.judgeable = false; });
  }
  for (double p : {0.5, 1.0, 2.0, 8.0}) add("right cy +" + std::to_string(p).substr(0, 3) + " px", [p](RigDrift& d) { d.right_cy_px = p; });
  for (double p : {2.0, 8.0}) {
    add("right cx +" + std::to_string(p).substr(0, 3) + " px", [p](RigDrift& d) { d.right_cx_px = p, d.judgeable = false; });
  }
  for (double t : {0.5, 1.0, 3.0}) add("vertical baseline " + std::to_string(t).substr(0, 3) + " mm", [t](RigDrift& d) { d.ty_mm = t; });
  for (double f : {0.005, 0.01, 0.02}) add("right focal +" + std::to_string(f * 100).substr(0, 3) + " %", [f](RigDrift& d) { d.right_focal = f; });
  add("baseline +1 %", [](RigDrift& d) { d.baseline_scale = 0.01, d.judgeable = false; });
  add("distortion half lost", [](RigDrift& d) { d.distortion_scale = 0.5; });
  add("distortion lost", [](RigDrift& d) { d.no_distortion = true; });
  add("cameras swapped", [](RigDrift& d) { d.swapped = true; });
  add("nominal rig", [](RigDrift& d) { d.nominal = true; });
  return s;
}

}  // namespace hedgefit::sim
