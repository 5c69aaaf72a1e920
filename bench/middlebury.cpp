#include "bench/middlebury.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgcodecs.hpp>  // the IMREAD_ flags
#include <opencv2/imgproc.hpp>

#include "pipeline/error.hpp"
#include "stereo/bspline.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::bench {

using stereo::BSplineCoefficientsAlongRows;
using stereo::BSplineWeights;
using stereo::ReadImageFile;

cv::Mat ReadPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the PFM file");
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();  // the single whitespace byte after the header
  if (magic != "Pf" || w <= 0 || h <= 0 || scale == 0 || !in) {
    throw Error(path + ": not a grey PFM file (expected 'Pf', width, height, scale)");
  }
  const bool little = scale < 0;
  cv::Mat out(h, w, CV_32F);
  std::vector<unsigned char> row(static_cast<std::size_t>(w) * 4);
  for (int y = h - 1; y >= 0; --y) {  // stored bottom to top
    in.read(reinterpret_cast<char*>(row.data()), std::streamsize(row.size()));
    if (!in) throw Error(path + ": truncated PFM data");
    for (int x = 0; x < w; ++x) {
      unsigned char b[4];
      std::memcpy(b, &row[std::size_t(x) * 4], 4);
      if (!little) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
      float v;
      std::memcpy(&v, b, 4);
      out.at<float>(y, x) = v;
    }
  }
  return out;
}

BadPixelScore ScoreDisparity(const cv::Mat& disparity, const cv::Mat& truth, const cv::Mat& mask, double threshold_px) {
  if (disparity.size() != truth.size() || (!mask.empty() && mask.size() != truth.size())) {
    throw Error("ScoreDisparity: disparity, truth and mask sizes differ");
  }
  BadPixelScore s;
  long bad = 0, dense = 0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      const float t = truth.at<float>(y, x);
      if (!std::isfinite(t) || (!mask.empty() && mask.at<std::uint8_t>(y, x) == 0)) continue;
      ++s.scored;
      const float d = disparity.at<float>(y, x);
      if (std::isfinite(d)) {
        ++dense;
        if (std::abs(d - t) > threshold_px) ++bad;
      } else {
        ++bad;
      }
    }
  }
  if (s.scored > 0) {
    s.bad_percent = 100.0 * double(bad) / double(s.scored);
    s.density_percent = 100.0 * double(dense) / double(s.scored);
  }
  return s;
}

namespace {

cv::Mat ReadOrThrow(const std::string& path, int flags) {
  try {
    return ReadImageFile(path, flags);
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + "; check the data directory");
  }
}

int SearchRange(const cv::Mat& truth) {
  double hi = 0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      const float t = truth.at<float>(y, x);
      if (std::isfinite(t)) hi = std::max(hi, double(t));
    }
  }
  return ((static_cast<int>(std::ceil(hi)) + 2 + 15) / 16) * 16;
}

}  // namespace

TruthPair LoadTruthPair(const std::string& data_dir, const std::string& name) {
  TruthPair p;
  p.name = name;
  const std::string root = data_dir + "/stereo_gt/";
  const float inf = std::numeric_limits<float>::infinity();
  if (name == "motorcycle") {
    const std::string d = root + "middlebury2014_motorcycle_Q/";
    p.left = ReadOrThrow(d + "im0.png", cv::IMREAD_COLOR);
    p.right = ReadOrThrow(d + "im1.png", cv::IMREAD_COLOR);
    p.truth = ReadPfm(d + "disp0GT.pfm");
    p.mask = ReadOrThrow(d + "mask0nocc.png", cv::IMREAD_GRAYSCALE) == 255;
  } else if (name == "aloe") {
    const std::string d = root + "aloe/";
    p.left = ReadOrThrow(d + "aloeL.jpg", cv::IMREAD_COLOR);
    p.right = ReadOrThrow(d + "aloeR.jpg", cv::IMREAD_COLOR);
    ReadOrThrow(d + "aloeGT.png", cv::IMREAD_GRAYSCALE).convertTo(p.truth, CV_32F);
    p.truth_step = 1.0;
    p.mask = p.truth > 0;
  } else if (name == "cones") {
    const std::string d = root + "middlebury2003_cones_pandora/";
    p.left = ReadOrThrow(d + "left.tif", cv::IMREAD_COLOR);
    p.right = ReadOrThrow(d + "right.tif", cv::IMREAD_COLOR);
    ReadOrThrow(d + "disp_left.tif", cv::IMREAD_UNCHANGED).convertTo(p.truth, CV_32F);
    p.truth_step = 0.25;
    p.mask = ReadOrThrow(d + "occlusion.png", cv::IMREAD_GRAYSCALE) > 0;
    p.mask &= p.truth > 0;
  } else {
    throw Error("truth pair '" + name + "': unknown; use motorcycle, aloe or cones");
  }
  if (p.truth.size() != p.left.size() || p.right.size() != p.left.size() || p.mask.size() != p.left.size()) {
    throw Error(root + ": truth pair '" + name + "': images, truth and mask differ in size");
  }
  p.truth.setTo(inf, p.truth <= 0);  // 0 = unknown in the 8-bit and TIFF truths (never a real disparity here)
  p.truth.setTo(inf, p.truth != p.truth);
  p.num_disparities = SearchRange(p.truth);
  return p;
}

cv::Mat DequantiseTruth(const cv::Mat& truth, double step, int radius, cv::Mat* planar) {
  cv::Mat out = truth.clone();
  cv::Mat ok(truth.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) ok.at<std::uint8_t>(y, x) = std::isfinite(truth.at<float>(y, x)) ? 255 : 0;
  }
  if (step <= 0) {
    if (planar) *planar = ok;
    return out;
  }
  const int side = 2 * radius + 1, n = side * side;
  Eigen::MatrixXd A(n, 3);
  for (int j = -radius, k = 0; j <= radius; ++j) {
    for (int i = -radius; i <= radius; ++i, ++k) A.row(k) << 1.0, i, j;
  }
  const Eigen::MatrixXd pinv = (A.transpose() * A).inverse() * A.transpose();
  cv::Mat flat(truth.size(), CV_8U, cv::Scalar(0));
  Eigen::VectorXd v(n);
  for (int y = radius; y < truth.rows - radius; ++y) {
    for (int x = radius; x < truth.cols - radius; ++x) {
      bool known = true;
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      for (int j = -radius, k = 0; j <= radius && known; ++j) {
        for (int i = -radius; i <= radius; ++i, ++k) {
          const float t = truth.at<float>(y + j, x + i);
          if (!std::isfinite(t)) {
            known = false;
            break;
          }
          v[k] = t;
          lo = std::min(lo, t), hi = std::max(hi, t);
        }
      }
      // A window of one stored value says nothing finer than the grid: the plane is pinned
      // only where the rounded values step inside the window.
      if (!known || hi - lo < step * 0.999) continue;
      const Eigen::Vector3d plane = pinv * v;
      // A plane rounded to the grid is off by at most half a step at every pixel from the true
      // plane; the least-squares plane is within ~0.1 step of that one, so a quarter step of
      // slack; a break in the surface (a step of a whole grid unit or more) still fails.
      if (((A * plane - v).array().abs() <= 0.75 * step).all()) {
        out.at<float>(y, x) = static_cast<float>(plane[0]);
        flat.at<std::uint8_t>(y, x) = 255;
      }
    }
  }
  if (planar) *planar = flat;
  return out;
}

TruthOffset TruthOffsetFromViews(const cv::Mat& left, const cv::Mat& right, const cv::Mat& truth, const cv::Mat& planar,
                                 int radius) {
  if (left.size() != right.size() || truth.size() != left.size() || planar.size() != left.size() || radius < 1) {
    throw Error("TruthOffsetFromViews: views, truth and planar mask differ in size, or radius < 1");
  }
  auto grey = [](const cv::Mat& img) {
    cv::Mat g, f;
    if (img.channels() == 3) {
      cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
    } else {
      g = img;
    }
    g.convertTo(f, CV_32F);
    return f;
  };
  const cv::Mat L = grey(left), coeffs = BSplineCoefficientsAlongRows(grey(right));
  const cv::Size box(2 * radius + 1, 2 * radius + 1);
  cv::Mat high_left;
  cv::blur(L, high_left, box, cv::Point(-1, -1), cv::BORDER_REPLICATE);
  high_left = L - high_left;
  constexpr double kStep = 0.05;
  constexpr int kSteps = 20;  // the offsets tried: +-1 px
  constexpr double kReach = kSteps * kStep;
  const int w = L.cols;
  // Judged: pixels whose whole window has a planar truth that reads the right view inside it at
  // every offset tried, so that every offset is judged on the same pixels.
  cv::Mat known(L.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < L.rows; ++y) {
    for (int x = 0; x < w; ++x) {
      const double xr = x - double(truth.at<float>(y, x));
      if (planar.at<std::uint8_t>(y, x) && std::isfinite(xr) && std::floor(xr - kReach) >= 1 &&
          std::floor(xr + kReach) + 2 < w) {
        known.at<std::uint8_t>(y, x) = 255;
      }
    }
  }
  cv::Mat judged;
  cv::erode(known, judged, cv::getStructuringElement(cv::MORPH_RECT, box), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
            cv::Scalar(0));
  auto residual = [&](double offset) {
    cv::Mat warped(L.size(), CV_32F, cv::Scalar(0));
    for (int y = 0; y < L.rows; ++y) {
      const float* c = coeffs.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        if (!known.at<std::uint8_t>(y, x)) continue;
        const double xr = x - truth.at<float>(y, x) - offset;
        const int ix = static_cast<int>(std::floor(xr));
        double wt[4];
        BSplineWeights(xr - ix, wt, nullptr);
        warped.at<float>(y, x) = float(wt[0] * c[ix - 1] + wt[1] * c[ix] + wt[2] * c[ix + 1] + wt[3] * c[ix + 2]);
      }
    }
    cv::Mat mean;
    cv::blur(warped, mean, box, cv::Point(-1, -1), cv::BORDER_REPLICATE);
    double sum = 0;
    long n = 0;
    for (int y = 0; y < L.rows; ++y) {
      for (int x = 0; x < w; ++x) {
        if (!judged.at<std::uint8_t>(y, x)) continue;
        const double e = high_left.at<float>(y, x) - (warped.at<float>(y, x) - mean.at<float>(y, x));
        sum += e * e, ++n;
      }
    }
    return std::make_pair(n > 0 ? sum / double(n) : 0.0, n);
  };
  TruthOffset out;
  const auto [at_zero, n_zero] = residual(0.0);
  if (n_zero < 1000) return out;
  out.pixels = n_zero;
  out.rms_at_zero = std::sqrt(at_zero);
  std::vector<double> cost(2 * kSteps + 1);
  for (int k = -kSteps; k <= kSteps; ++k) cost[std::size_t(k + kSteps)] = residual(k * kStep).first;
  const auto best = std::size_t(std::min_element(cost.begin(), cost.end()) - cost.begin());
  double offset = (double(best) - kSteps) * kStep;
  if (best > 0 && best + 1 < cost.size()) {
    const double a = cost[best - 1], b = cost[best], c = cost[best + 1], curvature = a - 2 * b + c;
    if (curvature > 0) offset += kStep * 0.5 * (a - c) / curvature;
  }
  out.offset_px = offset;
  out.rms_at_offset = std::sqrt(residual(offset).first);
  return out;
}

}  // namespace hedgefit::bench
