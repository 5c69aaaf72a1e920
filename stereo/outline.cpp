#include "stereo/outline.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <vector>



namespace hedgefit::stereo {

namespace {

// The profile: samples every kStep px along the normal, from -kReach to +kReach about the border
// point, each the mean of kAcross samples along the border (1 px apart): a leaf's texture inside
// averages out, a straight edge does not.
constexpr double kStep = 0.25, kReach = 8.0;
constexpr int kAcross = 4;
// The edge is sought within this many px of the start sphere's outline (a fit to the front's
// points, a few mm and so a pixel or two off the envelope).
constexpr double kSearch = 6.0;
// Each side of a cut keeps at least this many px of the profile.
constexpr double kMinSide = 2.0;
// A cut counts when its two levels differ by more than this many times the profile's scatter
// about them: the 0.1 % tail of the scatter's normal distribution, not a grey level.
constexpr double kMinContrast = 3.0;

double Bilinear(const cv::Mat& img, double x, double y) {
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= img.cols || y0 + 1 >= img.rows) return std::nan("");
  const double fx = x - x0, fy = y - y0;
  const float* r0 = img.ptr<float>(y0);
  const float* r1 = img.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

// The two-level cut of the profile along `n` about `p` (grey image): its offset from p along n
// (px), or nullopt when there is none within kSearch or its levels differ too little.
std::optional<double> EdgeAlong(const cv::Mat& grey, cv::Point2d p, cv::Point2d n, double* contrast) {
  const cv::Point2d t(-n.y, n.x);
  const int count = int(std::lround(2 * kReach / kStep)) + 1;
  std::vector<double> v(static_cast<std::size_t>(count));
  for (int j = 0; j < count; ++j) {
    const double s = -kReach + j * kStep;
    double sum = 0;
    for (int a = 0; a < kAcross; ++a) {
      const double o = a - (kAcross - 1) / 2.0;
      const double value = Bilinear(grey, p.x + s * n.x + o * t.x, p.y + s * n.y + o * t.y);
      if (!std::isfinite(value)) return std::nullopt;
      sum += value;
    }
    v[std::size_t(j)] = sum / kAcross;
  }
  // Prefix sums: the squared residual about two levels, cut before sample k, in O(1) per k.
  std::vector<double> s1(std::size_t(count) + 1, 0.0), s2(std::size_t(count) + 1, 0.0);
  for (int j = 0; j < count; ++j) {
    s1[std::size_t(j) + 1] = s1[std::size_t(j)] + v[std::size_t(j)];
    s2[std::size_t(j) + 1] = s2[std::size_t(j)] + v[std::size_t(j)] * v[std::size_t(j)];
  }
  auto sse = [&](int k) {
    const double n1 = k, n2 = count - k;
    const double a = s2[std::size_t(k)] - s1[std::size_t(k)] * s1[std::size_t(k)] / n1;
    const double b = (s2[std::size_t(count)] - s2[std::size_t(k)]) -
                     (s1[std::size_t(count)] - s1[std::size_t(k)]) * (s1[std::size_t(count)] - s1[std::size_t(k)]) / n2;
    return a + b;
  };
  const int lo = std::max(int(std::lround((kReach - kSearch) / kStep)), int(std::lround(kMinSide / kStep))),
            hi = std::min(int(std::lround((kReach + kSearch) / kStep)), count - int(std::lround(kMinSide / kStep)));
  int best = -1;
  double best_sse = 0;
  for (int k = lo; k <= hi; ++k) {
    const double e = sse(k);
    if (best < 0 || e < best_sse) best = k, best_sse = e;
  }
  if (best <= lo || best >= hi) return std::nullopt;  // at the search's end: no edge inside it
  const double m1 = s1[std::size_t(best)] / best, m2 = (s1[std::size_t(count)] - s1[std::size_t(best)]) / (count - best);
  const double scatter = std::sqrt(std::max(best_sse, 1e-12) / (count - 2));
  *contrast = std::abs(m2 - m1) / scatter;
  if (*contrast < kMinContrast) return std::nullopt;
  // The cut lies between samples best - 1 and best; a parabola through the residuals about it
  // places it to a fraction of a step.
  const double em = sse(best - 1), e0 = best_sse, ep = sse(best + 1), den = em - 2 * e0 + ep;
  const double frac = den > 0 ? std::clamp(0.5 * (em - ep) / den, -0.5, 0.5) : 0.0;
  return -kReach + (best - 0.5 + frac) * kStep;
}

cv::Mat Grey(const cv::Mat& img) {
  cv::Mat g;
  if (img.channels() == 3) cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
  else g = img;
  cv::Mat f;
  g.convertTo(f, CV_32F);
  return f;
}

}  // namespace

std::vector<SilhouettePoint> SphereSilhouette(const cv::Vec3d& centre, double radius, const cv::Vec3d& origin, double f,
                                              double cx, double cy) {
  std::vector<SilhouettePoint> out;
  const cv::Vec3d w = centre - origin;
  const double D = cv::norm(w), r = radius;
  if (!(D > 1.05 * r) || !(w[2] > r)) return out;
  const cv::Vec3d a = w / D;
  const cv::Vec3d e1 = cv::normalize(a.cross(cv::Vec3d(0, 1, 0))), e2 = a.cross(e1);
  const double rho = r * std::sqrt(1 - r * r / (D * D));
  const cv::Vec3d ring = centre - a * (r * r / D);
  auto project = [&](const cv::Vec3d& p) {
    const cv::Vec3d q = p - origin;
    return cv::Point2d(f * q[0] / q[2] + cx, f * q[1] / q[2] + cy);
  };
  // About one point per pixel of the predicted outline.
  const int samples = std::max(64, int(2 * CV_PI * f * rho / w[2]));
  out.reserve(std::size_t(samples));
  for (int k = 0; k < samples; ++k) {
    const double phi = 2 * CV_PI * k / samples;
    const cv::Vec3d u = std::cos(phi) * e1 + std::sin(phi) * e2, q = ring + rho * u;
    const cv::Point2d p = project(q), p2 = project(q + 2.0 * u);
    cv::Point2d n = p2 - p;
    const double len = std::hypot(n.x, n.y);
    if (!(len > 1e-9) || q[2] - origin[2] <= 0) continue;
    n /= len;
    out.push_back({u, q, p, n});
  }
  return out;
}

cloud::HedgeOutlines MeasureOutlines(const cv::Mat& left_rect, const cv::Mat& right_rect, const cv::Mat& labels,
                                     const StereoRig& rig, const std::map<int, Eigen::Vector4d>& start,
                                     const std::optional<cv::Vec4d>& ground, std::map<int, OutlineStats>* stats) {
  cloud::HedgeOutlines out;
  if (left_rect.empty() || right_rect.empty() || rig.P1.empty()) return out;
  const cv::Mat grey[2] = {Grey(left_rect), Grey(right_rect)};
  const double f = rig.P1.at<double>(0, 0);
  const double cx[2] = {rig.P1.at<double>(0, 2), rig.P2.at<double>(0, 2)},
               cy[2] = {rig.P1.at<double>(1, 2), rig.P2.at<double>(1, 2)};
  const double tx = rig.P2.at<double>(0, 3) / f;  // the right camera sits at x = -tx in the rectified frame
  const cv::Matx33d R1(rig.R1), left_from_rect = R1.t();
  const cv::Vec3d centre_rect[2] = {cv::Vec3d(0, 0, 0), cv::Vec3d(-tx, 0, 0)};
  for (const auto& [id, sphere] : start) {
    const cv::Vec3d c = R1 * cv::Vec3d(sphere[0], sphere[1], sphere[2]);  // rectified frame
    const double r = sphere[3];
    std::vector<cloud::TangentRay> rays;
    std::vector<double> contrasts;
    OutlineStats st;
    for (int view = 0; view < 2; ++view) {
      const cv::Vec3d o = centre_rect[view];
      for (const SilhouettePoint& point : SphereSilhouette(c, r, o, f, cx[view], cy[view])) {
        const cv::Vec3d& q = point.q;
        const cv::Point2d& p = point.p;
        const cv::Point2d& n = point.n;
        ++st.border;
        const cv::Mat& img = grey[view];
        if (p.x < kReach + 4 || p.y < kReach + 4 || p.x > img.cols - kReach - 5 || p.y > img.rows - kReach - 5) continue;
        // Against another hedge: not its outline (the labels are the left view's).
        if (view == 0 && labels.type() == CV_32S && !labels.empty()) {
          bool other = false;
          for (double s = 1; s <= kReach && !other; s += 1) {
            const cv::Point2d t = p + s * n;
            const int v = labels.at<int>(int(std::lround(t.y)), int(std::lround(t.x)));
            other = v != 0 && v != id;
          }
          if (other) continue;
        }
        // Where the hedge meets the ground, what lies just outside is the lawn at its foot: the
        // ray past the outline meets the ground within a radius of the tangent point.
        if (ground) {
          const cv::Point2d t = p + 4.0 * n;
          const cv::Vec3d dir = left_from_rect * cv::Vec3d((t.x - cx[view]) / f, (t.y - cy[view]) / f, 1);
          const cv::Vec3d origin = left_from_rect * o, gn((*ground)[0], (*ground)[1], (*ground)[2]);
          const double den = gn.dot(dir);
          if (std::abs(den) > 1e-12) {
            const double at = -(gn.dot(origin) + (*ground)[3]) / den;
            if (at > 0 && cv::norm(origin + at * dir - left_from_rect * q) < r) continue;
          }
        }
        double contrast = 0;
        const std::optional<double> edge = EdgeAlong(img, p, n, &contrast);
        if (!edge) continue;
        ++(view == 0 ? st.left : st.right);
        if (view == 0) contrasts.push_back(contrast);
        const cv::Point2d e = p + *edge * n;
        const cv::Vec3d d = cv::normalize(left_from_rect * cv::Vec3d((e.x - cx[view]) / f, (e.y - cy[view]) / f, 1));
        const cv::Vec3d origin = left_from_rect * o;
        cloud::TangentRay ray;
        ray.focal_px = f;
        ray.view = view;
        ray.origin_mm = Eigen::Vector3d(origin[0], origin[1], origin[2]);
        ray.direction = Eigen::Vector3d(d[0], d[1], d[2]);
        rays.push_back(ray);
      }
    }
    if (!contrasts.empty()) {
      std::nth_element(contrasts.begin(), contrasts.begin() + std::ptrdiff_t(contrasts.size() / 2), contrasts.end());
      st.contrast = contrasts[contrasts.size() / 2];
    }
    if (stats) (*stats)[id] = st;
    if (!rays.empty()) out[id] = std::move(rays);
  }
  return out;
}

}  // namespace hedgefit::stereo
