#include "render/overlay.hpp"

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "pipeline/error.hpp"

namespace hedgefit::render {

namespace {

// A point of the unrectified left camera frame (mm) to the rectified left image (px).
bool ToRectifiedPixel(const stereo::StereoRig& rig, const cv::Vec3d& p, cv::Point2d* px) {
  const cv::Vec3d q = cv::Matx33d(rig.R1) * p;
  const cv::Matx34d P(rig.P1);
  const cv::Vec3d h = P * cv::Vec4d(q[0], q[1], q[2], 1.0);
  if (!(h[2] > 1e-9)) return false;
  *px = cv::Point2d(h[0] / h[2], h[1] / h[2]);
  return true;
}

cv::Scalar Bgr(const std::array<double, 3>& rgb) { return cv::Scalar(255 * rgb[2], 255 * rgb[1], 255 * rgb[0]); }

}  // namespace

std::vector<cv::Point2d> SphereOutline(const stereo::StereoRig& rig, const fitting::Sphere& sphere, int n) {
  std::vector<cv::Point2d> out;
  if (rig.R1.empty() || rig.P1.empty()) throw Error("overlay: the rig has no rectification (R1, P1)");
  const Eigen::Vector3d c = sphere.center_mm;
  const double d = c.norm(), r = sphere.radius_mm;
  if (!(d > r) || !(c.z() > 0)) return out;
  // Rays from the camera grazing the sphere touch it on a circle: in the plane normal to c at
  // distance d - r^2/d from the camera, with radius r sqrt(d^2 - r^2) / d.
  const Eigen::Vector3d u = c / d;
  const Eigen::Vector3d e1 = u.unitOrthogonal(), e2 = u.cross(e1);
  const double along = d - r * r / d, rho = r * std::sqrt(d * d - r * r) / d;
  for (int k = 0; k < n; ++k) {
    const double t = 2 * M_PI * k / n;
    const Eigen::Vector3d p = u * along + rho * (std::cos(t) * e1 + std::sin(t) * e2);
    cv::Point2d px;
    if (ToRectifiedPixel(rig, cv::Vec3d(p.x(), p.y(), p.z()), &px)) out.push_back(px);
  }
  return out;
}

cv::Mat DrawOverlay(const cv::Mat& left_rect, const stereo::StereoRig& rig, const cv::Mat& mask,
                    const std::vector<SphereOverlay>& spheres, int line_px, bool crop) {
  cv::Mat out;
  if (left_rect.channels() == 1) {
    cv::cvtColor(left_rect, out, cv::COLOR_GRAY2BGR);
  } else {
    out = left_rect.clone();
  }
  const int shift = 4;  // sub-pixel drawing: coordinates in 1/16 px
  auto fixed = [](const cv::Point2d& p) { return cv::Point(cvRound(p.x * 16), cvRound(p.y * 16)); };
  if (!mask.empty()) {
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    cv::drawContours(out, contours, -1, cv::Scalar(255, 0, 255), line_px, cv::LINE_AA);
  }
  std::size_t fitted = 0;
  std::vector<std::pair<std::string, cv::Scalar>> legend;
  if (!mask.empty()) legend.emplace_back("magenta: the hedge's mask (the pixels matched)", cv::Scalar(255, 0, 255));
  std::vector<cv::Point2f> drawn;
  for (const auto& s : spheres) {
    const cv::Scalar colour = s.truth ? cv::Scalar(0, 0, 0) : Bgr(OverlayColor(fitted++));
    const std::vector<cv::Point2d> outline = SphereOutline(rig, s.sphere);
    if (outline.empty()) continue;
    std::vector<cv::Point> poly;
    for (const auto& p : outline) {
      poly.push_back(fixed(p));
      drawn.emplace_back(float(p.x), float(p.y));
    }
    if (s.dashed) {  // every other stretch of the outline: a sphere its points are not on
      const std::size_t dash = std::max<std::size_t>(1, poly.size() / 48);
      for (std::size_t k = 0; k < poly.size(); k += 2 * dash) {
        std::vector<cv::Point> stretch(poly.begin() + std::ptrdiff_t(k),
                                       poly.begin() + std::ptrdiff_t(std::min(poly.size(), k + dash + 1)));
        cv::polylines(out, stretch, false, colour, line_px, cv::LINE_AA, shift);
      }
    } else {
      cv::polylines(out, poly, true, colour, line_px, cv::LINE_AA, shift);
    }
    cv::Point2d centre;
    const Eigen::Vector3d& c = s.sphere.center_mm;
    if (ToRectifiedPixel(rig, cv::Vec3d(c.x(), c.y(), c.z()), &centre)) {
      cv::drawMarker(out, cv::Point(cvRound(centre.x), cvRound(centre.y)), colour, cv::MARKER_CROSS, 8 * line_px, line_px);
    }
    char text[200];
    std::snprintf(text, sizeof(text), "%s: r %.1f mm, centre (%.0f, %.0f, %.0f) mm", s.label.c_str(),
                  s.sphere.radius_mm, c.x(), c.y(), c.z());
    legend.emplace_back(text, colour);
  }
  if (crop && !drawn.empty()) {
    cv::Rect box = cv::boundingRect(drawn);
    box -= cv::Point(box.width / 4, box.height / 4);
    box += cv::Size(box.width / 2, box.height / 2);
    box &= cv::Rect(0, 0, out.cols, out.rows);
    if (box.area() > 0) out = out(box).clone();
  }
  // The legend, one line per sphere, top left on a light band so it reads on any image; Hershey
  // simplex at 0.6 draws capitals 14 px tall, the least that reads at the picture's own size.
  const double font = std::max(0.6, std::min(out.cols, out.rows) / 900.0);
  int baseline = 0;
  const int line_h = cv::getTextSize("Ag", cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline).height + baseline + 4;
  for (std::size_t i = 0; i < legend.size(); ++i) {
    const cv::Point at(6, 6 + line_h * int(i + 1) - baseline);
    const cv::Size size = cv::getTextSize(legend[i].first, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline);
    cv::rectangle(out, cv::Rect(at.x - 3, at.y - size.height - 3, size.width + 6, line_h), cv::Scalar(255, 255, 255),
                  cv::FILLED);
    cv::putText(out, legend[i].first, at, cv::FONT_HERSHEY_SIMPLEX, font, legend[i].second, 1, cv::LINE_AA);
  }
  return out;
}

}  // namespace hedgefit::render
