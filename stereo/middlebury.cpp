#include "stereo/middlebury.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "cloud/error.hpp"

namespace hedgefit::stereo {

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

}  // namespace hedgefit::stereo
