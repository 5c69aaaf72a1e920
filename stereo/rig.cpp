#include "stereo/rig.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::stereo {

std::string RigProblem(const StereoRig& rig) {
  auto finite = [](const cv::Mat& m) { return m.empty() || cv::checkRange(m, true, nullptr, -1e12, 1e12); };
  const auto& sz = rig.image_size;
  if (sz.width < 16 || sz.height < 16 || sz.width > 100000 || sz.height > 100000) {
    return "image size " + std::to_string(sz.width) + "x" + std::to_string(sz.height) + " is not 16..100000 px a side";
  }
  const std::pair<const char*, const cv::Mat*> mats[] = {{"K1", &rig.K1}, {"K2", &rig.K2}, {"D1", &rig.D1},
                                                         {"D2", &rig.D2}, {"R", &rig.R},   {"T", &rig.T},
                                                         {"R1", &rig.R1}, {"R2", &rig.R2}, {"P1", &rig.P1},
                                                         {"P2", &rig.P2}, {"Q", &rig.Q}, {"covariance", &rig.covariance}};
  for (const auto& [name, m] : mats) {
    if (!finite(*m)) return std::string("'") + name + "' holds a NaN, an infinity or a number beyond 1e12";
  }
  if (!rig.covariance.empty()) {
    for (int i = 0; i < rig.covariance.rows && i < rig.covariance.cols; ++i) {
      if (rig.covariance.at<double>(i, i) < 0) return "'covariance' has a negative variance (parameter " + std::to_string(i) + ")";
    }
  }
  for (const auto& [name, K] : {std::pair<const char*, const cv::Mat*>{"K1", &rig.K1}, {"K2", &rig.K2}}) {
    if (K->rows != 3 || K->cols != 3) return std::string("'") + name + "' is not 3x3";
    const double fx = K->at<double>(0, 0), fy = K->at<double>(1, 1), cx = K->at<double>(0, 2), cy = K->at<double>(1, 2);
    if (!(fx >= 1 && fx <= 1e6 && fy >= 1 && fy <= 1e6)) {
      return std::string("'") + name + "' has focal lengths " + std::to_string(fx) + ", " + std::to_string(fy) +
             " px; they must be in 1..1e6 px";
    }
    if (!(cx > -sz.width && cx < 2.0 * sz.width && cy > -sz.height && cy < 2.0 * sz.height)) {
      return std::string("'") + name + "' has its principal point (" + std::to_string(cx) + ", " + std::to_string(cy) +
             ") px far outside the image";
    }
  }
  if (rig.R.rows != 3 || rig.R.cols != 3 || cv::norm(rig.R.t() * rig.R - cv::Mat::eye(3, 3, CV_64F)) > 1e-3 ||
      std::abs(cv::determinant(rig.R) - 1) > 1e-3) {
    return "'R' is not a rotation matrix";
  }
  const double b = rig.T.total() == 3 ? cv::norm(rig.T) : 0.0;
  if (!(b >= 0.1 && b <= 1e5)) {
    return "the baseline |T| is " + std::to_string(b) + " mm; it must be 0.1 mm..100 m (T = 0 puts every point at infinity)";
  }
  const bool any = !rig.R1.empty() || !rig.R2.empty() || !rig.P1.empty() || !rig.P2.empty() || !rig.Q.empty();
  if (any) {
    if (rig.R1.size() != cv::Size(3, 3) || rig.R2.size() != cv::Size(3, 3) || rig.P1.size() != cv::Size(4, 3) ||
        rig.P2.size() != cv::Size(4, 3) || rig.Q.size() != cv::Size(4, 4)) {
      return "the rectification is incomplete: R1 and R2 (3x3), P1 and P2 (3x4) and Q (4x4) go together";
    }
    const double f = rig.P1.at<double>(0, 0);
    if (!(f >= 1 && f <= 1e6)) return "'P1' has a rectified focal length of " + std::to_string(f) + " px; it must be 1..1e6";
  }
  return "";
}

StereoRig RigForRectifiedPair(const cv::Size& image_size, double f, double cx, double cy, double baseline_mm) {
  if (image_size.width <= 0 || image_size.height <= 0) throw Error("size: must be positive, e.g. 640x480");
  if (!(f >= 1 && f <= 1e6)) throw Error("focal: must be in 1..1e6 px");
  if (!(std::isfinite(cx) && std::isfinite(cy))) throw Error("cx/cy: must be finite numbers (px)");
  if (!(baseline_mm >= 0.1 && baseline_mm <= 1e5)) throw Error("baseline: must be in 0.1..100000 mm");
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
  if (const std::string why = RigProblem(rig); !why.empty()) throw Error(why);
  return rig;
}

const std::vector<std::string>& RigParameterNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const char* cam : {"left", "right"}) {
      for (const char* p : {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"}) {
        n.push_back(std::string(cam) + "." + p);
      }
    }
    for (const char* p : {"rx", "ry", "rz", "tx", "ty", "tz"}) n.push_back(std::string("rig.") + p);
    return n;
  }();
  return names;
}

int RigParameterIndex(const std::string& name) {
  const auto& names = RigParameterNames();
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return int(i);
  }
  throw Error("internal: no rig parameter '" + name + "'");
}

cv::Vec<double, kRigParameters> RigParameters(const StereoRig& rig) {
  cv::Vec<double, kRigParameters> v = cv::Vec<double, kRigParameters>::all(0);
  const std::pair<const cv::Mat*, const cv::Mat*> cams[] = {{&rig.K1, &rig.D1}, {&rig.K2, &rig.D2}};
  for (int c = 0; c < 2; ++c) {
    const cv::Mat& K = *cams[c].first;
    const cv::Mat& D = *cams[c].second;
    double* o = &v[12 * c];
    o[0] = K.at<double>(0, 0);
    o[1] = K.at<double>(1, 1);
    o[2] = K.at<double>(0, 2);
    o[3] = K.at<double>(1, 2);
    for (int i = 0; i < std::min(8, static_cast<int>(D.total())); ++i) o[4 + i] = D.at<double>(i);
  }
  cv::Mat rvec;
  cv::Rodrigues(rig.R, rvec);
  for (int i = 0; i < 3; ++i) {
    v[24 + i] = rvec.at<double>(i);
    v[27 + i] = rig.T.at<double>(i);
  }
  return v;
}

StereoRig RigWithParameters(const StereoRig& rig, const cv::Vec<double, kRigParameters>& p) {
  StereoRig out = rig;
  cv::Mat* cams[2][2] = {{&out.K1, &out.D1}, {&out.K2, &out.D2}};
  for (int c = 0; c < 2; ++c) {
    const double* o = &p[12 * c];
    *cams[c][0] = (cv::Mat_<double>(3, 3) << o[0], 0, o[2], 0, o[1], o[3], 0, 0, 1);
    cv::Mat D = cams[c][1]->clone();
    if (D.empty()) D = cv::Mat::zeros(1, 5, CV_64F);
    for (int i = 0; i < std::min(8, static_cast<int>(D.total())); ++i) D.at<double>(i) = o[4 + i];
    *cams[c][1] = D;
  }
  // A fresh matrix: `out` shares its matrices' data with `rig`, and Rodrigues would write into it.
  out.R = cv::Mat();
  cv::Rodrigues(cv::Vec3d(p[24], p[25], p[26]), out.R);
  out.T = (cv::Mat_<double>(3, 1) << p[27], p[28], p[29]);
  out.baseline_mm = cv::norm(out.T);
  out.E = out.F = out.R1 = out.R2 = out.P1 = out.P2 = out.Q = cv::Mat();
  return out;
}

std::vector<double> RigStdDevs(const StereoRig& rig) {
  std::vector<double> s;
  if (rig.covariance.rows != kRigParameters || rig.covariance.cols != kRigParameters) return s;
  for (int i = 0; i < kRigParameters; ++i) s.push_back(std::sqrt(std::max(0.0, rig.covariance.at<double>(i, i))));
  return s;
}

double BaselineStdDev(const StereoRig& rig) {
  if (rig.covariance.rows != kRigParameters || rig.T.total() != 3) return 0;
  // Var |T| = g^T C g with g = T / |T|.
  const cv::Mat g = rig.T / std::max(1e-12, cv::norm(rig.T));
  const cv::Mat c = rig.covariance(cv::Rect(27, 27, 3, 3));
  return std::sqrt(std::max(0.0, cv::Mat(g.t() * c * g).at<double>(0)));
}

void WriteRig(const std::string& path, const StereoRig& rig) {
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  fs << "image_width" << rig.image_size.width << "image_height" << rig.image_size.height;
  fs << "K1" << rig.K1 << "D1" << rig.D1 << "K2" << rig.K2 << "D2" << rig.D2;
  fs << "R" << rig.R << "T" << rig.T << "E" << rig.E << "F" << rig.F;
  fs << "R1" << rig.R1 << "R2" << rig.R2 << "P1" << rig.P1 << "P2" << rig.P2 << "Q" << rig.Q;
  fs << "baseline_mm" << rig.baseline_mm;
  fs << "rms_left_px" << rig.rms_left_px << "rms_right_px" << rig.rms_right_px << "rms_stereo_px" << rig.rms_stereo_px;
  if (const std::vector<double> sd = RigStdDevs(rig); !sd.empty()) {
    // Standard deviations for people (fx fy cx cy, then the distortion terms the model has;
    // the rotation vector in degrees), then the full covariance for programs.
    auto row = [&](int from, int n, double scale) {
      cv::Mat m(1, n, CV_64F);
      for (int i = 0; i < n; ++i) m.at<double>(i) = sd[std::size_t(from + i)] * scale;
      return m;
    };
    const int n1 = std::min(8, static_cast<int>(rig.D1.total())), n2 = std::min(8, static_cast<int>(rig.D2.total()));
    fs << "std_K1" << row(0, 4, 1) << "std_D1" << row(4, n1, 1) << "std_K2" << row(12, 4, 1) << "std_D2" << row(16, n2, 1);
    fs << "std_R_deg" << row(24, 3, 180.0 / CV_PI) << "std_T" << row(27, 3, 1) << "std_baseline_mm" << BaselineStdDev(rig);
    fs << "covariance" << rig.covariance;
  }
  fs << "pairs" << "[";
  for (const auto& p : rig.pairs) {
    fs << "{" << "left" << p.left << "right" << p.right << "used" << static_cast<int>(p.used) << "status" << p.status
       << "rms_left_px" << p.rms_left_px << "rms_right_px" << p.rms_right_px << "rms_stereo_px" << p.rms_stereo_px
       << "}";
  }
  fs << "]";
  cloud::WriteTextFileAtomic(path, fs.releaseAndGetString());
}

namespace {

// A matrix node ({rows, cols, dt, data}) read element by element: OpenCV's own reader allocates
// whatever rows x cols it finds (or garbage when one is missing: fuzzing found a 51 GB
// allocation), and a rig's matrices are small. An absent key gives an empty matrix.
cv::Mat ReadMatrix(const cv::FileNode& node, const std::string& path, const char* key, int max_side = 16) {
  if (node.empty() || node.isNone()) return cv::Mat();
  const cv::FileNode rows = node["rows"], cols = node["cols"], data = node["data"];
  if (!node.isMap() || !rows.isInt() || !cols.isInt() || !data.isSeq()) {
    throw Error(path + ": key '" + key + "' is not a matrix (rows, cols, dt, data)");
  }
  const int r = int(rows), c = int(cols);
  if (r == 0 || c == 0) return cv::Mat();
  if (r < 0 || c < 0 || r > max_side || c > max_side) {
    throw Error(path + ": key '" + key + "' is " + std::to_string(r) + " x " + std::to_string(c) +
                "; a rig's matrices are at most " + std::to_string(max_side) + " a side");
  }
  if (data.size() != std::size_t(r) * std::size_t(c)) {
    throw Error(path + ": key '" + key + "' holds " + std::to_string(data.size()) + " values for a " + std::to_string(r) +
                " x " + std::to_string(c) + " matrix");
  }
  cv::Mat m(r, c, CV_64F);
  for (int i = 0; i < r * c; ++i) {
    const cv::FileNode v = data[i];
    if (!v.isReal() && !v.isInt()) throw Error(path + ": key '" + key + "' holds a value that is not a number");
    m.at<double>(i / c, i % c) = double(v);
  }
  return m;
}

}  // namespace

namespace {

// Refuses a file that is not a rig before OpenCV parses it: too large, or (YAML) not the lines
// `hedgefit calibrate` writes.
void CheckRigFileText(const std::string& path) {
  std::error_code ec;
  // A rig file is a few kB: a large one is not a rig (and would be parsed whole first).
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > (1u << 20)) throw Error(path + ": too large for a rig file (over 1 MB); give the YAML `hedgefit calibrate` wrote");
  // OpenCV's YAML parser loops forever on some malformed input (found by fuzzing), so a YAML
  // rig must first look like what `hedgefit calibrate` writes: ASCII lines that are the
  // header, comments, "key: value", a matrix's "rows/cols/dt/data" lines or rows of numbers.
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t line_no = 0;
  bool yaml = false, keys = false, ended = false;
  auto bad = [&](const std::string& why) {
    return Error(path + ":" + std::to_string(line_no) + ": " + why + "; a rig file is the YAML `hedgefit calibrate` writes");
  };
  // A number as OpenCV writes it (1., -4.5e-02, .5, 3), or YAML's .nan / .inf, which
  // RigProblem then refuses with a clear message.
  static const std::string number = R"((?:[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?|[-+]?\.(?:nan|NaN|NAN|inf|Inf|INF)))";
  static const std::string list = number + "(?:, *" + number + ")*(?:,| *\\])?";
  static const std::regex key_value(R"(^[A-Za-z_][A-Za-z0-9_]*:( .*)?$)");
  static const std::regex data_row("^" + list + " *$");  // a matrix's data continued on the next line
  // Words include the few-word notes OpenCV leaves unquoted, as calibrate's status of a pair it
  // could not use ("board (9x6 inner corners) not found in left image").
  static const std::regex plain_value("^( +(!!opencv-matrix|" + number + R"(|"[^"]*"|[A-Za-z0-9][A-Za-z0-9_.]*(?: [A-Za-z0-9(][^#:"\[\]{}]*)?|\[ *\]|\[ *)" +
                                      list + "))? *$");
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // OpenCV writes short lines; a very long one would also overflow std::regex's recursive
    // matcher below (found by fuzzing: a 31 kB line).
    if (line.size() > 1024) throw bad("a line of " + std::to_string(line.size()) + " characters (a rig file's are short)");
    for (unsigned char u : line) {
      if ((u < 0x20 && u != '\t') || u >= 0x7f) throw bad("a byte that is not ASCII text (" + std::to_string(u) + ")");
    }
    if (line_no == 1) {
      yaml = line.rfind("%YAML", 0) == 0;
      if (!yaml) break;  // XML: OpenCV's XML parser, unchecked
      continue;
    }
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    if (ended) throw bad("text after the end of the document ('...')");
    if (line == "---") {
      if (keys) throw bad("a second document ('---')");
      continue;
    }
    if (line == "...") {
      ended = true;
      continue;
    }
    const std::string body = line.substr(first);
    // A matrix's data continued, or the calibration's list of pairs: "[]" when empty, else
    // an item marker "-" on its own line before the item's keys.
    if (body == "-" || body == "[]" || std::regex_match(body, data_row)) continue;
    if (!std::regex_match(body, key_value)) throw bad("not a 'key: value' line");
    keys = true;
    const std::string value = body.substr(body.find(':') + 1);
    if (!std::regex_match(value, plain_value)) throw bad("a value that is not a number, a word or a matrix");
  }
}

// The rig's keys from an opened FileStorage; OpenCV's own exceptions become one line naming `path`.
StereoRig ReadRigKeys(const cv::FileStorage& fs, const std::string& path) {
  StereoRig rig;
  // OpenCV's parser throws its own exception for malformed values (a matrix of negative size, a
  // string where a number belongs): the file is named, not OpenCV's assertion.
  try {
    auto mat = [&](const char* key, int rows, int cols) {
      cv::Mat m = ReadMatrix(fs[key], path, key);
      if (m.empty() || (rows > 0 && m.rows != rows) || (cols > 0 && m.cols != cols)) {
        throw Error(path + ": key '" + key + "' is missing or not a " + std::to_string(rows) + "x" + std::to_string(cols) +
                    " matrix");
      }
      m.convertTo(m, CV_64F);
      return m;
    };
    // Another file given for the rig (a pipeline's JSON, a camera's own YAML): say so, not which
    // key is wrong.
    bool any = false;
    for (const char* key : {"image_width", "image_height", "K1", "K2", "D1", "D2", "R", "T"}) any = any || !fs[key].empty();
    if (!any) {
      throw Error(path + ": not a rig file (it has none of image_width, K1, K2, R, T); give the file `hedgefit "
                         "calibrate` or `hedgefit rig` wrote");
    }
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
      cv::Mat m = ReadMatrix(fs[key], path, key);
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
    rig.covariance = ReadMatrix(fs["covariance"], path, "covariance", kRigParameters);
    if (!rig.covariance.empty() && (rig.covariance.rows != kRigParameters || rig.covariance.cols != kRigParameters)) {
      throw Error(path + ": key 'covariance' must be " + std::to_string(kRigParameters) + " x " +
                  std::to_string(kRigParameters) + " (the calibrated parameters); recalibrate or delete the key");
    }
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    const auto* cv_error = dynamic_cast<const cv::Exception*>(&e);
    throw Error(path + ": a value is malformed (" + (cv_error ? cv_error->err : std::string(e.what())) +
                "); recalibrate with `hedgefit calibrate` or fix the file");
  }
  return rig;
}

}  // namespace

StereoRig ReadRig(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path + ": no such rig file; run `hedgefit calibrate` first");
  CheckRigFileText(path);
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ)) throw Error(path + ": not an OpenCV FileStorage file");
  } catch (const std::exception&) {  // cv::Exception, or std::length_error on a garbled length
    throw Error(path + ": not a readable OpenCV YAML/XML rig file");
  }
  StereoRig rig = ReadRigKeys(fs, path);
  if (const std::string why = RigProblem(rig); !why.empty()) {
    throw Error(path + ": " + why + "; recalibrate with `hedgefit calibrate` or fix the file");
  }
  // baseline_mm is |T|, written for readers: one that disagrees (or is not a number) means the
  // file was edited by hand and one of the two is wrong.
  if (!fs["baseline_mm"].empty()) {
    double written = 0;
    fs["baseline_mm"] >> written;
    if (!(std::abs(written - rig.baseline_mm) <= 1e-3 * rig.baseline_mm + 1e-9)) {
      char buf[200];
      const std::string value = std::isfinite(written) ? std::to_string(written) : std::string("not a number");
      std::snprintf(buf, sizeof(buf), ": key 'baseline_mm' is %s but |T| is %.6g mm; they must agree (fix or remove "
                    "baseline_mm)", value.c_str(), rig.baseline_mm);
      throw Error(path + buf);
    }
  }
  return rig;
}

}  // namespace hedgefit::stereo
