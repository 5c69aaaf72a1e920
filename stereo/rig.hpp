#pragma once
/// A calibrated stereo rig and its rectification, stored as OpenCV FileStorage YAML
/// (readable by cv::FileStorage and by hedgefit). Frames: R, T map the left camera's
/// frame to the right's (x_right = R x_left + T), mm; R1/R2 rotate each camera's frame
/// into its rectified frame; P1, P2, Q as from cv::stereoRectify.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace hedgefit::stereo {

/// What happened to one image pair during calibration.
struct PairReport {
  std::string left, right;   ///< image files
  bool used = false;         ///< part of the final calibration
  std::string status;        ///< "used", or why not ("board not found in right image", ...)
  double rms_left_px = 0;    ///< reprojection RMS of this pair's corners, left camera
  double rms_right_px = 0;   ///< right camera
  double rms_stereo_px = 0;  ///< both views, with the final stereo parameters
};

struct StereoRig {
  cv::Size image_size;                  ///< px
  cv::Mat K1, D1, K2, D2;               ///< intrinsics (px) and distortion (OpenCV order)
  cv::Mat R, T;                         ///< right_from_left rotation and translation (mm)
  cv::Mat E, F;                         ///< essential and fundamental matrices
  cv::Mat R1, R2, P1, P2, Q;            ///< Bouguet rectification (cv::stereoRectify)
  double baseline_mm = 0;               ///< |T|
  double rms_left_px = 0, rms_right_px = 0, rms_stereo_px = 0;  ///< calibration RMS
  std::vector<PairReport> pairs;        ///< per-pair results, rejected pairs included
  /// Covariance of the calibrated parameters (kRigParameters x kRigParameters, in the order of
  /// RigParameterNames()), from the calibration's own Jacobian scaled by its residual variance;
  /// empty when unknown (a rig written by hand or by an older hedgefit).
  cv::Mat covariance;
};

/// The calibrated parameters, in the order StereoRig::covariance uses: for each camera (left,
/// then right) fx fy cx cy (px) and k1 k2 p1 p2 k3 k4 k5 k6 (OpenCV's order, zero where the model
/// has fewer), then the rotation between the cameras as a rotation vector (rad), then T (mm).
constexpr int kRigParameters = 30;
const std::vector<std::string>& RigParameterNames();
/// The index of parameter `name` ("left.cx", "right.k3", "rig.tx") in RigParameterNames() order;
/// throws hedgefit::Error for an unknown name.
int RigParameterIndex(const std::string& name);

/// The parameter vector of `rig` (K, D, R, T) in RigParameterNames() order.
cv::Vec<double, kRigParameters> RigParameters(const StereoRig& rig);

/// `rig` with K, D, R, T (and the baseline) set from `parameters`; D keeps its length. E, F and
/// the rectification are cleared (they belonged to the old parameters); the covariance and the
/// calibration report are kept.
StereoRig RigWithParameters(const StereoRig& rig, const cv::Vec<double, kRigParameters>& parameters);

/// Standard deviation of each parameter (sqrt of the covariance's diagonal); empty when the
/// rig has no covariance.
std::vector<double> RigStdDevs(const StereoRig& rig);

/// Standard deviation of the baseline |T|, mm, from T's covariance; 0 when unknown.
double BaselineStdDev(const StereoRig& rig);

/// The rig of a pair that is already rectified (and undistorted): both cameras share the
/// focal length and principal point, the right camera sits `baseline_mm` to the right.
/// R1 = R2 = I, so rectification leaves the images as they are. Throws hedgefit::Error on
/// non-positive sizes, focal length or baseline.
StereoRig RigForRectifiedPair(const cv::Size& image_size, double focal_px, double cx_px, double cy_px,
                              double baseline_mm);

/// Why `rig` cannot be used, or "" if it can: every number finite; image sides 16..100000 px;
/// focal lengths 1..1e6 px; principal points within the image's size of it; R a rotation;
/// baseline 0.1 mm..100 m; the rectification (R1, R2: 3x3, P1, P2: 3x4, Q: 4x4) complete and
/// finite when present, with a rectified focal length in 1..1e6 px.
std::string RigProblem(const StereoRig& rig);

/// Writes `rig` as OpenCV FileStorage YAML, atomically; throws hedgefit::Error naming the file.
void WriteRig(const std::string& path, const StereoRig& rig);

/// Reads a rig written by WriteRig (or by hand with the same keys); throws hedgefit::Error
/// naming the file and the missing, malformed or unusable key (see RigProblem).
StereoRig ReadRig(const std::string& path);

}  // namespace hedgefit::stereo
