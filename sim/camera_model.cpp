#include "sim/camera_model.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>

#include "pipeline/error.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::sim {

using stereo::DecodeImage;
using stereo::EncodeImage;

CameraModel CameraModel::Ideal() {
  CameraModel m;
  m.gain_left = m.gain_right = 1.0;
  m.white_right = cv::Vec3d(1, 1, 1);
  m.vignetting = 0;
  m.bayer = false;
  m.read_noise = m.shot_noise = 0;
  m.jpeg_quality = 0;
  return m;
}

CameraModel WithoutEffect(CameraModel m, const std::string& effect, const std::string& what) {
  if (effect == "gains") {
    m.gain_right = m.gain_left;
    m.white_right = cv::Vec3d(1, 1, 1);
  } else if (effect == "vignetting") {
    m.vignetting = 0;
  } else if (effect == "bayer") {
    m.bayer = false;
  } else if (effect == "noise") {
    m.read_noise = m.shot_noise = 0;
  } else if (effect == "jpeg") {
    m.jpeg_quality = 0;
  } else {
    std::string names;
    for (const char* e : kCameraEffects) names += std::string(names.empty() ? "" : ", ") + e;
    throw Error(what + ": no camera effect '" + effect + "'; use " + names);
  }
  return m;
}

cv::Mat ApplyCameraModel(const cv::Mat& image, const CameraModel& m, bool right, std::uint64_t seed) {
  if (image.empty() || image.type() != CV_8UC3) throw Error("camera model: give an 8-bit BGR image");
  const int w = image.cols, h = image.rows;
  const double gain = right ? m.gain_right : m.gain_left;
  const cv::Vec3d white = right ? m.white_right : cv::Vec3d(1, 1, 1);
  const double cx = (w - 1) / 2.0, cy = (h - 1) / 2.0, r2max = cx * cx + cy * cy;
  // Light on the sensor: exposure, white balance, vignetting (1 - v r^2 / r_max^2, squared
  // for a cos^4-like fall-off that reaches 1 - v at the corners to first order).
  cv::Mat light(h, w, CV_32FC3);
  for (int y = 0; y < h; ++y) {
    const cv::Vec3b* src = image.ptr<cv::Vec3b>(y);
    cv::Vec3f* dst = light.ptr<cv::Vec3f>(y);
    for (int x = 0; x < w; ++x) {
      const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max;
      const double v = 1 - m.vignetting * r2;
      for (int c = 0; c < 3; ++c) dst[x][c] = static_cast<float>(src[x][c] * gain * white[c] * v);
    }
  }
  std::mt19937_64 rng(seed * 2 + (right ? 1 : 0));
  std::normal_distribution<double> normal(0, 1);
  auto expose = [&](double value) {
    const double sigma = std::sqrt(m.read_noise * m.read_noise + m.shot_noise * std::max(0.0, value));
    return cv::saturate_cast<std::uint8_t>(value + sigma * normal(rng));
  };
  cv::Mat out;
  if (m.bayer) {
    // One colour per photosite (RGGB: R at even row / even column), then OpenCV demosaics.
    cv::Mat raw(h, w, CV_8U);
    for (int y = 0; y < h; ++y) {
      const cv::Vec3f* l = light.ptr<cv::Vec3f>(y);
      std::uint8_t* r = raw.ptr<std::uint8_t>(y);
      for (int x = 0; x < w; ++x) {
        const int channel = (y % 2 == 0) ? (x % 2 == 0 ? 2 : 1) : (x % 2 == 0 ? 1 : 0);  // BGR index
        r[x] = expose(l[x][channel]);
      }
    }
    // OpenCV names Bayer patterns by the second row's first two pixels: RGGB is "BayerBG".
    cv::cvtColor(raw, out, cv::COLOR_BayerBG2BGR);
  } else {
    out.create(h, w, CV_8UC3);
    for (int y = 0; y < h; ++y) {
      const cv::Vec3f* l = light.ptr<cv::Vec3f>(y);
      cv::Vec3b* o = out.ptr<cv::Vec3b>(y);
      for (int x = 0; x < w; ++x) {
        for (int c = 0; c < 3; ++c) o[x][c] = expose(l[x][c]);
      }
    }
  }
  if (m.jpeg_quality > 0) {
    std::vector<std::uint8_t> buf;
    if (!EncodeImage(".jpg", out, &buf, m.jpeg_quality)) throw Error("camera model: cannot encode the JPEG");
    out = DecodeImage(buf, cv::IMREAD_COLOR, "camera model");
  }
  return out;
}

}  // namespace hedgefit::sim
