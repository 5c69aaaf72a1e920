#include "render/top_view.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "pipeline/error.hpp"
#include "pipeline/print.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::render {

void WriteTopView(const cloud::PointCloud& cloud, const scene::FindResult& result, const std::string& path, int size,
                  const std::vector<Eigen::Vector2d>& marks) {
  // Scene frame: up is +z, so the top view is (x, y), y drawn upwards.
  std::vector<Eigen::Vector3d> pts(cloud.size(), Eigen::Vector3d::Constant(std::nan("")));
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  double zlo = 1e300, zhi = -1e300;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.points_mm[i].allFinite()) continue;
    pts[i] = result.scene_from_cloud * cloud.points_mm[i].cast<double>();
    lo = lo.cwiseMin(pts[i].head<2>()), hi = hi.cwiseMax(pts[i].head<2>());
    zlo = std::min(zlo, pts[i].z()), zhi = std::max(zhi, pts[i].z());
  }
  if (!(hi.x() >= lo.x())) lo = hi = Eigen::Vector2d::Zero();
  // The view frames the objects (with 2 m about them), not a scan's far, sparse lawn.
  if (!result.objects.empty()) {
    Eigen::Vector2d olo(1e300, 1e300), ohi(-1e300, -1e300);
    for (const auto& o : result.objects) {
      for (const auto& p : o.top_outline_mm) olo = olo.cwiseMin(p), ohi = ohi.cwiseMax(p);
    }
    if (ohi.x() >= olo.x()) {
      lo = lo.cwiseMax(olo - Eigen::Vector2d::Constant(2000));
      hi = hi.cwiseMin(ohi + Eigen::Vector2d::Constant(2000));
    }
  }
  const double margin = 60, span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1.0});
  const double px = (size - 2 * margin) / span;
  const int w = int(std::ceil((hi.x() - lo.x()) * px + 2 * margin)), h = int(std::ceil((hi.y() - lo.y()) * px + 2 * margin));
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  auto at = [&](const Eigen::Vector2d& p) {
    return cv::Point(int(std::lround(margin + (p.x() - lo.x()) * px)), int(std::lround(h - margin - (p.y() - lo.y()) * px)));
  };
  std::vector<int> kind(cloud.size(), 0);  // 0 ground or nothing, 1 ball, 2 other
  for (const auto& o : result.objects) for (std::size_t i : o.indices) kind[i] = o.topiary ? 1 : 2;
  // Draw low points first so the tops of objects stay visible.
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < cloud.size(); ++i) if (pts[i].allFinite()) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return pts[a].z() < pts[b].z(); });
  const double zr = std::max(zhi - zlo, 1.0);
  for (std::size_t i : order) {
    const double t = (pts[i].z() - zlo) / zr;
    cv::Vec3b c;
    if (kind[i] == 1) {
      c = cv::Vec3b(uchar(60 + 60 * t), uchar(120 + 110 * t), uchar(40 + 50 * t));  // green, lighter higher
    } else if (kind[i] == 2) {
      c = cv::Vec3b(uchar(90 + 80 * t), uchar(120 + 80 * t), uchar(150 + 90 * t));  // brownish
    } else {
      c = cv::Vec3b(uchar(190 + 40 * t), uchar(190 + 40 * t), uchar(190 + 40 * t));  // ground: light grey
    }
    if ((pts[i].head<2>().array() < lo.array()).any() || (pts[i].head<2>().array() > hi.array()).any()) continue;
    const cv::Point q = at(pts[i].head<2>());
    if (q.x >= 0 && q.y >= 0 && q.x < w && q.y < h) img.at<cv::Vec3b>(q) = c;
  }
  const cv::Scalar green(40, 150, 20), orange(0, 120, 240);
  for (const auto& o : result.objects) {
    if (o.shape && o.topiary) {
      // A topiary found by height: its footprint (the widest section above the ground), turned by
      // its heading, with its number and class.
      const auto& s = *o.shape;
      const cv::Point c = at(s.center_mm.head<2>());
      const cv::Size axes(std::max(2, int(std::lround(s.footprint_mm.x() * px))), std::max(2, int(std::lround(s.footprint_mm.y() * px))));
      if (s.shape == "cuboid") {
        // A box's footprint is its rectangle (the image's y runs down: the heading turns clockwise).
        cv::Point2f corners[4];
        cv::RotatedRect(cv::Point2f(c), cv::Size2f(2.f * float(axes.width), 2.f * float(axes.height)), float(-s.heading_deg)).points(corners);
        for (int k = 0; k < 4; ++k) cv::line(img, corners[k], corners[(k + 1) % 4], green, 2, cv::LINE_AA);
      } else {
        cv::ellipse(img, c, axes, -s.heading_deg, 0, 360, green, 2, cv::LINE_AA);
      }
      cv::putText(img, std::to_string(o.id) + " " + s.shape, c + cv::Point(axes.width / 2 + 4, -axes.height / 2 - 4),
                  cv::FONT_HERSHEY_SIMPLEX, 0.6, green, 2, cv::LINE_AA);
    } else if (o.ball && o.fit.converged) {
      const Eigen::Vector3d c = result.scene_from_cloud * o.fit.sphere.center_mm;
      cv::circle(img, at(c.head<2>()), std::max(2, int(std::lround(o.fit.sphere.radius_mm * px))), green, 2, cv::LINE_AA);
      const int rad = std::max(2, int(std::lround(o.fit.sphere.radius_mm * px)));
      cv::putText(img, std::to_string(o.id), at(c.head<2>()) + cv::Point(rad / 2 + 4, -rad / 2 - 4), cv::FONT_HERSHEY_SIMPLEX,
                  0.7, green, 2, cv::LINE_AA);
    } else {
      std::vector<cv::Point> hull;
      for (const auto& p : o.top_outline_mm) hull.push_back(at(p));
      if (hull.size() >= 2) cv::polylines(img, hull, true, orange, 2, cv::LINE_AA);
      cv::putText(img, std::to_string(o.id), at(o.top_center_mm) + cv::Point(6, -6), cv::FONT_HERSHEY_SIMPLEX, 0.6,
                  orange, 2, cv::LINE_AA);
    }
  }
  for (const auto& m : marks) {
    const Eigen::Vector3d v = result.scene_from_cloud * Eigen::Vector3d(m.x(), m.y(), 0);
    cv::drawMarker(img, at(v.head<2>()), cv::Scalar(0, 0, 0), cv::MARKER_CROSS, 18, 2, cv::LINE_AA);
  }
  // A scale bar of 1 m, and the legend.
  const cv::Point bar(int(margin), h - int(margin / 2));
  cv::line(img, bar, bar + cv::Point(int(1000 * px), 0), cv::Scalar(0, 0, 0), 2);
  cv::putText(img, "1 m", bar + cv::Point(0, -6), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  const std::size_t shapes = result.Topiary(), others = result.objects.size() - shapes;
  cv::putText(img, pipeline::Format("%zu ball%s or topiary (green), %zu other%s (orange)%s", shapes, shapes == 1 ? "" : "s",
                                    others, others == 1 ? "" : "s",
                                    marks.empty() ? "" : pipeline::Format(", %zu marks (black +)", marks.size()).c_str()),
              cv::Point(int(margin), int(margin / 2)), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  stereo::WriteImageAtomic(path, img);
}

std::vector<Eigen::Vector2d> ReadTopViewMarks(const std::string& path, double scale) {
  std::ifstream in(path);
  if (!in) throw InputError("--plot-marks " + path + ": cannot read it (a text file of 'x y' per line, in the cloud's units)");
  std::vector<Eigen::Vector2d> marks;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    line = line.substr(0, line.find('#'));
    for (char& ch : line) if (ch == ',') ch = ' ';
    std::istringstream fields(line);
    double x = 0, y = 0;
    if (!(fields >> x)) continue;
    if (!(fields >> y) || !std::isfinite(x) || !std::isfinite(y)) {
      throw InputError(pipeline::Format("--plot-marks %s line %d: expected two numbers 'x y'", path.c_str(), n));
    }
    marks.emplace_back(x * scale, y * scale);
  }
  return marks;
}

}  // namespace hedgefit::render
