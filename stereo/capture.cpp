#include "stereo/capture.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <limits>

#include "cloud/error.hpp"

namespace hedgefit::stereo {

void SegmentOptions::Check() const {
  if (!(gamma > 0)) throw Error("gamma: must be > 0");
  if (bilateral_diameter < 0 || bilateral_sigma_color < 0 || bilateral_sigma_space < 0) {
    throw Error("bilateral: diameter and sigmas must be >= 0");
  }
  if (erode_px < 0) throw Error("erode: must be >= 0 px");
}

void ConvertOptions::Check() const {
  segment.Check();
  sgbm.Check();
  if (!(min_z_mm > 0 && max_z_mm > min_z_mm)) throw Error("min_z/max_z: need 0 < min_z < max_z (mm)");
  if (margin_px < 0) throw Error("margin: must be >= 0 px");
}

cv::Mat SegmentHedge(const cv::Mat& bgr, const SegmentOptions& o) {
  o.Check();
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("stereo.segment: needs a colour (BGR) image");
  cv::Mat f;
  bgr.convertTo(f, CV_32FC3, 1.0 / 255.0);
  std::vector<cv::Mat> ch;
  cv::split(f, ch);
  // Excess green 2G - R - B in [-2, 2], mapped to [0, 1].
  cv::Mat exg = (2 * ch[1] - ch[2] - ch[0] + 2.0) / 4.0;
  if (o.bilateral_diameter > 0) {
    cv::Mat smooth;
    cv::bilateralFilter(exg, smooth, o.bilateral_diameter, o.bilateral_sigma_color, o.bilateral_sigma_space);
    exg = smooth;
  }
  cv::Mat g = exg + o.esp;
  cv::max(g, 0.0, g);
  cv::pow(g, o.gamma, g);
  cv::Mat g8;
  cv::normalize(g, g, 0, 255, cv::NORM_MINMAX);
  g.convertTo(g8, CV_8U);
  cv::Mat mask;
  cv::threshold(g8, mask, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  if (o.largest_component) {
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8);
    int best = 0, best_area = 0;
    for (int i = 1; i < n; ++i) {
      if (stats.at<int>(i, cv::CC_STAT_AREA) > best_area) best_area = stats.at<int>(i, cv::CC_STAT_AREA), best = i;
    }
    mask = labels == best;
    if (best == 0) mask.setTo(0);
  }
  if (o.fill_holes && cv::countNonZero(mask) > 0) {
    // Holes: background regions not connected to the image border.
    cv::Mat inv = ~mask, padded;
    cv::copyMakeBorder(inv, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 255);
    cv::floodFill(padded, cv::Point(0, 0), 0);
    mask |= padded(cv::Rect(1, 1, mask.cols, mask.rows));
  }
  if (o.erode_px > 0) {
    cv::erode(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * o.erode_px + 1, 2 * o.erode_px + 1)));
  }
  return mask;
}

void RectifyPair(const StereoRig& rig, const cv::Mat& left, const cv::Mat& right, cv::Mat* left_rect,
                 cv::Mat* right_rect) {
  if (rig.R1.empty() || rig.P1.empty() || rig.R2.empty() || rig.P2.empty()) {
    throw Error("stereo.rectify: the rig has no rectification (R1, P1, R2, P2); recalibrate with `hedgefit calibrate`");
  }
  if (left.size() != rig.image_size || right.size() != rig.image_size) {
    throw Error("stereo.rectify: images are " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                " but the rig was calibrated at " + std::to_string(rig.image_size.width) + "x" +
                std::to_string(rig.image_size.height));
  }
  cv::Mat m1, m2;
  cv::initUndistortRectifyMap(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size, CV_32FC2, m1, m2);
  cv::remap(left, *left_rect, m1, m2, cv::INTER_LINEAR);
  cv::initUndistortRectifyMap(rig.K2, rig.D2, rig.R2, rig.P2, rig.image_size, CV_32FC2, m1, m2);
  cv::remap(right, *right_rect, m1, m2, cv::INTER_LINEAR);
}

cloud::PointCloud Reproject(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& left_rect,
                            const StereoRig& rig, const ReprojectOptions& o) {
  cloud::PointCloud out;
  const cv::Matx44d Q(rig.Q);
  const cv::Matx33d R1t = cv::Matx33d(rig.R1).t();
  const double f = rig.P1.at<double>(0, 0), b = rig.baseline_mm;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> disp_field, sigma_field;
  for (int y = 0; y < disparity.rows; ++y) {
    for (int x = 0; x < disparity.cols; ++x) {
      const float d = disparity.at<float>(y, x);
      const bool use = std::isfinite(d) && d > 0 && (mask.empty() || mask.at<std::uint8_t>(y, x) != 0);
      if (!use) {
        if (o.organized) {
          out.points_mm.emplace_back(nan, nan, nan);
          out.colors.push_back({0, 0, 0});
          disp_field.push_back(nan);
          sigma_field.push_back(nan);
        }
        continue;
      }
      const cv::Vec4d h = Q * cv::Vec4d(x, y, d, 1.0);
      const cv::Vec3d p_rect(h[0] / h[3], h[1] / h[3], h[2] / h[3]);
      const cv::Vec3d p = R1t * p_rect;  // unrectified left camera frame
      out.points_mm.emplace_back(float(p[0]), float(p[1]), float(p[2]));
      const cv::Vec3b c = left_rect.channels() == 3 ? left_rect.at<cv::Vec3b>(y, x)
                                                    : cv::Vec3b::all(left_rect.at<std::uint8_t>(y, x));
      out.colors.push_back({c[2], c[1], c[0]});
      disp_field.push_back(d);
      sigma_field.push_back(float(p_rect[2] * p_rect[2] * o.sigma_disparity_px / (f * b)));
    }
  }
  if (o.organized) {
    out.width = static_cast<std::uint32_t>(disparity.cols);
    out.height = static_cast<std::uint32_t>(disparity.rows);
  } else {
    out.Flatten();
  }
  if (o.extra_fields) {
    out.fields["disparity"] = std::move(disp_field);
    out.fields["sigma_z"] = std::move(sigma_field);
  }
  return out;
}

ConvertResult ConvertCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig,
                             const ConvertOptions& options) {
  options.Check();
  const auto t0 = std::chrono::steady_clock::now();
  ConvertResult r;
  RectifyPair(rig, left_bgr, right_bgr, &r.left_rect, &r.right_rect);
  if (!options.mask_path.empty()) {
    cv::Mat user = cv::imread(options.mask_path, cv::IMREAD_GRAYSCALE);
    if (user.empty() || user.size() != rig.image_size) {
      throw Error(options.mask_path + ": cannot read the mask, or its size differs from the images");
    }
    // The mask is drawn on the unrectified left image: rectify it the same way.
    cv::Mat m1, m2;
    cv::initUndistortRectifyMap(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size, CV_32FC2, m1, m2);
    cv::remap(user, r.mask, m1, m2, cv::INTER_NEAREST);
    r.mask = r.mask > 127;
  } else {
    r.mask = SegmentHedge(r.left_rect, options.segment);
  }
  if (cv::countNonZero(r.mask) == 0) throw Error("no hedge found: the segmentation mask is empty");
  SgbmOptions sg = options.sgbm;
  DisparityRangeForDepth(rig.P1.at<double>(0, 0), rig.baseline_mm, options.min_z_mm, options.max_z_mm,
                         &sg.min_disparity, &sg.num_disparities);
  const cv::Size size = r.left_rect.size();
  cv::Rect roi(0, 0, size.width, size.height);
  if (options.region_only) roi = MatchRegion(r.mask, sg, options.margin_px);
  r.matched_region = roi;
  r.matched_fraction = double(roi.area()) / double(size.area());
  const DisparityMap d = ComputeDisparity(r.left_rect(roi), r.right_rect(roi), sg);
  r.disparity = cv::Mat(size, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  d.disparity.copyTo(r.disparity(roi));
  r.cloud = Reproject(r.disparity, r.mask, r.left_rect, rig, options.reproject);
  if (r.cloud.size() - cloud::CountNonFinite(r.cloud) == 0) {
    throw Error("no hedge found: no disparity inside the mask within the working range");
  }
  r.wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

cv::Rect MatchRegion(const cv::Mat& mask, const SgbmOptions& sgbm, int margin_px) {
  const cv::Rect box = cv::boundingRect(mask);
  const int reach = sgbm.min_disparity + sgbm.num_disparities;  // columns SGBM needs to the left
  const int x0 = std::max(0, box.x - margin_px - reach), y0 = std::max(0, box.y - margin_px);
  const int x1 = std::min(mask.cols, box.x + box.width + margin_px);
  const int y1 = std::min(mask.rows, box.y + box.height + margin_px);
  return cv::Rect(x0, y0, x1 - x0, y1 - y0);
}

cv::Mat ColorizeDisparity(const cv::Mat& disparity) {
  double lo = 0, hi = 1;
  cv::Mat known = disparity == disparity;
  cv::minMaxLoc(disparity, &lo, &hi, nullptr, nullptr, known);
  cv::Mat norm;
  disparity.convertTo(norm, CV_8U, 255.0 / std::max(1e-6, hi - lo), -lo * 255.0 / std::max(1e-6, hi - lo));
  cv::Mat color;
  cv::applyColorMap(norm, color, cv::COLORMAP_TURBO);
  color.setTo(cv::Scalar(0, 0, 0), ~known);
  return color;
}

cv::Mat MaskOverlay(const cv::Mat& bgr, const cv::Mat& mask) {
  cv::Mat out = bgr.clone(), tint(bgr.size(), bgr.type(), cv::Scalar(255, 0, 255));
  cv::Mat blended;
  cv::addWeighted(bgr, 0.5, tint, 0.5, 0, blended);
  blended.copyTo(out, ~mask);
  return out;
}

}  // namespace hedgefit::stereo
