#include "around/around_view.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "pipeline/print.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::around {

void WriteAroundView(const FuseResult& r, const std::string& path, int size) {
  // The view: looking down the vertical; the first capture's forward points up the picture.
  const Eigen::Vector3d up = r.up.normalized();
  Eigen::Vector3d ahead = Eigen::Vector3d::UnitZ();
  if (!r.poses.empty()) ahead = r.poses.front().refined.linear() * Eigen::Vector3d::UnitZ();
  ahead = (ahead - ahead.dot(up) * up).normalized();
  if (!ahead.allFinite()) ahead = up.unitOrthogonal();
  const Eigen::Vector3d right = ahead.cross(up);  // x of the picture
  auto plane = [&](const Eigen::Vector3d& p) { return Eigen::Vector2d(p.dot(right), p.dot(ahead)); };
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const auto& p : r.poses) lo = lo.cwiseMin(plane(p.refined.translation())), hi = hi.cwiseMax(plane(p.refined.translation()));
  for (const auto& h : r.hedges) {
    const Eigen::Vector2d c = plane(h.fit.fit.sphere.center_mm);
    const double rad = h.fit.fit.sphere.radius_mm;
    lo = lo.cwiseMin(c - Eigen::Vector2d::Constant(rad)), hi = hi.cwiseMax(c + Eigen::Vector2d::Constant(rad));
  }
  if (!(hi.x() >= lo.x())) lo = hi = Eigen::Vector2d::Zero();
  lo -= Eigen::Vector2d::Constant(400), hi += Eigen::Vector2d::Constant(400);
  const double margin = 60, span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1.0});
  const double px = (size - 2 * margin) / span;
  const int w = int(std::ceil((hi.x() - lo.x()) * px + 2 * margin)), h = int(std::ceil((hi.y() - lo.y()) * px + 2 * margin)) + 40;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  auto at = [&](const Eigen::Vector2d& p) {
    return cv::Point(int(std::lround(margin + (p.x() - lo.x()) * px)), int(std::lround(h - 40 - margin - (p.y() - lo.y()) * px)));
  };
  // Eight colours, one per capture (BGR), repeated past eight.
  const cv::Scalar palette[] = {{200, 80, 30},  {40, 140, 240}, {60, 170, 60},  {40, 40, 220},
                                {170, 90, 150}, {90, 140, 140}, {200, 120, 230}, {20, 20, 20}};
  auto colour = [&](int capture) { return palette[std::size_t(std::max(0, capture - 1)) % 8]; };
  // Points, lowest first, so each hedge's top shows.
  const auto& cap = r.cloud.fields.count("capture") ? r.cloud.fields.at("capture") : std::vector<float>();
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < r.cloud.size(); ++i) if (r.cloud.points_mm[i].allFinite()) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return r.cloud.points_mm[a].cast<double>().dot(up) < r.cloud.points_mm[b].cast<double>().dot(up);
  });
  for (std::size_t i : order) {
    const cv::Point q = at(plane(r.cloud.points_mm[i].cast<double>()));
    if (q.x < 0 || q.y < 0 || q.x >= w || q.y >= h) continue;
    const cv::Scalar c = colour(cap.empty() ? 1 : int(cap[i]));
    img.at<cv::Vec3b>(q) = cv::Vec3b(uchar(c[0]), uchar(c[1]), uchar(c[2]));
  }
  for (const auto& hd : r.hedges) {
    const Eigen::Vector2d c = plane(hd.fit.fit.sphere.center_mm);
    const int rad = std::max(2, int(std::lround(hd.fit.fit.sphere.radius_mm * px)));
    // An unconfirmed hedge (FusedHedge::unconfirmed) in grey, thin, and said so.
    const bool confirmed = hd.unconfirmed.empty();
    const cv::Scalar ink = confirmed ? cv::Scalar(0, 0, 0) : cv::Scalar(150, 150, 150);
    cv::circle(img, at(c), rad, ink, confirmed ? 2 : 1, cv::LINE_AA);
    cv::putText(img,
                confirmed ? pipeline::Format("%d: r %.1f mm, %.0f%% seen", hd.id, hd.fit.fit.sphere.radius_mm, 100 * hd.coverage)
                          : pipeline::Format("%d: unconfirmed", hd.id),
                at(c) + cv::Point(-rad, rad + 22), cv::FONT_HERSHEY_SIMPLEX, 0.55, ink, 1, cv::LINE_AA);
  }
  // The cameras: a wedge from where each stood, opening the way it looked.
  for (std::size_t k = 0; k < r.poses.size(); ++k) {
    const auto& p = r.poses[k];
    const Eigen::Vector3d o = p.refined.translation();
    Eigen::Vector3d f = p.refined.linear() * Eigen::Vector3d::UnitZ();
    f = (f - f.dot(up) * up).normalized();
    const Eigen::Vector3d s = f.cross(up);
    const double len = 350;
    const std::vector<cv::Point> wedge = {at(plane(o)), at(plane(o + len * f + 0.6 * len * s)), at(plane(o + len * f - 0.6 * len * s))};
    const cv::Scalar c = p.used ? colour(int(k) + 1) : cv::Scalar(170, 170, 170);
    cv::fillConvexPoly(img, wedge, c, cv::LINE_AA);
    cv::putText(img, std::to_string(k + 1), at(plane(o - 180 * f)) + cv::Point(-6, 6), cv::FONT_HERSHEY_SIMPLEX, 0.6, c, 2,
                cv::LINE_AA);
  }
  const cv::Point bar(int(margin), h - 20);
  cv::line(img, bar, bar + cv::Point(int(1000 * px), 0), cv::Scalar(0, 0, 0), 2);
  cv::putText(img, "1 m", bar + cv::Point(0, -6), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  int used = 0;
  for (const auto& p : r.poses) used += p.used ? 1 : 0;
  cv::putText(img, pipeline::Format("%zu hedge%s from %d of %zu captures (points and cameras coloured by capture)",
                                    r.hedges.size(), r.hedges.size() == 1 ? "" : "s", used, r.poses.size()),
              cv::Point(int(margin), int(margin / 2)), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  stereo::WriteImageAtomic(path, img);
}

}  // namespace hedgefit::around
