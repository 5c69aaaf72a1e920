#include "stereo/rectification.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <memory>
#include <mutex>
#include <vector>

#include "pipeline/error.hpp"
#include "stereo/bspline.hpp"
#include "stereo/remap_linear.hpp"

namespace hedgefit::stereo {

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
  RemapLinearFixed(left, lm->map1, lm->map2, left_rect);
  RemapLinearFixed(right, rm->map1, rm->map2, right_rect);
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

cv::Rect OriginalBox(const StereoRig& rig, const cv::Rect& rb) {
  const auto maps = MapsFor(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size);
  const cv::Rect b = rb & cv::Rect(0, 0, maps->map_xy.cols, maps->map_xy.rows);
  if (b.empty()) return {};
  std::vector<cv::Point2f> edge;
  for (int i = 0; i <= 8; ++i) {
    const int x = b.x + (b.width - 1) * i / 8, y = b.y + (b.height - 1) * i / 8;
    for (const cv::Point& q : {cv::Point(x, b.y), cv::Point(x, b.y + b.height - 1), cv::Point(b.x, y),
                               cv::Point(b.x + b.width - 1, y)}) {
      edge.push_back(maps->map_xy.at<cv::Point2f>(q));
    }
  }
  return cv::boundingRect(edge) & cv::Rect(0, 0, rig.image_size.width, rig.image_size.height);
}

void RectifyRegionPrecisely(const StereoRig& rig, const cv::Mat& left, const cv::Mat& right, const cv::Rect& roi,
                            cv::Mat* left_rect, cv::Mat* right_rect) {
  const auto lm = MapsFor(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size);
  const auto rm = MapsFor(rig.K2, rig.D2, rig.R2, rig.P2, rig.image_size);
  RemapBSplineInto(left, lm->map_xy(roi), (*left_rect)(roi));
  RemapBSplineInto(right, rm->map_xy(roi), (*right_rect)(roi));
}

cv::Mat RectifyLeftMask(const StereoRig& rig, const cv::Mat& mask) {
  const auto maps = MapsFor(rig.K1, rig.D1, rig.R1, rig.P1, rig.image_size);
  cv::Mat out;
  cv::remap(mask, out, maps->map1, maps->map2, cv::INTER_NEAREST);
  return out > 127;
}

}  // namespace hedgefit::stereo
