#include "sim/simulator.hpp"
#include "stereo/stereo_stages.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"

#include "pipeline/parallel.hpp"
#include "eval/truth_file.hpp"
namespace hedgefit::sim {

using stereo::StereoRig;
using stereo::WriteImageAtomic;
using stereo::WriteRig;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Undistorted ray directions (x, y, 1) for every sub-pixel of a camera, cached: the
// iterative undistortion is the expensive part and the same rig renders many scenes.
std::shared_ptr<const std::vector<cv::Point2f>> Rays(const SimCamera& cam, int ss) {
  static std::mutex mutex;
  static std::map<std::vector<double>, std::shared_ptr<const std::vector<cv::Point2f>>> cache;
  std::vector<double> key = {double(cam.size.width), double(cam.size.height), double(ss)};
  for (int i = 0; i < 9; ++i) key.push_back(cam.K.val[i]);
  for (int i = 0; i < 5; ++i) key.push_back(cam.dist[i]);
  std::lock_guard<std::mutex> lock(mutex);
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  // Exact undistortion on a grid every kStep px, bilinear in between: the distortion
  // field is smooth, so the interpolated rays are within ~1e-4 px of exact ones, at a
  // small fraction of the cost of undistorting every sub-pixel.
  constexpr int kStep = 4;
  const int gw = (cam.size.width + kStep - 1) / kStep + 2, gh = (cam.size.height + kStep - 1) / kStep + 2;
  std::vector<cv::Point2f> grid_px, grid_rays;
  for (int j = 0; j < gh; ++j) {
    for (int i = 0; i < gw; ++i) grid_px.emplace_back(float(i * kStep - 1), float(j * kStep - 1));
  }
  cv::undistortPoints(grid_px, grid_rays, cv::Mat(cam.K), cv::Mat(cam.dist), cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-12));
  auto rays = std::make_shared<std::vector<cv::Point2f>>(std::size_t(cam.size.area()) * ss * ss);
  std::size_t k = 0;
  for (int v = 0; v < cam.size.height; ++v) {
    for (int sy = 0; sy < ss; ++sy) {
      const double y = v - 0.5 + (sy + 0.5) / ss;
      const double gy = (y + 1) / kStep;
      const int j = std::min(gh - 2, static_cast<int>(gy));
      const double fy = gy - j;
      for (int u = 0; u < cam.size.width; ++u) {
        for (int sx = 0; sx < ss; ++sx) {
          // Sub-pixel centres; pixel (u, v) covers [u - 0.5, u + 0.5] as in OpenCV.
          const double x = u - 0.5 + (sx + 0.5) / ss;
          const double gx = (x + 1) / kStep;
          const int i = std::min(gw - 2, static_cast<int>(gx));
          const double fx = gx - i;
          const cv::Point2f& a00 = grid_rays[std::size_t(j * gw + i)];
          const cv::Point2f& a10 = grid_rays[std::size_t(j * gw + i + 1)];
          const cv::Point2f& a01 = grid_rays[std::size_t((j + 1) * gw + i)];
          const cv::Point2f& a11 = grid_rays[std::size_t((j + 1) * gw + i + 1)];
          (*rays)[k++] = cv::Point2f(
              float((1 - fy) * ((1 - fx) * a00.x + fx * a10.x) + fy * ((1 - fx) * a01.x + fx * a11.x)),
              float((1 - fy) * ((1 - fx) * a00.y + fx * a10.y) + fy * ((1 - fx) * a01.y + fx * a11.y)));
        }
      }
    }
  }
  cache[key] = rays;
  return rays;
}

// Smooth 3-D value noise in [0, 1]: the same texture wherever a surface point is seen from.
double Hash(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t seed) {
  std::uint64_t h = seed * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<std::uint64_t>(x) * 0xC2B2AE3D27D4EB4Full;
  h = (h ^ (h >> 29)) * 0xBF58476D1CE4E5B9ull;
  h ^= static_cast<std::uint64_t>(y) * 0x165667B19E3779F9ull;
  h = (h ^ (h >> 32)) * 0x94D049BB133111EBull;
  h ^= static_cast<std::uint64_t>(z) * 0x27D4EB2F165667C5ull;
  h ^= h >> 31;
  return double(h >> 11) * (1.0 / 9007199254740992.0);
}

double ValueNoise(const cv::Vec3d& p, std::uint64_t seed) {
  const double fx = std::floor(p[0]), fy = std::floor(p[1]), fz = std::floor(p[2]);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy), iz = static_cast<std::int64_t>(fz);
  auto smooth = [](double t) { return t * t * (3 - 2 * t); };
  const double tx = smooth(p[0] - fx), ty = smooth(p[1] - fy), tz = smooth(p[2] - fz);
  double v = 0;
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const double w = (dx ? tx : 1 - tx) * (dy ? ty : 1 - ty) * (dz ? tz : 1 - tz);
        v += w * Hash(ix + dx, iy + dy, iz + dz, seed);
      }
  return v;
}

double Fractal(const cv::Vec3d& p_mm, double scale_mm, int octaves, std::uint64_t seed) {
  double v = 0, amp = 0.5, total = 0, f = 1.0 / scale_mm;
  for (int o = 0; o < octaves; ++o) {
    v += amp * ValueNoise(p_mm * f, seed + std::uint64_t(o));
    total += amp;
    amp *= 0.5;
    f *= 2.3;
  }
  return v / total;
}

struct CameraPose {
  cv::Vec3d origin;  // camera centre in the world
  cv::Matx33d world_from_camera;
};

CameraPose Pose(const SimRig& rig, bool right) {
  if (!right) return {cv::Vec3d(0, 0, 0), cv::Matx33d::eye()};
  return {-(rig.R.t() * rig.T), rig.R.t()};
}

// Renders with `shade(origin, direction)` returning BGR in [0, 255] (or a label in [0]).
template <class Shade>
cv::Mat Render(const SimRig& rig, bool right, const RenderOptions& options, Shade shade) {
  const SimCamera& cam = right ? rig.right : rig.left;
  const int ss = options.labels ? 1 : std::max(1, options.supersample);
  const auto rays = Rays(cam, ss);
  const CameraPose pose = Pose(rig, right);
  cv::Mat out(cam.size, options.labels ? CV_8UC1 : CV_8UC3);
  const int h = cam.size.height, w = cam.size.width;
  auto rows = [&](int r0, int r1) {
    for (int v = r0; v < r1; ++v) {
      for (int u = 0; u < w; ++u) {
        cv::Vec3d acc(0, 0, 0);
        for (int sy = 0; sy < ss; ++sy) {
          for (int sx = 0; sx < ss; ++sx) {
            const cv::Point2f& r = (*rays)[((std::size_t(v) * ss + sy) * w + u) * ss + sx];
            const cv::Vec3d d = pose.world_from_camera * cv::Vec3d(r.x, r.y, 1.0);
            acc += shade(pose.origin, d);
          }
        }
        acc *= 1.0 / (ss * ss);
        if (options.labels) {
          out.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(acc[0]);
        } else {
          out.at<cv::Vec3b>(v, u) = cv::Vec3b(cv::saturate_cast<std::uint8_t>(acc[0]),
                                              cv::saturate_cast<std::uint8_t>(acc[1]),
                                              cv::saturate_cast<std::uint8_t>(acc[2]));
        }
      }
    }
  };
  pipeline::ParallelFor(std::size_t(h), 0, 16, [&](std::size_t v0, std::size_t v1) { rows(int(v0), int(v1)); });
  if (!options.labels) {
    if (options.blur_sigma_px > 0) cv::GaussianBlur(out, out, cv::Size(0, 0), options.blur_sigma_px);
    if (options.noise_sigma > 0) {
      cv::Mat noise(out.size(), CV_32FC3);
      // Each camera has its own sensor: independent noise fields in the two views.
      cv::RNG rng(options.seed * 2 + (right ? 1 : 0));
      rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma);
      cv::Mat f;
      out.convertTo(f, CV_32FC3);
      f += noise;
      f.convertTo(out, CV_8UC3);
    }
  }
  return out;
}

}  // namespace

SimRig PaperRig(double scale) {
  SimRig rig;
  const cv::Size size(static_cast<int>(std::lround(1920 * scale)), static_cast<int>(std::lround(1200 * scale)));
  const double f = 933.3 * scale;
  for (SimCamera* c : {&rig.left, &rig.right}) {
    c->size = size;
    c->K = cv::Matx33d(f, 0, (size.width - 1) / 2.0, 0, f, (size.height - 1) / 2.0, 0, 0, 1);
    c->dist = cv::Vec<double, 5>(-0.05, 0.01, 0, 0, 0);  // mild barrel distortion
  }
  rig.right.K(0, 2) += 3 * scale;  // the two cameras are not identical
  rig.right.dist[0] = -0.045;
  // About 1 degree between the cameras, as the paper's calibration found.
  cv::Matx31d rvec(0.003, -0.015, 0.004);
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  rig.R = R;
  rig.T = cv::Vec3d(-140, 0.3, 1.5);
  return rig;
}

std::vector<cv::Point3d> BoardInnerCornersWorld(const BoardScene& b) {
  std::vector<cv::Point3d> out;
  for (int r = 0; r < b.squares.height - 1; ++r) {
    for (int c = 0; c < b.squares.width - 1; ++c) {
      const cv::Vec3d p = b.rotation * cv::Vec3d(c * b.square_mm, r * b.square_mm, 0) + b.translation;
      out.emplace_back(p[0], p[1], p[2]);
    }
  }
  return out;
}

cv::Mat RenderBoard(const SimRig& rig, bool right, const BoardScene& b, const RenderOptions& options) {
  const cv::Vec3d n = b.rotation * cv::Vec3d(0, 0, 1);
  const double s = b.square_mm;
  const double x_lo = -s - b.margin_mm, x_hi = (b.squares.width - 1) * s + b.margin_mm;
  const double y_lo = -s - b.margin_mm, y_hi = (b.squares.height - 1) * s + b.margin_mm;
  // Each sub-pixel ray stands for a cone 1 / (f ss) rad wide. The squares are box-filtered
  // over that footprint analytically: point-sampled squares would put every edge on a
  // 1/ss-px grid, and that quantisation alone biases detected corners by ~0.06 px rms.
  // The footprint is the bounding box, in board coordinates, of the parallelogram that
  // one sub-pixel step along the image's x and y sweeps on the (tilted) board.
  const SimCamera& cam = right ? rig.right : rig.left;
  const double step = 1.0 / (cam.K(0, 0) * std::max(1, options.labels ? 1 : options.supersample));
  const cv::Matx33d world_from_camera = right ? rig.R.t() : cv::Matx33d::eye();
  const cv::Vec3d step_x = world_from_camera * cv::Vec3d(step, 0, 0), step_y = world_from_camera * cv::Vec3d(0, step, 0);
  // Integral of the square wave that is +1 on [0, s) and -1 on [s, 2s): a triangle wave.
  auto tri = [s](double x) {
    const double m = x - 2 * s * std::floor(x / (2 * s));
    return s - std::abs(m - s);
  };
  auto filtered_square = [&](double x, double w) {
    if (w < 1e-9) return x - 2 * s * std::floor(x / (2 * s)) < s ? 1.0 : -1.0;
    return (tri(x + w / 2) - tri(x - w / 2)) / w;
  };
  return Render(rig, right, options, [&](const cv::Vec3d& o, const cv::Vec3d& d) -> cv::Vec3d {
    const double denom = n.dot(d);
    if (std::abs(denom) > 1e-12) {
      const double t = n.dot(b.translation - o) / denom;
      if (t > 0) {
        const cv::Vec3d q = b.rotation.t() * (o + t * d - b.translation);
        if (q[0] >= x_lo && q[0] <= x_hi && q[1] >= y_lo && q[1] <= y_hi) {
          if (options.labels) return cv::Vec3d(kLabelBoard, 0, 0);
          const bool inside = q[0] >= -s && q[0] < (b.squares.width - 1) * s && q[1] >= -s &&
                              q[1] < (b.squares.height - 1) * s;
          if (!inside) return cv::Vec3d(235, 235, 235);
          if (!b.texture.empty()) {
            // The texture spans the squares: x in [-s, (w - 1) s) -> [0, cols).
            const double u = (q[0] + s) / (b.squares.width * s) * b.texture.cols - 0.5;
            const double v = (q[1] + s) / (b.squares.height * s) * b.texture.rows - 0.5;
            const int u0 = std::clamp(int(std::floor(u)), 0, b.texture.cols - 2);
            const int v0 = std::clamp(int(std::floor(v)), 0, b.texture.rows - 2);
            const double fu = std::clamp(u - u0, 0.0, 1.0), fv = std::clamp(v - v0, 0.0, 1.0);
            auto at = [&](int y, int x) { return double(b.texture.at<uchar>(y, x)); };
            const double tex = (1 - fv) * ((1 - fu) * at(v0, u0) + fu * at(v0, u0 + 1)) +
                             fv * ((1 - fu) * at(v0 + 1, u0) + fu * at(v0 + 1, u0 + 1));
            const double g = 20 + (235 - 20) * tex / 255.0;
            return cv::Vec3d(g, g, g);
          }
          // Square (ix, iy), ix = floor(q0 / s) + 1, is dark when ix + iy is even, i.e.
          // when the square waves of q0 + s and q1 + s have the same sign.
          // d(hit)/d(ray) for the plane n.(o + t d - c) = 0: t (delta - d (n.delta) / (n.d)).
          const cv::Vec3d fx = b.rotation.t() * (t * (step_x - d * (n.dot(step_x) / denom)));
          const cv::Vec3d fy = b.rotation.t() * (t * (step_y - d * (n.dot(step_y) / denom)));
          const double wx = std::abs(fx[0]) + std::abs(fy[0]), wy = std::abs(fx[1]) + std::abs(fy[1]);
          const double v = filtered_square(q[0] + s, wx) * filtered_square(q[1] + s, wy);
          const double g = 127.5 - 107.5 * v;  // +1 -> 20 (dark), -1 -> 235 (light)
          return cv::Vec3d(g, g, g);
        }
      }
    }
    return options.labels ? cv::Vec3d(kLabelNone, 0, 0) : cv::Vec3d(110, 105, 100);
  });
}

cv::Mat RenderSphere(const SimRig& rig, bool right, const SphereScene& sc, const RenderOptions& options) {
  const double ground_y = sc.ground_y != 0 ? sc.ground_y : sc.center[1] + sc.radius;
  const double wall_z = sc.wall_z != 0 ? sc.wall_z : sc.center[2] + 2000;
  const cv::Vec3d light = cv::normalize(cv::Vec3d(-0.4, -0.7, -0.6));  // from above, front-left
  return Render(rig, right, options, [&](const cv::Vec3d& o, const cv::Vec3d& d) -> cv::Vec3d {
    double best = 1e18;
    int what = kLabelNone;
    // Sphere: |o + t d - c|^2 = r^2, nearest positive root.
    const cv::Vec3d oc = o - sc.center;
    const double a = d.dot(d), bq = 2 * oc.dot(d), cq = oc.dot(oc) - sc.radius * sc.radius;
    const double disc = bq * bq - 4 * a * cq;
    if (disc >= 0) {
      const double t = (-bq - std::sqrt(disc)) / (2 * a);
      if (t > 0) {
        best = t;
        what = kLabelSphere;
      }
    }
    if (d[1] > 1e-12) {
      const double t = (ground_y - o[1]) / d[1];
      if (t > 0 && t < best) {
        best = t;
        what = kLabelGround;
      }
    }
    if (d[2] > 1e-12) {
      const double t = (wall_z - o[2]) / d[2];
      if (t > 0 && t < best) {
        best = t;
        what = kLabelWall;
      }
    }
    if (options.labels) return cv::Vec3d(what, 0, 0);
    const cv::Vec3d p = o + best * d;
    switch (what) {
      case kLabelSphere: {
        const cv::Vec3d nrm = (p - sc.center) * (1.0 / sc.radius);
        const double lambert = 0.35 + 0.65 * std::max(0.0, nrm.dot(-light));
        const double leaf = Fractal(p, 35.0, 4, sc.texture_seed);
        const double gap = leaf < 0.35 ? 0.35 : 1.0;  // dark gaps between leaves
        const double k = lambert * gap * (0.55 + 0.9 * leaf);
        return cv::Vec3d(45 * k, 150 * k + 40 * Fractal(p, 9.0, 2, sc.texture_seed + 9), 60 * k);
      }
      case kLabelGround: {
        const double g = Fractal(p, 60.0, 4, sc.texture_seed + 20);
        return cv::Vec3d(70 + 60 * g, 95 + 70 * g, 110 + 80 * g);
      }
      case kLabelWall: {
        const double g = Fractal(p, 90.0, 4, sc.texture_seed + 40);
        return cv::Vec3d(150 + 70 * g, 140 + 60 * g, 120 + 50 * g);
      }
      default: return cv::Vec3d(200, 180, 160);
    }
  });
}


namespace {

// The garden is built in a level frame (x right, y down along gravity, z forward); the camera
// stands at (view_x, 0, view_z) turned by its heading about y, and is pitched down about its x.
struct GardenFrame {
  cv::Matx33d level_from_camera;   // the camera's own level frame (pitch only)
  cv::Matx33d garden_from_camera;  // heading and pitch
  cv::Vec3d camera_in_garden;      // the left camera's centre in the garden's level frame
  explicit GardenFrame(const GardenScene& sc) {
    const double p = sc.pitch_deg * kPi / 180, c = std::cos(p), s = std::sin(p);
    // Camera z (forward) points down by p: (0, sin p, cos p) in the level frame.
    level_from_camera = cv::Matx33d(1, 0, 0, 0, c, s, 0, -s, c);
    const double h = sc.view_heading_deg * kPi / 180, ch = std::cos(h), sh = std::sin(h);
    const cv::Matx33d turn(ch, 0, sh, 0, 1, 0, -sh, 0, ch);  // +z towards +x
    garden_from_camera = turn * level_from_camera;
    camera_in_garden = cv::Vec3d(sc.view_x_mm, 0, sc.view_z_mm);
  }
};

cv::Vec3d LevelCenter(const GardenScene& sc, const GardenHedge& h) {
  // Sits on the lawn, sunk into the grass (5 % of its radius by default; a dome deeper).
  return cv::Vec3d(h.x_mm, sc.camera_height_mm - (1 - h.sink_share) * h.radius_mm, h.z_mm);
}

// Radial leaf depth below the envelope at point p (level frame), in [0, 1] of the shell: for the
// default leaves about a quarter of the surface reaches the envelope, a few per cent are deep
// gaps. The relief's scale follows the leaf size (28 mm for 16 mm leaves); a larger clipped share
// brings more of the surface to the envelope, fewer layers spread the rest deeper.
double LeafDepthFraction(const cv::Vec3d& p, std::uint64_t seed, const LeafShape& leaf) {
  const double n = Fractal(p, 28.0 * leaf.size_mm / 16, 3, seed);
  const double lo = 0.40 - 0.3 * (leaf.clipped_share - 1.0 / 3), width = 0.28 * 3.5 / leaf.layers;
  return std::clamp((n - lo) / width, 0.0, 1.0);
}

// Nearest positive root of |o + t d - c| = r, or -1.
double HitSphere(const cv::Vec3d& o, const cv::Vec3d& d, const cv::Vec3d& c, double r, double* t_far = nullptr) {
  const cv::Vec3d oc = o - c;
  const double a = d.dot(d), b = 2 * oc.dot(d), q = oc.dot(oc) - r * r;
  const double disc = b * b - 4 * a * q;
  if (disc < 0) return -1;
  const double sq = std::sqrt(disc);
  if (t_far) *t_far = (-b + sq) / (2 * a);
  const double t0 = (-b - sq) / (2 * a), t1 = (-b + sq) / (2 * a);
  return t0 > 0 ? t0 : (t1 > 0 ? t1 : -1);
}

// A vertical cylinder (axis along y) from y_top to y_bottom: nearest positive hit, or -1.
double HitCylinder(const cv::Vec3d& o, const cv::Vec3d& d, double cx, double cz, double r, double y_top,
                   double y_bottom) {
  const double ox = o[0] - cx, oz = o[2] - cz;
  const double a = d[0] * d[0] + d[2] * d[2], b = 2 * (ox * d[0] + oz * d[2]), q = ox * ox + oz * oz - r * r;
  if (a < 1e-12) return -1;
  const double disc = b * b - 4 * a * q;
  if (disc < 0) return -1;
  for (double t : {(-b - std::sqrt(disc)) / (2 * a), (-b + std::sqrt(disc)) / (2 * a)}) {
    const double y = o[1] + t * d[1];
    if (t > 0 && y >= y_top && y <= y_bottom) return t;
  }
  return -1;
}

// Sphere tracing through a leafy shell: the first point where |p - c| <= R - L * depth(p).
// The default leaves' noise has a gradient below ~3.5 / L per mm of the shell, so steps of
// g / 3.5 never skip a leaf (finer relief or a steeper ramp: smaller steps). Returns -1 for a ray
// that passes through gaps only.
double HitLeafyBall(const cv::Vec3d& o, const cv::Vec3d& d, const cv::Vec3d& c, const GardenHedge& g_ball,
                    std::uint64_t seed, double* depth_fraction) {
  const double R = g_ball.radius_mm, L = g_ball.leaf_depth_mm;
  const LeafShape& leaf = g_ball.leaf;
  const double steepness = 3.5 * std::max(1.0, 16 / leaf.size_mm) * std::max(1.0, leaf.layers / 3.5);
  double t_far = 0;
  double t = HitSphere(o, d, c, R, &t_far);
  if (t < 0) return -1;
  for (int i = 0; i < 1200 && t <= t_far; ++i) {
    const cv::Vec3d p = o + t * d;
    const double s = LeafDepthFraction(p, seed, leaf);
    const double g = cv::norm(p - c) - (R - L * s);
    if (g <= 0.05) {
      *depth_fraction = s;
      return t;
    }
    t += std::max(0.3, g / steepness);
  }
  return -1;
}

struct GardenHit {
  double t = 1e18;
  int what = kLabelNone;  // kLabelHedge + i, kLabelGround, kLabelWall, kLabelNone = sky
  int kind = 0;           // 0 sky, 1 hedge, 2 lawn, 3 pot, 4 hedge row, 5 fence, 6 crown, 7 trunk, 8 shrub
  double leaf = 0;        // hedges: depth fraction
  cv::Vec3d centre;       // hedges and crowns
  double leaf_scale = 1;  // hedges: leaf size over the default's (the texture's scale)
};

struct Tree {
  double x, z, crown_r, trunk_r, crown_height;
};
const Tree kTrees[] = {{-2600, 8600, 1600, 160, 3300}, {3200, 9800, 1900, 190, 3700}};
constexpr double kRowFront = 5200, kRowBack = 6000, kRowHeight = 1500, kFenceZ = 6600, kFenceHeight = 1900;
constexpr double kPotRadius = 180, kPotHeight = 380;

GardenHit TraceGarden(const GardenScene& sc, const cv::Vec3d& o, const cv::Vec3d& d, bool shadow_ray) {
  GardenHit h;
  const double ground = sc.camera_height_mm;
  // Leafy balls: the hedges, and the lobes of other shrubs (kind 8, not hedges).
  auto trace_balls = [&](const std::vector<GardenHedge>& balls, std::uint64_t seed, bool hedges) {
    for (std::size_t i = 0; i < balls.size(); ++i) {
      const GardenHedge& g = balls[i];
      const cv::Vec3d c = LevelCenter(sc, g);
      double t, leaf = 0;
      // Shadow rays test the half-depth sphere only: the sun's shadow edge is not worth the cost.
      if (shadow_ray) t = HitSphere(o, d, c, g.radius_mm - g.leaf_depth_mm / 2);
      else t = HitLeafyBall(o, d, c, g, seed + i, &leaf);
      if (t > 0 && t < h.t) {
        h = GardenHit{t, hedges ? kLabelHedge + int(i) : int(kLabelWall), hedges ? 1 : 8, leaf, c, g.leaf.size_mm / 16};
      }
      if (const auto bulge = GardenBulge(g, c)) {  // the same leaves, the hedge's label
        GardenHedge b = g;
        b.radius_mm = bulge->second;
        if (shadow_ray) t = HitSphere(o, d, bulge->first, b.radius_mm - b.leaf_depth_mm / 2);
        else t = HitLeafyBall(o, d, bulge->first, b, seed + i, &leaf);
        if (t > 0 && t < h.t) {
          h = GardenHit{t, hedges ? kLabelHedge + int(i) : int(kLabelWall), hedges ? 1 : 8, leaf, bulge->first,
                        g.leaf.size_mm / 16};
        }
      }
    }
  };
  trace_balls(sc.hedges, sc.texture_seed + 100, true);
  trace_balls(sc.shrub_lobes, sc.texture_seed + 300, false);
  if (sc.pot) {
    const double t = HitCylinder(o, d, sc.pot_x_mm, sc.pot_z_mm, kPotRadius, ground - kPotHeight, ground);
    if (t > 0 && t < h.t) h = GardenHit{t, kLabelWall, 3, 0, {}};
  }
  if (sc.background) {
    if (d[2] > 1e-9) {
      const double t = (kRowFront - o[2]) / d[2];
      const cv::Vec3d p = o + t * d;
      if (t > 0 && t < h.t && p[1] >= ground - kRowHeight && p[1] <= ground) h = GardenHit{t, kLabelWall, 4, 0, {}};
      const double tf = (kFenceZ - o[2]) / d[2];
      const cv::Vec3d pf = o + tf * d;
      if (tf > 0 && tf < h.t && pf[1] >= ground - kFenceHeight && pf[1] <= ground) h = GardenHit{tf, kLabelWall, 5, 0, {}};
    }
    if (d[1] < -1e-9) {  // the hedge row's top
      const double t = (ground - kRowHeight - o[1]) / d[1];
      const cv::Vec3d p = o + t * d;
      if (t > 0 && t < h.t && p[2] >= kRowFront && p[2] <= kRowBack) h = GardenHit{t, kLabelWall, 4, 0, {}};
    }
    for (const Tree& tr : kTrees) {
      const cv::Vec3d c(tr.x, ground - tr.crown_height, tr.z);
      const double t = HitSphere(o, d, c, tr.crown_r);
      if (t > 0 && t < h.t) h = GardenHit{t, kLabelWall, 6, 0, c};
      const double tt = HitCylinder(o, d, tr.x, tr.z, tr.trunk_r, ground - tr.crown_height, ground);
      if (tt > 0 && tt < h.t) h = GardenHit{tt, kLabelWall, 7, 0, {}};
    }
  }
  if (d[1] > 1e-9) {
    const double t = (ground - o[1]) / d[1];
    if (t > 0 && t < h.t) h = GardenHit{t, kLabelGround, 2, 0, {}};
  }
  return h;
}

}  // namespace

cv::Vec3d GardenLevelCenter(const GardenScene& sc, const GardenHedge& ball) { return LevelCenter(sc, ball); }

std::optional<std::pair<cv::Vec3d, double>> GardenBulge(const GardenHedge& g, const cv::Vec3d& c) {
  if (!(g.bulge_mm > 0) || !(g.bulge_radius_mm > 0)) return std::nullopt;
  const double h = g.bulge_heading_deg * kPi / 180;
  const cv::Vec3d u(std::sin(h), 0, std::cos(h));
  return std::make_pair(c + (g.radius_mm + g.bulge_mm - g.bulge_radius_mm) * u, g.bulge_radius_mm);
}

cv::Vec3d GardenHedgeCenter(const GardenScene& sc, std::size_t i) {
  if (i >= sc.hedges.size()) throw Error("garden: no hedge " + std::to_string(i));
  const GardenFrame f(sc);
  return f.garden_from_camera.t() * (LevelCenter(sc, sc.hedges[i]) - f.camera_in_garden);
}

cv::Matx33d GardenLevelFromCamera(const GardenScene& sc) { return GardenFrame(sc).level_from_camera; }

cv::Matx44d GardenLevelFromCameraPose(const GardenScene& sc) {
  const GardenFrame f(sc);
  cv::Matx44d m = cv::Matx44d::eye();
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) m(r, k) = f.garden_from_camera(r, k);
    m(r, 3) = f.camera_in_garden[r];
  }
  return m;
}

double GardenHedgeSurfaceRadius(const GardenScene& sc, std::size_t i) {
  if (i >= sc.hedges.size()) throw Error("garden: no hedge " + std::to_string(i));
  const GardenHedge& g = sc.hedges[i];
  const cv::Vec3d c = LevelCenter(sc, g);
  // Fibonacci sphere: even coverage, deterministic.
  const int n = 20000;
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    const double z = 1 - (2.0 * k + 1) / n, r = std::sqrt(1 - z * z), phi = k * kPi * (3 - std::sqrt(5.0));
    const cv::Vec3d u(r * std::cos(phi), z, r * std::sin(phi));
    sum += g.radius_mm - g.leaf_depth_mm * LeafDepthFraction(c + g.radius_mm * u, sc.texture_seed + 100 + i, g.leaf);
  }
  return sum / n;
}

cv::Mat RenderGarden(const SimRig& rig, bool right, const GardenScene& sc, const RenderOptions& options) {
  const GardenFrame frame(sc);
  const cv::Vec3d sun = cv::normalize(cv::Vec3d(-0.55, -0.62, -0.35));  // towards the sun: high, left, behind
  const std::uint64_t seed = sc.texture_seed;
  return Render(rig, right, options, [&](const cv::Vec3d& o_cam, const cv::Vec3d& d_cam) -> cv::Vec3d {
    const cv::Vec3d o = frame.garden_from_camera * o_cam + frame.camera_in_garden, d = frame.garden_from_camera * d_cam;
    const GardenHit h = TraceGarden(sc, o, d, false);
    if (options.labels) return cv::Vec3d(h.what, 0, 0);
    if (h.kind == 0) {  // sky: brighter towards the horizon
      const double up = std::clamp(-d[1] / cv::norm(d), 0.0, 1.0);
      return cv::Vec3d(235 - 20 * up, 205 - 40 * up, 185 - 70 * up);
    }
    const cv::Vec3d p = o + h.t * d;
    auto lit = [&](const cv::Vec3d& normal) {
      // Overcast: light from the whole sky, the more of it a surface faces; no shadows.
      if (sc.overcast) return 0.55 + 0.35 * std::max(0.0, -normal[1]);
      const double direct = std::max(0.0, normal.dot(sun));
      const bool shadowed = direct > 0 && TraceGarden(sc, p + 2.0 * normal, sun, true).kind != 0;
      return 0.32 + (shadowed ? 0.0 : 0.78 * direct);
    };
    switch (h.kind) {
      case 1:
      case 8: {  // leaves: darker deeper in the shell; a shrub's bluer and larger
        const cv::Vec3d nrm = cv::normalize(p - h.centre);
        const double scale = h.kind == 8 ? 1.6 : h.leaf_scale;
        const double leaf = Fractal(p, 9.0 * scale, 3, seed + 7), vein = Fractal(p, 3.5 * scale, 2, seed + 8);
        const double k = lit(nrm) * (1.0 - 0.6 * h.leaf) * (0.55 + 0.8 * leaf);
        if (h.kind == 8) return cv::Vec3d((55 + 25 * vein) * k, (115 + 50 * vein) * k, (45 + 25 * vein) * k);
        return cv::Vec3d((30 + 25 * vein) * k, (120 + 60 * vein) * k, (55 + 30 * vein) * k);
      }
      case 2: {  // mown lawn: fine blades, mowing stripes
        const double blade = Fractal(p, 6.0, 3, seed + 20), patch = Fractal(p, 400.0, 2, seed + 21);
        const double stripe = std::fmod(std::abs(p[0]) + 10000, 1000.0) < 500 ? 1.0 : 0.88;
        const double k = lit(cv::Vec3d(0, -1, 0)) * stripe * (0.6 + 0.7 * blade);
        return cv::Vec3d((45 + 20 * patch) * k, (135 + 40 * patch) * k, (85 + 40 * patch) * k);
      }
      case 3: {  // terracotta pot
        const cv::Vec3d nrm = cv::normalize(cv::Vec3d(p[0] - sc.pot_x_mm, 0, p[2] - sc.pot_z_mm));
        const double k = lit(nrm) * (0.8 + 0.4 * Fractal(p, 15.0, 3, seed + 30));
        return cv::Vec3d(60 * k, 95 * k, 175 * k);
      }
      case 4: {  // clipped hedge row: green on green
        const double k = lit(cv::Vec3d(0, 0, -1)) * (0.5 + 0.9 * Fractal(p, 20.0, 4, seed + 40));
        return cv::Vec3d(35 * k, 125 * k, 60 * k);
      }
      case 5: {  // wooden fence: planks
        const double plank = std::fmod(std::abs(p[0]) + 100000, 150.0) < 8 ? 0.4 : 1.0;
        const double k = lit(cv::Vec3d(0, 0, -1)) * plank * (0.75 + 0.5 * Fractal(cv::Vec3d(p[0] * 4, p[1] * 0.3, 0), 40.0, 3, seed + 50));
        return cv::Vec3d(70 * k, 110 * k, 150 * k);
      }
      case 6: {  // tree crowns
        const double k = lit(cv::normalize(p - h.centre)) * (0.45 + 0.9 * Fractal(p, 60.0, 4, seed + 60));
        return cv::Vec3d(40 * k, 130 * k, 85 * k);
      }
      default: {  // trunks
        const double k = 0.5 + 0.6 * Fractal(p, 25.0, 3, seed + 70);
        return cv::Vec3d(45 * k, 65 * k, 85 * k);
      }
    }
  });
}

cv::Mat RenderGardenSurface(const SimRig& rig, const GardenScene& sc) {
  const GardenFrame frame(sc);
  const SimCamera& cam = rig.left;
  const auto rays = Rays(cam, 1);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat out(cam.size, CV_32FC3, cv::Scalar(nan, nan, nan));
  const cv::Matx33d camera_from_level = frame.garden_from_camera.t();
  pipeline::ParallelFor(std::size_t(cam.size.height), 0, 16, [&](std::size_t v0, std::size_t v1) {
    for (int v = int(v0); v < int(v1); ++v) {
      for (int u = 0; u < cam.size.width; ++u) {
        const cv::Point2f& r = (*rays)[std::size_t(v) * cam.size.width + u];
        const cv::Vec3d d = frame.garden_from_camera * cv::Vec3d(r.x, r.y, 1.0);
        const GardenHit h = TraceGarden(sc, frame.camera_in_garden, d, false);
        if (h.kind == 0) continue;
        const cv::Vec3d p = camera_from_level * (h.t * d);
        out.at<cv::Vec3f>(v, u) = cv::Vec3f(float(p[0]), float(p[1]), float(p[2]));
      }
    }
  });
  return out;
}

std::vector<std::string> GardenPresetNames() { return {"row", "single", "outdoor"}; }

std::vector<std::string> GardenHardPresetNames() {
  return {"pair", "low_camera", "high_camera", "small_far", "big_near", "off_centre", "touching", "left_edge",
          "cut_by_frame", "shrubs"};
}

std::vector<std::string> GardenLeafPresetNames() {
  return {"boxwood", "boxwood_dome", "yew", "yew_dome", "privet", "privet_dome", "holly", "holly_dome"};
}

namespace {

// A ball of the default leaves: position on the lawn, envelope radius and shell depth (mm).
GardenHedge Ball(double x_mm, double z_mm, double radius_mm, double leaf_depth_mm) {
  GardenHedge h;
  h.x_mm = x_mm, h.z_mm = z_mm, h.radius_mm = radius_mm, h.leaf_depth_mm = leaf_depth_mm;
  return h;
}

// The leaves and shell of a leaf preset's hedges (GardenLeafPresetNames), or nullopt.
std::optional<GardenHedge> LeafPresetHedge(const std::string& species) {
  GardenHedge h;
  if (species == "boxwood") {  // small, flat, dense, freshly clipped
    h.leaf = {14, 0.65, 0.0, 3.5, 0.45};
    h.leaf_depth_mm = 20;
  } else if (species == "yew") {  // needles in a thick shell
    h.leaf = {20, 0.2, 0.0, 2.5, 0.35};
    h.leaf_depth_mm = 50;
  } else if (species == "privet") {  // mid-size, cupped
    h.leaf = {30, 0.45, 0.08, 3.0, 0.3};
    h.leaf_depth_mm = 45;
  } else if (species == "holly") {  // large, strongly cupped, gappy, a thick shell
    h.leaf = {55, 0.55, 0.2, 2.2, 0.25};
    h.leaf_depth_mm = 80;
  } else {
    return std::nullopt;
  }
  return h;
}

// "SPECIES" (sun: r 350 mm at 1.6 m, r 650 mm at 2.8 m) or "SPECIES_dome" (overcast: a dome of
// r 950 mm sunk 40 % into the lawn at 2.9 m, a ball of r 300 mm at 1.5 m), or nullopt.
std::optional<GardenScene> LeafGarden(const std::string& name) {
  const bool dome = name.size() > 5 && name.compare(name.size() - 5, 5, "_dome") == 0;
  const std::optional<GardenHedge> base = LeafPresetHedge(dome ? name.substr(0, name.size() - 5) : name);
  if (!base) return std::nullopt;
  GardenScene sc;
  sc.pot = false;
  const std::vector<std::string> names = GardenLeafPresetNames();
  sc.texture_seed = 200 + 7 * std::uint64_t(std::find(names.begin(), names.end(), name) - names.begin());
  auto ball = [&](double x, double z, double r, double sink) {
    GardenHedge h = *base;
    h.x_mm = x, h.z_mm = z, h.radius_mm = r, h.sink_share = sink;
    return h;
  };
  if (dome) {
    sc.overcast = true;
    sc.hedges = {ball(-1000, 1500, 300, 0.05), ball(500, 2900, 950, 0.4)};
  } else {
    sc.hedges = {ball(-750, 1600, 350, 0.05), ball(800, 2800, 650, 0.05)};
  }
  return sc;
}

// "random<seed>": one to three balls of the range (r 420-600 mm, centres 2.0-2.7 m away)
// side by side across the view, leaf layers 25-40 mm, the camera 0.9-1.4 m up and pitched 4-14
// degrees, and in two gardens of five a two-lobed shrub beside them; no pot (it could hide a
// ball). The same seed gives the same garden (a 64-bit Mersenne twister, mapped to [0, 1) by
// hand, so it does not depend on the library's distributions).
GardenScene RandomGarden(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto u = [&rng] { return double(rng() >> 11) * (1.0 / 9007199254740992.0); };
  GardenScene sc;
  sc.pot = false;
  sc.texture_seed = 1000 + seed;
  sc.camera_height_mm = 900 + 500 * u();
  sc.pitch_deg = 4 + 10 * u();
  const int balls = 1 + int(3 * u());
  double x = -1800 + 400 * u();  // the left edge of the next ball
  for (int i = 0; i < balls; ++i) {
    GardenHedge h;
    h.radius_mm = 420 + 180 * u();
    h.z_mm = 2000 + 700 * u();
    h.x_mm = x + h.radius_mm;
    h.leaf_depth_mm = 25 + 15 * u();
    if (h.x_mm + h.radius_mm > 2000 && !sc.hedges.empty()) break;  // out of the view
    sc.hedges.push_back(h);
    x += 2 * h.radius_mm + 150 + 500 * u();
  }
  if (u() < 0.4) {
    const double z = 2300 + 300 * u();
    sc.shrub_lobes = {Ball(x + 260, z, 260, 35), Ball(x + 540, z + 60, 240, 35)};
  }
  return sc;
}

// "paper<seed>": the paper's outdoor case drawn from a seed (sim::GardenPreset): one ball of r
// 880-960 mm with its centre 2.0-2.4 m away, so its nearest leaves are 1.1-1.5 m from the
// cameras, and in half the gardens a second one beside it, farther (2.4-3.0 m) and pushed back
// until it is inside the view. The leaves are one of the four leaf presets (seed mod 4: boxwood,
// yew, privet, holly), under sun or an overcast sky; the camera 0.9-1.4 m up, pitched 4-14
// degrees. The same seed gives the same garden (RandomGarden's generator).
GardenScene PaperGarden(std::uint64_t seed) {
  std::mt19937_64 rng(seed + 7919);
  auto u = [&rng] { return double(rng() >> 11) * (1.0 / 9007199254740992.0); };
  static const char* const species[] = {"boxwood", "yew", "privet", "holly"};
  const GardenHedge leafy = *LeafPresetHedge(species[seed % 4]);
  GardenScene sc;
  sc.pot = false;
  sc.texture_seed = 3000 + seed;
  sc.camera_height_mm = 900 + 500 * u();
  sc.pitch_deg = 4 + 10 * u();
  sc.overcast = u() < 0.4;
  GardenHedge a = leafy;
  a.radius_mm = 880 + 80 * u();
  a.z_mm = 2000 + 400 * u();
  a.x_mm = -1000 + 800 * u();
  sc.hedges.push_back(a);
  if (u() < 0.5) {
    GardenHedge b = leafy;
    b.radius_mm = 880 + 80 * u();
    b.x_mm = a.x_mm + a.radius_mm + 150 + 350 * u() + b.radius_mm;
    // Inside the view: the rig's half field is about 1.03 (960 / 933.3 px) of the distance.
    b.z_mm = std::max(2400 + 600 * u(), (b.x_mm + b.radius_mm + 150) / 1.03);
    sc.hedges.push_back(b);
  }
  return sc;
}

}  // namespace

GardenScene GardenPreset(const std::string& name) {
  if (name.size() > 6 && name.compare(0, 6, "random") == 0 && name.size() <= 15 &&
      std::all_of(name.begin() + 6, name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return RandomGarden(std::stoull(name.substr(6)));
  }
  if (name.size() > 5 && name.compare(0, 5, "paper") == 0 && name.size() <= 14 &&
      std::all_of(name.begin() + 5, name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return PaperGarden(std::stoull(name.substr(5)));
  }
  if (std::optional<GardenScene> leafy = LeafGarden(name)) return *leafy;
  GardenScene sc;
  if (name == "row") {
    sc.hedges = {Ball(-1350, 2300, 450, 30), Ball(80, 2500, 520, 30), Ball(1500, 2700, 600, 35)};
    sc.pot_x_mm = -550, sc.pot_z_mm = 1750;
  } else if (name == "single") {
    sc.hedges = {Ball(150, 2400, 520, 30)};
    sc.pot_x_mm = -1100, sc.pot_z_mm = 2200;
    sc.texture_seed = 23;
  } else if (name == "outdoor") {
    // The paper's outdoor hedges: r 880-960 mm, centres about 2 m away, so the front leaves are
    // about 1.1 m from the cameras.
    sc.hedges = {Ball(100, 2000, 920, 40)};
    sc.pot = false;
    sc.texture_seed = 31;
  } else if (name == "paper_pair") {
    // Two hedges of the paper's outdoor size side by side (r 900 and 940 mm, centres 2.3 and
    // 2.7 m away): the frame issue "One pass" times against the lab's (bench_capture --scenes paper).
    sc.hedges = {Ball(-1000, 2300, 900, 40), Ball(1140, 2700, 940, 40)};
    sc.pot = false;
    sc.texture_seed = 37;
  } else if (name == "pair") {
    // Two balls a hand's width apart in the image, the hedge row between them.
    sc.hedges = {Ball(-700, 2200, 450, 30), Ball(600, 2400, 500, 30)};
    sc.pot = false;
    sc.texture_seed = 61;
  } else if (name == "low_camera") {
    // A camera 0.8 m up, pitched 3 degrees: the lawn between the pot and the ball seen edge-on.
    sc.hedges = {Ball(0, 2300, 480, 30)};
    sc.camera_height_mm = 800;
    sc.pitch_deg = 3;
    sc.texture_seed = 53;
  } else if (name == "high_camera") {
    // 1.5 m up, pitched 15 degrees down: the ball against the lawn, the hedge row out of view.
    sc.hedges = {Ball(-100, 2500, 550, 30)};
    sc.camera_height_mm = 1500;
    sc.pitch_deg = 15;
    sc.pot = false;
    sc.texture_seed = 59;
  } else if (name == "small_far") {
    // The smallest, farthest ball the issue names (r 420 mm at 2.6 m), the pot nearer.
    sc.hedges = {Ball(-200, 2600, 420, 25)};
    sc.pot_x_mm = 700, sc.pot_z_mm = 2000;
    sc.texture_seed = 41;
  } else if (name == "big_near") {
    // The largest, nearest (r 600 mm at 2.0 m).
    sc.hedges = {Ball(250, 2000, 600, 35)};
    sc.pot_x_mm = -1000, sc.pot_z_mm = 1900;
    sc.texture_seed = 43;
  } else if (name == "off_centre") {
    // Towards the image's right edge, where distortion and vignetting are strongest.
    sc.hedges = {Ball(900, 2300, 500, 30)};
    sc.pot_x_mm = -400, sc.pot_z_mm = 2100;
    sc.texture_seed = 47;
  } else if (name == "touching") {
    // A planted row whose balls touch, the pot in front: no gap between them in the image, and
    // the lawn below where they meet lies in their shadow.
    sc.hedges = {Ball(-900, 2500, 450, 30), Ball(0, 2500, 450, 30), Ball(900, 2500, 450, 30)};
    sc.pot_x_mm = 1150, sc.pot_z_mm = 1850;
    sc.texture_seed = 67;
  } else if (name == "left_edge") {
    // Near the image's left edge, where SGBM's search leaves the right view.
    sc.hedges = {Ball(-1500, 2300, 500, 30)};
    sc.pot_x_mm = 400, sc.pot_z_mm = 2100;
    sc.texture_seed = 71;
  } else if (name == "cut_by_frame") {
    // Half out of the image on the right: the fit sees part of the ball.
    sc.hedges = {Ball(2250, 2400, 500, 30)};
    sc.pot_x_mm = -600, sc.pot_z_mm = 2000;
    sc.texture_seed = 73;
  } else if (name == "shrubs") {
    // Other shrubs, green and leafy but no balls: four lobes against the ball's right side, two
    // more apart on the left.
    sc.hedges = {Ball(-300, 2400, 500, 30)};
    sc.shrub_lobes = {Ball(420, 2350, 300, 40), Ball(700, 2500, 320, 40), Ball(560, 2450, 260, 40),
                      Ball(950, 2380, 250, 40), Ball(-1500, 2200, 280, 40), Ball(-1800, 2300, 240, 40)};
    sc.pot = false;
    sc.texture_seed = 91;
  } else {
    throw Error("garden preset '" + name + "': unknown; give one of row, single, outdoor, paper_pair, pair, low_camera, "
                "high_camera, small_far, big_near, off_centre, touching, left_edge, cut_by_frame, shrubs, boxwood, yew, privet, holly "
                "(each also NAME_dome), random<seed> (e.g. random7) or paper<seed> (e.g. paper3)");
  }
  return sc;
}

std::vector<std::string> StartSimulationDir(const std::string& dir, const SimRig& rig) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec)) throw Error(dir + ": cannot create the output directory");
  const std::string truth = (fs::path(dir) / "rig_truth.json").string(), yaml = (fs::path(dir) / "rig.yaml").string();
  cloud::WriteTextFileAtomic(truth, RigJson(rig) + "\n");
  WriteRig(yaml, RigFromSimulation(rig));
  return {truth, yaml};
}

std::vector<std::string> WriteGardenWith(const std::string& dir, const SimRig& rig,
                                         const std::vector<std::string>& presets,
                                         const std::function<cv::Mat(const GardenScene&, bool right)>& render,
                                         const std::function<double(const GardenScene&, std::size_t)>& surface) {
  namespace fs = std::filesystem;
  // No boards in a garden: the exact rig, so a garden run measures segmentation and matching.
  std::vector<std::string> written = StartSimulationDir(dir, rig);
  for (const std::string& name : presets) {
    const GardenScene sc = GardenPreset(name);
    for (bool right : {false, true}) {
      const std::string path = (fs::path(dir) / ("garden_" + name + (right ? "_right.png" : "_left.png"))).string();
      WriteImageAtomic(path, render(sc, right));
      written.push_back(path);
    }
    std::vector<eval::SphereTruth> truths;
    for (std::size_t i = 0; i < sc.hedges.size(); ++i) {
      eval::SphereTruth t;
      const cv::Vec3d c = GardenHedgeCenter(sc, i);
      t.center_mm = Eigen::Vector3d(c[0], c[1], c[2]);
      t.radius_mm = sc.hedges[i].radius_mm;
      t.surface_radius_mm = surface(sc, i);
      t.shell_mm = sc.hedges[i].leaf_depth_mm;
      truths.push_back(t);
    }
    const std::string truth = (fs::path(dir) / ("garden_" + name + ".truth.json")).string();
    eval::WriteSphereTruths(truth, truths);
    written.push_back(truth);
  }
  return written;
}

std::vector<std::string> WriteGarden(const std::string& dir, double scale, const RenderOptions& options,
                                     const std::vector<std::string>& presets) {
  const SimRig rig = PaperRig(scale);
  return WriteGardenWith(
      dir, rig, presets, [&](const GardenScene& sc, bool right) { return RenderGarden(rig, right, sc, options); },
      GardenHedgeSurfaceRadius);
}

StereoRig RigFromSimulation(const SimRig& sim) {
  StereoRig rig;
  rig.image_size = sim.left.size;
  rig.K1 = cv::Mat(sim.left.K).clone();
  rig.D1 = cv::Mat(sim.left.dist).t();
  rig.K2 = cv::Mat(sim.right.K).clone();
  rig.D2 = cv::Mat(sim.right.dist).t();
  rig.R = cv::Mat(sim.R).clone();
  rig.T = cv::Mat(sim.T).clone();
  rig.baseline_mm = cv::norm(rig.T);
  cv::stereoRectify(rig.K1, rig.D1, rig.K2, rig.D2, rig.image_size, rig.R, rig.T, rig.R1, rig.R2, rig.P1, rig.P2,
                    rig.Q, cv::CALIB_ZERO_DISPARITY, 0);
  return rig;
}

std::string RigJson(const SimRig& rig) {
  auto mat = [](const cv::Matx33d& m) {
    char buf[512];
    std::snprintf(buf, sizeof(buf), "[[%.10g, %.10g, %.10g], [%.10g, %.10g, %.10g], [%.10g, %.10g, %.10g]]", m(0, 0),
                  m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2));
    return std::string(buf);
  };
  auto cam = [&](const SimCamera& c) {
    char buf[256];
    std::snprintf(buf, sizeof(buf), "\"dist\": [%.10g, %.10g, %.10g, %.10g, %.10g]", c.dist[0], c.dist[1], c.dist[2],
                  c.dist[3], c.dist[4]);
    return "{\"K\": " + mat(c.K) + ", " + buf + "}";
  };
  char t[160];
  std::snprintf(t, sizeof(t), "[%.10g, %.10g, %.10g]", rig.T[0], rig.T[1], rig.T[2]);
  return "{\"image_size\": [" + std::to_string(rig.left.size.width) + ", " + std::to_string(rig.left.size.height) +
         "], \"left\": " + cam(rig.left) + ", \"right\": " + cam(rig.right) + ", \"R\": " + mat(rig.R) +
         ", \"T\": " + t + ", \"frame\": \"right_from_left, mm\"}";
}

void WriteSphereTruth(const std::string& path, const SphereScene& scene) {
  eval::SphereTruth t;
  t.center_mm = Eigen::Vector3d(scene.center[0], scene.center[1], scene.center[2]);
  t.radius_mm = scene.radius;
  eval::WriteSphereTruth(path, t);
}

void WriteBoardTruth(const std::string& path, const BoardScene& b) {
  nlohmann::json j;
  j["squares"] = {b.squares.width, b.squares.height};
  j["square_mm"] = b.square_mm;
  j["inner_corners"] = {b.squares.width - 1, b.squares.height - 1};
  const cv::Matx33d& R = b.rotation;
  j["rotation"] = {{R(0, 0), R(0, 1), R(0, 2)}, {R(1, 0), R(1, 1), R(1, 2)}, {R(2, 0), R(2, 1), R(2, 2)}};
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  j["rotation_vector"] = {rvec[0], rvec[1], rvec[2]};
  j["translation_mm"] = {b.translation[0], b.translation[1], b.translation[2]};
  j["frame"] = "left_camera_from_board; board origin at the first inner corner";
  cloud::WriteTextFileAtomic(path, j.dump() + "\n");
}

std::vector<BoardScene> PaperLabBoards() {
  // 16 board poses: 1.0-1.6 m away, tilted up to 30 degrees, spread over the view.
  std::vector<BoardScene> out;
  for (int i = 0; i < 16; ++i) {
    BoardScene b;
    const double tilt_x = (std::vector<double>{-25, -10, 10, 25})[std::size_t(i % 4)] * kPi / 180;
    const double tilt_y = (std::vector<double>{-30, -12, 12, 30})[std::size_t((i / 4) % 4)] * kPi / 180;
    const double roll = (i % 3 - 1) * 8 * kPi / 180;
    cv::Matx33d R;
    cv::Rodrigues(cv::Matx31d(tilt_x, tilt_y, roll), R);
    b.rotation = R;
    const double z = 1000 + 150 * ((i * 7) % 5);
    const cv::Vec3d centre_world((i % 4 - 1.5) * 0.18 * z + 70, ((i / 4) % 4 - 1.5) * 0.13 * z, z);
    const cv::Vec3d centre_board((b.squares.width - 2) * b.square_mm / 2, (b.squares.height - 2) * b.square_mm / 2, 0);
    b.translation = centre_world - R * centre_board;
    out.push_back(b);
  }
  return out;
}

std::vector<BoardScene> WideBoards() {
  // Where each board's centre goes, as x / z and y / z (the view spans about +-1.03 and +-0.64);
  // less far to the left, which the right camera, 140 mm to the right, sees 0.15 further left.
  const double reach[12][2] = {{-0.55, -0.38}, {0.70, -0.38}, {-0.55, 0.38}, {0.70, 0.38}, {-0.57, 0.0}, {0.72, 0.0},
                               {0.0, -0.40},   {0.0, 0.40},   {-0.45, -0.2}, {0.45, 0.2},  {-0.45, 0.25}, {0.45, -0.25}};
  std::vector<BoardScene> out;
  for (int k = 0; k < 12; ++k) {
    BoardScene b;
    const double tilt_y = (k % 2 ? 30 : -30) * kPi / 180;
    const double tilt_x = ((k / 2) % 2 ? 20 : -20) * kPi / 180;
    const double roll = (k % 3 - 1) * 10 * kPi / 180;
    cv::Matx33d R;
    cv::Rodrigues(cv::Matx31d(tilt_x, tilt_y, roll), R);
    b.rotation = R;
    const double z = 850 + 50 * (k % 5);
    const cv::Vec3d centre_world(reach[k][0] * z, reach[k][1] * z, z);
    const cv::Vec3d centre_board((b.squares.width - 2) * b.square_mm / 2, (b.squares.height - 2) * b.square_mm / 2, 0);
    b.translation = centre_world - R * centre_board;
    out.push_back(b);
  }
  return out;
}

std::vector<SphereScene> PaperLabSpheres() {
  std::vector<SphereScene> out;
  for (int z = 2000; z <= 2600; z += 100) {
    SphereScene sc;
    sc.center = cv::Vec3d(70, 50, z);  // between the cameras, slightly below the optical axis
    out.push_back(sc);
  }
  return out;
}

std::vector<std::string> WritePaperLab(const std::string& dir, double scale, const RenderOptions& options) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec)) throw Error(dir + ": cannot create the output directory");
  const SimRig rig = PaperRig(scale);
  std::vector<std::string> written;
  auto save = [&](const std::string& name, const cv::Mat& img) {
    const std::string path = (fs::path(dir) / name).string();
    WriteImageAtomic(path, img);
    written.push_back(path);
  };
  cloud::WriteTextFileAtomic((fs::path(dir) / "rig_truth.json").string(), RigJson(rig) + "\n");
  written.push_back((fs::path(dir) / "rig_truth.json").string());
  const std::vector<BoardScene> boards = PaperLabBoards();
  for (std::size_t i = 0; i < boards.size(); ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "board_%02zu", i + 1);
    save(std::string(name) + "_left.png", RenderBoard(rig, false, boards[i], options));
    save(std::string(name) + "_right.png", RenderBoard(rig, true, boards[i], options));
    WriteBoardTruth((fs::path(dir) / (std::string(name) + ".truth.json")).string(), boards[i]);
  }
  for (const SphereScene& sc : PaperLabSpheres()) {
    char name[64];
    std::snprintf(name, sizeof(name), "sphere_%04d", static_cast<int>(std::lround(sc.center[2])));
    save(std::string(name) + "_left.png", RenderSphere(rig, false, sc, options));
    save(std::string(name) + "_right.png", RenderSphere(rig, true, sc, options));
    WriteSphereTruth((fs::path(dir) / (std::string(name) + ".truth.json")).string(), sc);
    written.push_back((fs::path(dir) / (std::string(name) + ".truth.json")).string());
  }
  return written;
}

}  // namespace hedgefit::sim
