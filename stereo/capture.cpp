#include "stereo/capture.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "cloud/error.hpp"
#include "stereo/bspline.hpp"

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
  if (!box.empty() && (box.width < 3 || box.height < 3 || box.x < 0 || box.y < 0)) {
    throw Error("box: give X,Y,W,H with X, Y >= 0 and W, H >= 3 px");
  }
  if (!(depth_tolerance_px > 0)) throw Error("depth_tolerance: must be > 0 px");
}

namespace {

// True when every pixel has B = G = R: a grey image stored as colour.
bool IsGrey(const cv::Mat& bgr) {
  for (int y = 0; y < bgr.rows; ++y) {
    const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      if (p[x][0] != p[x][1] || p[x][1] != p[x][2]) return false;
    }
  }
  return true;
}

}  // namespace

cv::Mat SegmentHedge(const cv::Mat& bgr, const SegmentOptions& o) {
  o.Check();
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("stereo.segment: needs a colour (BGR) image");
  if (IsGrey(bgr)) {
    throw Error("no hedge found: the image has no colour, so excess green cannot segment it; segment by depth "
                "inside a box around the hedge (convert --box X,Y,W,H) or give a mask");
  }
  // Excess green 2G - R - B in [-510, 510], mapped to 8 bits ([0, 255] ~ ExG / 4 + 127.5):
  // 8-bit images make the bilateral filter ~3x faster (table-driven range weights), and
  // Otsu bins 256 levels anyway.
  cv::Mat exg(bgr.size(), CV_8U);
  cv::parallel_for_(cv::Range(0, bgr.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y);
      std::uint8_t* out = exg.ptr<std::uint8_t>(y);
      for (int x = 0; x < bgr.cols; ++x) out[x] = std::uint8_t((2 * p[x][1] - p[x][2] - p[x][0] + 510) >> 2);
    }
  });
  if (o.bilateral_diameter > 0) {
    cv::Mat smooth;
    cv::bilateralFilter(exg, smooth, o.bilateral_diameter, o.bilateral_sigma_color * 255.0, o.bilateral_sigma_space);
    exg = smooth;
  }
  // y = (x + esp)^gamma on x in [0, 1], stretched to the image's own range, as one table.
  double lo = 0, hi = 0;
  cv::minMaxLoc(exg, &lo, &hi);
  auto curve = [&](double level) { return std::pow(std::max(0.0, level / 255.0 + o.esp), o.gamma); };
  const double c_lo = curve(lo), c_hi = curve(hi);
  cv::Mat lut(1, 256, CV_8U);
  for (int i = 0; i < 256; ++i) {
    lut.at<std::uint8_t>(i) = cv::saturate_cast<std::uint8_t>(c_hi > c_lo ? 255.0 * (curve(i) - c_lo) / (c_hi - c_lo) : 0.0);
  }
  cv::Mat g8;
  cv::LUT(exg, lut, g8);
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
  if (o.fill_holes) mask = FillHoles(mask);
  return ErodeMask(mask, o.erode_px);
}

cv::Mat FillHoles(const cv::Mat& mask) {
  if (cv::countNonZero(mask) == 0) return mask.clone();
  // Holes: background regions not connected to the image border.
  cv::Mat inv = ~mask, padded;
  cv::copyMakeBorder(inv, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 255);
  cv::floodFill(padded, cv::Point(0, 0), 0);
  return mask | padded(cv::Rect(1, 1, mask.cols, mask.rows));
}

cv::Mat SegmentByDepth(const cv::Mat& disparity, const cv::Rect& box, double tolerance_px, int erode_px) {
  const cv::Rect b = box & cv::Rect(0, 0, disparity.cols, disparity.rows);
  if (b.width < 3 || b.height < 3) throw Error("stereo.segment: the box lies outside the image");
  // The object's disparity: the median over the box's central third.
  const cv::Rect core(b.x + b.width / 3, b.y + b.height / 3, std::max(1, b.width / 3), std::max(1, b.height / 3));
  std::vector<float> values;
  for (int y = core.y; y < core.y + core.height; ++y) {
    for (int x = core.x; x < core.x + core.width; ++x) {
      const float d = disparity.at<float>(y, x);
      if (std::isfinite(d)) values.push_back(d);
    }
  }
  if (values.size() < 9) throw Error("no hedge found: no disparity in the middle of the box within the working range");
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(values.size() / 2), values.end());
  const float seed = values[values.size() / 2];
  cv::Mat candidate = cv::Mat::zeros(disparity.size(), CV_8U);
  for (int y = b.y; y < b.y + b.height; ++y) {
    for (int x = b.x; x < b.x + b.width; ++x) {
      const float d = disparity.at<float>(y, x);
      if (std::isfinite(d) && std::abs(d - seed) <= tolerance_px) candidate.at<std::uint8_t>(y, x) = 255;
    }
  }
  // The connected region with most pixels in the core: the object, not a patch of ground
  // or background that happens to lie at the same depth elsewhere in the box.
  cv::Mat labels;
  const int n = cv::connectedComponents(candidate, labels, 8, CV_32S);
  std::vector<int> in_core(static_cast<std::size_t>(n), 0);
  for (int y = core.y; y < core.y + core.height; ++y) {
    for (int x = core.x; x < core.x + core.width; ++x) ++in_core[std::size_t(labels.at<int>(y, x))];
  }
  in_core[0] = 0;
  const int best = static_cast<int>(std::max_element(in_core.begin(), in_core.end()) - in_core.begin());
  if (best == 0 || in_core[std::size_t(best)] == 0) throw Error("no hedge found: nothing at one depth in the box");
  return ErodeMask(FillHoles(labels == best), erode_px);
}

cv::Mat ErodeMask(const cv::Mat& mask, int px) {
  if (px <= 0) return mask;
  cv::Mat out;
  cv::erode(mask, out, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * px + 1, 2 * px + 1)));
  return out;
}

namespace {

// Rectification maps for one camera of a rig, cached: building them costs ~10 ms per
// camera at 1920x1200 and a batch converts many captures with one rig. Fixed-point maps
// (CV_16SC2 + interpolation table) remap faster than float ones.
struct RectifyMaps {
  cv::Mat map1, map2;  // fixed point, for cv::remap
  cv::Mat map_xy;      // CV_32FC2, for the B-spline remap of the matched region
};

std::shared_ptr<const RectifyMaps> MapsFor(const cv::Mat& K, const cv::Mat& D, const cv::Mat& R, const cv::Mat& P,
                                           const cv::Size& size) {
  static std::mutex mutex;
  static std::vector<std::pair<std::vector<double>, std::shared_ptr<const RectifyMaps>>> cache;  // newest last
  std::vector<double> key = {double(size.width), double(size.height)};
  for (const cv::Mat* m : {&K, &D, &R, &P}) {
    cv::Mat d;
    m->convertTo(d, CV_64F);
    key.insert(key.end(), d.begin<double>(), d.end<double>());
  }
  std::lock_guard<std::mutex> lock(mutex);
  for (const auto& entry : cache) {
    if (entry.first == key) return entry.second;
  }
  auto maps = std::make_shared<RectifyMaps>();
  cv::Mat m1, m2;
  cv::initUndistortRectifyMap(K, D, R, P, size, CV_32FC2, m1, m2);
  cv::convertMaps(m1, m2, maps->map1, maps->map2, CV_16SC2);
  maps->map_xy = m1;
  if (cache.size() >= 8) cache.erase(cache.begin());
  cache.emplace_back(std::move(key), maps);
  return maps;
}

}  // namespace

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
  const auto lm = MapsFor(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size);
  const auto rm = MapsFor(rig.K2, rig.D2, rig.R2, rig.P2, rig.image_size);
  cv::remap(left, *left_rect, lm->map1, lm->map2, cv::INTER_LINEAR);
  cv::remap(right, *right_rect, rm->map1, rm->map2, cv::INTER_LINEAR);
}

cv::Rect RectifiedBox(const StereoRig& rig, const cv::Rect& box) {
  std::vector<cv::Point2f> edge, rect;
  for (int i = 0; i <= 8; ++i) {
    const float fx = float(box.x + box.width * i / 8.0), fy = float(box.y + box.height * i / 8.0);
    edge.emplace_back(fx, float(box.y));
    edge.emplace_back(fx, float(box.y + box.height));
    edge.emplace_back(float(box.x), fy);
    edge.emplace_back(float(box.x + box.width), fy);
  }
  cv::undistortPoints(edge, rect, rig.K1, rig.D1, rig.R1, rig.P1);
  return cv::boundingRect(rect) & cv::Rect(0, 0, rig.image_size.width, rig.image_size.height);
}

void RectifyRegionPrecisely(const StereoRig& rig, const cv::Mat& left, const cv::Mat& right, const cv::Rect& roi,
                            cv::Mat* left_rect, cv::Mat* right_rect) {
  const auto lm = MapsFor(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size);
  const auto rm = MapsFor(rig.K2, rig.D2, rig.R2, rig.P2, rig.image_size);
  RemapBSpline(left, lm->map_xy(roi)).copyTo((*left_rect)(roi));
  RemapBSpline(right, rm->map_xy(roi)).copyTo((*right_rect)(roi));
}

cloud::PointCloud Reproject(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& left_rect,
                            const StereoRig& rig, const ReprojectOptions& o, const cv::Mat& disparity_sigma) {
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
      const float own = disparity_sigma.empty() ? nan : disparity_sigma.at<float>(y, x);
      // The window's residuals cannot see interpolation or calibration error, so a pixel's
      // own estimate is floored at 0.02 px (the lab's remaining systematic error is ~0.01).
      const double sigma_d = std::isfinite(own) ? std::max(0.02, double(own)) : o.sigma_disparity_px;
      sigma_field.push_back(float(p_rect[2] * p_rect[2] * sigma_d / (f * b)));
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
  auto last = t0;
  auto lap = [&last]() {
    const auto now = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - last).count();
    last = now;
    return ms;
  };
  ConvertResult r;
  RectifyPair(rig, left_bgr, right_bgr, &r.left_rect, &r.right_rect);
  r.stage_ms.rectify = lap();
  if (!options.mask_path.empty()) {
    cv::Mat user = cv::imread(options.mask_path, cv::IMREAD_GRAYSCALE);
    if (user.empty() || user.size() != rig.image_size) {
      throw Error(options.mask_path + ": cannot read the mask, or its size differs from the images");
    }
    // The mask is drawn on the unrectified left image: rectify it the same way.
    const auto maps = MapsFor(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size);
    cv::remap(user, r.mask, maps->map1, maps->map2, cv::INTER_NEAREST);
    r.mask = ErodeMask(r.mask > 127, options.segment.erode_px);
  } else if (options.box.empty()) {
    r.mask = SegmentHedge(r.left_rect, options.segment);
  }
  SgbmOptions sg = options.sgbm;
  DisparityRangeForDepth(rig.P1.at<double>(0, 0), rig.baseline_mm, options.min_z_mm, options.max_z_mm,
                         &sg.min_disparity, &sg.num_disparities);
  if (options.mask_path.empty() && !options.box.empty()) {
    // Segment by depth: match the box's region, then keep what lies at the depth of its middle.
    const cv::Rect box = RectifiedBox(rig, options.box);
    cv::Mat box_mask = cv::Mat::zeros(r.left_rect.size(), CV_8U);
    box_mask(box).setTo(255);
    const cv::Rect roi = MatchRegion(box_mask, sg, options.margin_px);
    if (options.precise_resampling) RectifyRegionPrecisely(rig, left_bgr, right_bgr, roi, &r.left_rect, &r.right_rect);
    SgbmOptions coarse = sg;
    coarse.refine_radius = 0;
    coarse.fill_holes = false;
    cv::Mat disparity(r.left_rect.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    ComputeDisparity(r.left_rect(roi), r.right_rect(roi), coarse).disparity.copyTo(disparity(roi));
    r.mask = SegmentByDepth(disparity, box, options.depth_tolerance_px, options.segment.erode_px);
  }
  if (cv::countNonZero(r.mask) == 0) throw Error("no hedge found: the segmentation mask is empty");
  r.stage_ms.segment = lap();
  const cv::Size size = r.left_rect.size();
  cv::Rect roi(0, 0, size.width, size.height);
  if (options.region_only) roi = MatchRegion(r.mask, sg, options.margin_px);
  r.matched_region = roi;
  // The matched region again, with B-spline instead of bilinear resampling: matching to
  // hundredths of a pixel needs resampling that does not shift the texture (see bspline.hpp).
  if (options.precise_resampling) RectifyRegionPrecisely(rig, left_bgr, right_bgr, roi, &r.left_rect, &r.right_rect);
  r.stage_ms.rectify += lap();
  r.matched_fraction = double(roi.area()) / double(size.area());
  const DisparityMap d = ComputeDisparity(r.left_rect(roi), r.right_rect(roi), sg, r.mask(roi));
  r.disparity = cv::Mat(size, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  d.disparity.copyTo(r.disparity(roi));
  r.filled = cv::Mat::zeros(size, CV_8U);
  d.rejected.copyTo(r.filled(roi));
  r.disparity_sigma = cv::Mat(size, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  if (!d.sigma.empty()) d.sigma.copyTo(r.disparity_sigma(roi));
  r.stage_ms.match = lap();
  // Filled pixels are occluded or mismatched in the other view: no measurement, so by
  // default they stay in the dense map but not in the cloud.
  r.cloud = Reproject(r.disparity, options.reproject.keep_filled ? r.mask : (r.mask & ~r.filled), r.left_rect, rig,
                      options.reproject, r.disparity_sigma);
  if (r.cloud.size() - cloud::CountNonFinite(r.cloud) == 0) {
    throw Error("no hedge found: no disparity inside the mask within the working range");
  }
  r.stage_ms.reproject = lap();
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
