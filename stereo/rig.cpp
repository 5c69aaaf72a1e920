#include "stereo/rig.hpp"

#include <opencv2/core/persistence.hpp>

#include <filesystem>

#include "cloud/cloud_io.hpp"
#include "cloud/error.hpp"

namespace hedgefit::stereo {

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
