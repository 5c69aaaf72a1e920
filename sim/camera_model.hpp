#pragma once
/// What a real camera does to the light a renderer computes, applied after rendering so any
/// renderer's images (hedgefit's, POV-Ray's) can go through it: a different exposure and
/// white balance in each camera, vignetting, a Bayer colour filter with OpenCV's demosaicing,
/// shot and read noise drawn independently in each camera, 8-bit quantisation and optional
/// JPEG. `CameraModel::Ideal()` leaves an image as it is (for unit tests).

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>

namespace hedgefit::sim {

struct CameraModel {
  /// Exposure x gain of each camera (1 = as rendered); the right one a little darker.
  double gain_left = 1.0, gain_right = 0.93;
  /// White balance: per-channel (B, G, R) factors of the right camera relative to the left.
  cv::Vec3d white_right{1.03, 1.0, 0.96};
  /// Vignetting: brightness falls to (1 - vignetting) at the image corners (cos^4-like).
  double vignetting = 0.25;
  bool bayer = true;         ///< RGGB mosaic, then OpenCV's bilinear demosaicing
  double read_noise = 1.2;   ///< grey levels, every pixel
  /// Shot noise: variance shot_noise * value (grey levels^2), i.e. ~2.2 grey levels at 200.
  double shot_noise = 0.025;
  int jpeg_quality = 0;      ///< 1-100: encode and decode as JPEG; 0 = lossless
  /// A model that changes nothing.
  static CameraModel Ideal();
};

/// The effects `WithoutEffect` can switch off, by name.
inline constexpr const char* kCameraEffects[] = {"gains", "vignetting", "bayer", "noise", "jpeg"};

/// `model` with one effect switched off, to see what each costs: "gains" (the same exposure and
/// white balance in both cameras), "vignetting", "bayer" (every colour at every pixel), "noise"
/// (no shot or read noise) or "jpeg". Throws hedgefit::Error naming `what` and the valid names.
CameraModel WithoutEffect(CameraModel model, const std::string& effect, const std::string& what);

/// `image` (8-bit BGR) as camera `right` (false = left) would record it; `seed` draws the
/// noise (the two cameras use seed * 2 and seed * 2 + 1, so their noise is independent).
cv::Mat ApplyCameraModel(const cv::Mat& image, const CameraModel& model, bool right, std::uint64_t seed);

}  // namespace hedgefit::sim
