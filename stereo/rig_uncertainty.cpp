#include "stereo/rig_uncertainty.hpp"

#include <opencv2/calib3d.hpp>

#include <cmath>
#include <limits>
#include <memory>

#include "pipeline/error.hpp"

namespace hedgefit::stereo {

std::vector<StereoRig> SampleRigs(const StereoRig& rig, int n, std::uint64_t seed) {
  if (rig.covariance.rows != kRigParameters || rig.covariance.cols != kRigParameters) {
    throw Error("the rig has no calibration covariance; recalibrate with `hedgefit calibrate`");
  }
  // C = V diag(l) V^T; a draw is theta + V diag(sqrt(l)) z. Eigen-decomposition rather than
  // Cholesky: parameters a model holds fixed have zero variance.
  cv::Mat values, vectors;
  cv::Mat c = 0.5 * (rig.covariance + rig.covariance.t());
  cv::eigen(c, values, vectors);
  cv::Mat L(kRigParameters, kRigParameters, CV_64F);
  for (int k = 0; k < kRigParameters; ++k) {
    const double s = std::sqrt(std::max(0.0, values.at<double>(k)));
    for (int i = 0; i < kRigParameters; ++i) L.at<double>(i, k) = vectors.at<double>(k, i) * s;
  }
  const cv::Vec<double, kRigParameters> theta = RigParameters(rig);
  cv::RNG rng(seed);
  std::vector<StereoRig> out;
  for (int s = 0; s < n; ++s) {
    cv::Mat z(kRigParameters, 1, CV_64F);
    for (int i = 0; i < kRigParameters; ++i) z.at<double>(i) = rng.gaussian(1.0);
    const cv::Mat d = L * z;
    cv::Vec<double, kRigParameters> p = theta;
    for (int i = 0; i < kRigParameters; ++i) p[i] += d.at<double>(i);
    out.push_back(RigWithParameters(rig, p));
  }
  return out;
}

void Retriangulate(const StereoRig& nominal, const StereoRig& other, const std::vector<Eigen::Vector3d>& in,
                   std::vector<Eigen::Vector3d>* out) {
  out->assign(in.size(), Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  if (in.empty()) return;
  std::vector<cv::Point3d> pts(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) pts[i] = cv::Point3d(in[i].x(), in[i].y(), in[i].z());
  // The pixels the nominal rig saw.
  std::vector<cv::Point2d> left_px, right_px;
  cv::Mat rvec;
  cv::Rodrigues(nominal.R, rvec);
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), nominal.K1, nominal.D1, left_px);
  cv::projectPoints(pts, rvec, nominal.T, nominal.K2, nominal.D2, right_px);
  // The rays the other rig would cast through them (normalised coordinates, z = 1).
  const cv::TermCriteria iter(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 20, 1e-12);
  std::vector<cv::Point2d> left_n, right_n;
  cv::undistortPoints(left_px, left_n, other.K1, other.D1, cv::noArray(), cv::noArray(), iter);
  cv::undistortPoints(right_px, right_n, other.K2, other.D2, cv::noArray(), cv::noArray(), iter);
  const cv::Matx33d R(other.R);
  const cv::Vec3d T(other.T.at<double>(0), other.T.at<double>(1), other.T.at<double>(2));
  const cv::Matx33d Rt = R.t();
  const cv::Vec3d c2 = -(Rt * T);  // the right camera's centre, left frame
  for (std::size_t i = 0; i < in.size(); ++i) {
    const cv::Vec3d d1(left_n[i].x, left_n[i].y, 1.0);
    const cv::Vec3d d2 = Rt * cv::Vec3d(right_n[i].x, right_n[i].y, 1.0);
    // Closest points of s d1 and c2 + t d2.
    const double a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2), d = d1.dot(-c2), e = d2.dot(-c2);
    const double den = a * c - b * b;
    if (!(std::abs(den) > 1e-15)) continue;
    const double s = (b * e - c * d) / den, t = (a * e - b * d) / den;
    if (!(s > 0)) continue;
    const cv::Vec3d p = 0.5 * (s * d1 + c2 + t * d2);
    (*out)[i] = Eigen::Vector3d(p[0], p[1], p[2]);
  }
}

cloud::PointPerturbation RigPerturbation(const StereoRig& rig, int samples, std::uint64_t seed) {
  cloud::PointPerturbation p;
  if (rig.covariance.empty() || samples <= 0) return p;
  auto nominal = std::make_shared<const StereoRig>(rig);
  auto rigs = std::make_shared<const std::vector<StereoRig>>(SampleRigs(rig, samples, seed));
  p.source = "rig covariance";
  p.samples = samples;
  p.apply = [nominal, rigs](int s, const std::vector<Eigen::Vector3d>& in, std::vector<Eigen::Vector3d>* out) {
    Retriangulate(*nominal, (*rigs)[std::size_t(s)], in, out);
  };
  return p;
}

cloud::PointPerturbation DisparityOffsetPerturbation(const StereoRig& rig, double sigma_px, int samples,
                                                     std::uint64_t seed) {
  cloud::PointPerturbation p;
  if (rig.R1.empty() || rig.P2.empty() || samples <= 0 || !(sigma_px > 0)) return p;
  const double f = rig.P2.at<double>(0, 0);
  const double fb = -rig.P2.at<double>(0, 3);  // f B, px mm
  if (!(f > 0) || !(std::abs(fb) > 0)) return p;
  const Eigen::Vector3d depth_axis(rig.R1.at<double>(2, 0), rig.R1.at<double>(2, 1), rig.R1.at<double>(2, 2));
  cv::RNG rng(seed);
  auto offsets = std::make_shared<std::vector<double>>();
  for (int s = 0; s < samples; ++s) offsets->push_back(rng.gaussian(sigma_px));
  p.source = "disparity offset";
  p.samples = samples;
  p.apply = [offsets, depth_axis, fb](int s, const std::vector<Eigen::Vector3d>& in, std::vector<Eigen::Vector3d>* out) {
    out->resize(in.size());
    const double delta = (*offsets)[std::size_t(s)];
    for (std::size_t i = 0; i < in.size(); ++i) {
      const double z = depth_axis.dot(in[i]);  // rectified depth
      const double d = std::abs(fb) / z;
      (*out)[i] = d + delta > 0 ? Eigen::Vector3d(in[i] * (d / (d + delta)))
                                : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    }
  };
  return p;
}

cloud::PointPerturbation DisparityErrorPerturbation(const StereoRig& rig, const DisparityErrorField& field,
                                                    double sigma_px, int samples, std::uint64_t seed) {
  cloud::PointPerturbation p = DisparityOffsetPerturbation(rig, sigma_px, samples, seed);
  if (p.samples == 0) return p;
  const double f = rig.P1.at<double>(0, 0), cx = rig.P1.at<double>(0, 2), cy = rig.P1.at<double>(1, 2);
  const double fb = std::abs(rig.P2.at<double>(0, 3));
  Eigen::Matrix3d r1;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r1(i, j) = rig.R1.at<double>(i, j);
  }
  // The same offsets as DisparityOffsetPerturbation (its seed), then the field's scale per draw.
  cv::RNG rng(seed), more(seed + 1);
  auto draws = std::make_shared<std::vector<Eigen::Vector4d>>();
  for (int s = 0; s < samples; ++s) {
    const double offset = rng.gaussian(sigma_px);
    const double planar = more.gaussian(1.0), lens = more.gaussian(1.0), which = more.gaussian(1.0);
    draws->push_back({offset, planar, lens, which});
  }
  p.source = "disparity offset and the rows' disagreement";
  p.apply = [draws, field, r1, f, cx, cy, fb](int s, const std::vector<Eigen::Vector3d>& in,
                                              std::vector<Eigen::Vector3d>* out) {
    out->resize(in.size());
    const Eigen::Vector4d& k = (*draws)[std::size_t(s)];
    for (std::size_t i = 0; i < in.size(); ++i) {
      const Eigen::Vector3d q = r1 * in[i];  // rectified frame
      const double d = fb / q.z();
      const double u = f * q.x() / q.z() + cx, v = f * q.y() / q.z() + cy;
      const double delta =
          k[0] + k[1] * field.Planar(u, v, d) + k[2] * field.OffPlane(u, v) + k[3] * field.ScaleOffset(d);
      (*out)[i] = d + delta > 0 ? Eigen::Vector3d(in[i] * (d / (d + delta)))
                                : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    }
  };
  return p;
}

}  // namespace hedgefit::stereo
