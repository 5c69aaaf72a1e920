#include "stereo/matching.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/disparity_filter.hpp>

#include <cmath>
#include <limits>

#include "cloud/error.hpp"

namespace hedgefit::stereo {

void SgbmOptions::Check() const {
  if (num_disparities < 1) throw Error("num_disparities: must be >= 1 px");
  if (block_size < 1 || block_size % 2 == 0 || block_size > 31) throw Error("block_size: must be odd, 1..31 px");
  if (p1 < 0 || p2 < 0 || (p2 > 0 && p2 <= p1)) throw Error("p1/p2: need 0 <= p1 < p2 (0 = automatic)");
  if (uniqueness_ratio < 0 || uniqueness_ratio > 100) throw Error("uniqueness: must be in 0..100 %");
  if (bilateral_sigma_disp < 0 || bilateral_sigma_space < 0) throw Error("bilateral sigmas: must be >= 0");
}

void DisparityRangeForDepth(double focal_px, double baseline_mm, double min_z_mm, double max_z_mm, int* min_disparity,
                            int* num_disparities) {
  if (!(min_z_mm > 0 && max_z_mm > min_z_mm)) throw Error("min_z/max_z: need 0 < min_z < max_z (mm)");
  const double d_max = focal_px * baseline_mm / min_z_mm, d_min = focal_px * baseline_mm / max_z_mm;
  *min_disparity = std::max(0, static_cast<int>(std::floor(d_min)) - 2);
  const int span = static_cast<int>(std::ceil(d_max)) + 2 - *min_disparity;
  *num_disparities = ((span + 15) / 16) * 16;
}

int FillHolesFromBackground(cv::Mat* disparity) {
  int filled = 0;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < disparity->rows; ++y) {
    float* row = disparity->ptr<float>(y);
    const int w = disparity->cols;
    std::vector<float> left(static_cast<std::size_t>(w), nan), right(static_cast<std::size_t>(w), nan);
    float last = nan;
    for (int x = 0; x < w; ++x) {
      if (!std::isnan(row[x])) last = row[x];
      left[std::size_t(x)] = last;
    }
    last = nan;
    for (int x = w - 1; x >= 0; --x) {
      if (!std::isnan(row[x])) last = row[x];
      right[std::size_t(x)] = last;
    }
    for (int x = 0; x < w; ++x) {
      if (!std::isnan(row[x])) continue;
      const float a = left[std::size_t(x)], b = right[std::size_t(x)];
      // Occluded pixels belong to the farther surface: the smaller disparity.
      const float v = std::isnan(a) ? b : std::isnan(b) ? a : std::min(a, b);
      if (!std::isnan(v)) {
        row[x] = v;
        ++filled;
      }
    }
  }
  return filled;
}

DisparityMap ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const SgbmOptions& o) {
  o.Check();
  if (left.empty() || right.empty() || left.size() != right.size() || left.type() != right.type()) {
    throw Error("stereo.sgbm: the left and right images must be non-empty and of the same size and type");
  }
  const int channels = left.channels();
  const int num = ((o.num_disparities + 15) / 16) * 16;
  const int p1 = o.p1 > 0 ? o.p1 : 8 * channels * o.block_size * o.block_size;
  const int p2 = o.p2 > 0 ? o.p2 : 32 * channels * o.block_size * o.block_size;
  const int mode = o.mode == SgbmMode::kHh8       ? cv::StereoSGBM::MODE_HH
                   : o.mode == SgbmMode::kSgbm5   ? cv::StereoSGBM::MODE_SGBM
                   : o.mode == SgbmMode::kSgbm3Way ? cv::StereoSGBM::MODE_SGBM_3WAY
                                                   : cv::StereoSGBM::MODE_HH4;
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(o.min_disparity, num, o.block_size, p1, p2,
                                                        o.disp12_max_diff, 0, o.uniqueness_ratio, 0, 0, mode);
  cv::Mat d16_left;
  sgbm->compute(left, right, d16_left);
  DisparityMap out;
  const float invalid_left = float(o.min_disparity - 1) * 16.0f;
  out.disparity.create(left.size(), CV_32F);
  out.rejected = cv::Mat::zeros(left.size(), CV_8U);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < left.rows; ++y) {
    const short* s = d16_left.ptr<short>(y);
    float* d = out.disparity.ptr<float>(y);
    for (int x = 0; x < left.cols; ++x) d[x] = s[x] <= invalid_left ? nan : s[x] / 16.0f;
  }
  if (o.lrc_tolerance_px >= 0) {
    cv::Ptr<cv::StereoMatcher> right_matcher = cv::ximgproc::createRightMatcher(sgbm);
    cv::Mat d16_right;
    right_matcher->compute(right, left, d16_right);  // negative disparities, as OpenCV's right matcher gives
    for (int y = 0; y < left.rows; ++y) {
      float* d = out.disparity.ptr<float>(y);
      const short* r = d16_right.ptr<short>(y);
      std::uint8_t* rej = out.rejected.ptr<std::uint8_t>(y);
      for (int x = 0; x < left.cols; ++x) {
        if (std::isnan(d[x])) {
          rej[x] = 255;
          continue;
        }
        const int xr = static_cast<int>(std::lround(x - d[x]));
        bool ok = xr >= 0 && xr < left.cols;
        if (ok) {
          const short rv = r[xr];
          const float dr = -rv / 16.0f;
          ok = rv != std::numeric_limits<short>::min() && rv <= 0 && std::abs(dr - d[x]) <= o.lrc_tolerance_px &&
               -rv > (o.min_disparity - 1) * 16;
        }
        if (!ok) {
          d[x] = nan;
          rej[x] = 255;
        }
      }
    }
  }
  if (o.fill_holes) out.filled = FillHolesFromBackground(&out.disparity);
  if (o.bilateral_sigma_disp > 0 && o.bilateral_sigma_space > 0) {
    // Edge-preserving smoothing of the (filled) map; pixels still unknown stay unknown.
    cv::Mat known = out.disparity == out.disparity;  // false for NaN
    cv::Mat src = out.disparity.clone();
    src.setTo(0, ~known);
    cv::Mat smooth;
    const int diameter = static_cast<int>(std::ceil(o.bilateral_sigma_space * 2)) * 2 + 1;
    cv::bilateralFilter(src, smooth, diameter, o.bilateral_sigma_disp, o.bilateral_sigma_space);
    smooth.copyTo(out.disparity, known);
  }
  return out;
}

}  // namespace hedgefit::stereo
