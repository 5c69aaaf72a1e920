#include "stereo/rig.hpp"

#include <opencv2/core/persistence.hpp>

#include <filesystem>

#include "cloud/cloud_io.hpp"
#include "cloud/error.hpp"

namespace hedgefit::stereo {

StereoRig RigForRectifiedPair(const cv::Size& image_size, double f, double cx, double cy, double baseline_mm) {
  if (image_size.width <= 0 || image_size.height <= 0) throw Error("size: must be positive, e.g. 640x480");
  if (!(f > 0)) throw Error("focal: must be > 0 px");
  if (!(baseline_mm > 0)) throw Error("baseline: must be > 0 mm");
  StereoRig rig;
  rig.image_size = image_size;
  rig.K1 = (cv::Mat_<double>(3, 3) << f, 0, cx, 0, f, cy, 0, 0, 1);
  rig.K2 = rig.K1.clone();
  rig.D1 = cv::Mat::zeros(1, 5, CV_64F);
  rig.D2 = cv::Mat::zeros(1, 5, CV_64F);
  rig.R = cv::Mat::eye(3, 3, CV_64F);
  rig.T = (cv::Mat_<double>(3, 1) << -baseline_mm, 0, 0);
  rig.baseline_mm = baseline_mm;
  // E = [T]x R, F = K2^-T E K1^-1, as cv::stereoCalibrate would report them.
  const cv::Mat tx = (cv::Mat_<double>(3, 3) << 0, 0, 0, 0, 0, baseline_mm, 0, -baseline_mm, 0);
  rig.E = tx * rig.R;
  rig.F = rig.K2.inv().t() * rig.E * rig.K1.inv();
  rig.R1 = cv::Mat::eye(3, 3, CV_64F);
  rig.R2 = cv::Mat::eye(3, 3, CV_64F);
  rig.P1 = (cv::Mat_<double>(3, 4) << f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0);
  rig.P2 = (cv::Mat_<double>(3, 4) << f, 0, cx, -f * baseline_mm, 0, f, cy, 0, 0, 0, 1, 0);
  // cv::stereoRectify's Q for equal principal points: (x, y, d) -> (X, Y, Z, W).
  rig.Q = (cv::Mat_<double>(4, 4) << 1, 0, 0, -cx, 0, 1, 0, -cy, 0, 0, 0, f, 0, 0, 1.0 / baseline_mm, 0);
  return rig;
}

void WriteRig(const std::string& path, const StereoRig& rig) {
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  fs << "image_width" << rig.image_size.width << "image_height" << rig.image_size.height;
  fs << "K1" << rig.K1 << "D1" << rig.D1 << "K2" << rig.K2 << "D2" << rig.D2;
  fs << "R" << rig.R << "T" << rig.T << "E" << rig.E << "F" << rig.F;
  fs << "R1" << rig.R1 << "R2" << rig.R2 << "P1" << rig.P1 << "P2" << rig.P2 << "Q" << rig.Q;
  fs << "baseline_mm" << rig.baseline_mm;
  fs << "rms_left_px" << rig.rms_left_px << "rms_right_px" << rig.rms_right_px << "rms_stereo_px" << rig.rms_stereo_px;
  fs << "pairs" << "[";
  for (const auto& p : rig.pairs) {
    fs << "{" << "left" << p.left << "right" << p.right << "used" << static_cast<int>(p.used) << "status" << p.status
       << "rms_left_px" << p.rms_left_px << "rms_right_px" << p.rms_right_px << "rms_stereo_px" << p.rms_stereo_px
       << "}";
  }
  fs << "]";
  cloud::WriteTextFileAtomic(path, fs.releaseAndGetString());
}

StereoRig ReadRig(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path + ": no such rig file; run `hedgefit calibrate` first");
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ)) throw Error(path + ": not an OpenCV FileStorage file");
  } catch (const cv::Exception&) {
    throw Error(path + ": not a readable OpenCV YAML/XML rig file");
  }
  StereoRig rig;
  auto mat = [&](const char* key, int rows, int cols) {
    cv::Mat m;
    fs[key] >> m;
    if (m.empty() || (rows > 0 && m.rows != rows) || (cols > 0 && m.cols != cols)) {
      throw Error(path + ": key '" + key + "' is missing or not a " + std::to_string(rows) + "x" + std::to_string(cols) +
                  " matrix");
    }
    m.convertTo(m, CV_64F);
    return m;
  };
  rig.image_size = cv::Size(static_cast<int>(fs["image_width"]), static_cast<int>(fs["image_height"]));
  if (rig.image_size.width <= 0 || rig.image_size.height <= 0) {
    throw Error(path + ": image_width and image_height must be positive");
  }
  rig.K1 = mat("K1", 3, 3);
  rig.K2 = mat("K2", 3, 3);
  rig.D1 = mat("D1", 1, -1);
  rig.D2 = mat("D2", 1, -1);
  rig.R = mat("R", 3, 3);
  rig.T = mat("T", 3, 1);
  auto optional_mat = [&](const char* key) {
    cv::Mat m;
    fs[key] >> m;
    if (!m.empty()) m.convertTo(m, CV_64F);
    return m;
  };
  rig.E = optional_mat("E");
  rig.F = optional_mat("F");
  rig.R1 = optional_mat("R1");
  rig.R2 = optional_mat("R2");
  rig.P1 = optional_mat("P1");
  rig.P2 = optional_mat("P2");
  rig.Q = optional_mat("Q");
  rig.baseline_mm = cv::norm(rig.T);
  fs["rms_left_px"] >> rig.rms_left_px;
  fs["rms_right_px"] >> rig.rms_right_px;
  fs["rms_stereo_px"] >> rig.rms_stereo_px;
  return rig;
}

}  // namespace hedgefit::stereo
