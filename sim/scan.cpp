// Simulated garden scans by ray casting an analytic scene (see scan.hpp).

#include "sim/scan.hpp"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <thread>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "pipeline/print.hpp"

namespace hedgefit::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDeg = M_PI / 180;

// A small deterministic generator per ray (splitmix64), so threads draw the same as one.
struct RayRandom {
  std::uint64_t state;
  std::uint64_t Next() {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double Uniform() { return double(Next() >> 11) * (1.0 / 9007199254740992.0); }
  double Normal() {
    const double u = std::max(Uniform(), 1e-300), v = Uniform();
    return std::sqrt(-2 * std::log(u)) * std::cos(2 * M_PI * v);
  }
};

// How deep a beam goes into a leaf layer `shell` deep before it stops on a leaf.
double LeafDepth(RayRandom& rng, double shell, double clipped_share) {
  if (shell <= 0) return 0;
  if (rng.Uniform() < clipped_share) return std::abs(rng.Normal()) * 2.0;
  return std::min(shell, -std::log(std::max(rng.Uniform(), 1e-12)) * shell / 3);
}

bool SphereSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& c, double r, double* t0,
                double* t1) {
  const Eigen::Vector3d oc = o - c;
  const double b = oc.dot(d), cc = oc.squaredNorm() - r * r, disc = b * b - cc;
  if (disc < 0) return false;
  const double s = std::sqrt(disc);
  *t0 = -b - s, *t1 = -b + s;
  return *t1 > 0;
}

// The span of a vertical-axis ellipsoid along the ray: the ray in the frame where it is the unit
// sphere (t keeps its meaning: distance along the unit direction `d`).
bool SpheroidSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const ScanSpheroid& e, double* t0, double* t1) {
  const double cs = std::cos(e.heading_rad), sn = std::sin(e.heading_rad);
  auto local = [&](const Eigen::Vector3d& v) {
    return Eigen::Vector3d((v.x() * cs + v.y() * sn) / e.axes_mm.x(), (-v.x() * sn + v.y() * cs) / e.axes_mm.y(),
                           v.z() / e.axes_mm.z());
  };
  const Eigen::Vector3d ol = local(o - e.center_mm), dl = local(d);
  const double a = dl.squaredNorm(), b = ol.dot(dl), c = ol.squaredNorm() - 1, disc = b * b - a * c;
  if (disc < 0) return false;
  const double s = std::sqrt(disc);
  *t0 = (-b - s) / a, *t1 = (-b + s) / a;
  return *t1 > 0;
}

bool BoxSpan(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const ScanBox& b, double* t0, double* t1) {
  double lo = -kInf, hi = kInf;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (o[k] < b.min_mm[k] || o[k] > b.max_mm[k]) return false;
      continue;
    }
    double a = (b.min_mm[k] - o[k]) / d[k], e = (b.max_mm[k] - o[k]) / d[k];
    if (a > e) std::swap(a, e);
    lo = std::max(lo, a), hi = std::min(hi, e);
  }
  *t0 = lo, *t1 = hi;
  return hi >= lo && hi > 0;
}

double CylinderHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const ScanCylinder& c) {
  const Eigen::Vector2d oc = o.head<2>() - c.xy_mm, dd = d.head<2>();
  const double a = dd.squaredNorm();
  if (a < 1e-12) return kInf;
  const double b = oc.dot(dd), cc = oc.squaredNorm() - c.radius_mm * c.radius_mm, disc = b * b - a * cc;
  if (disc < 0) return kInf;
  const double t = (-b - std::sqrt(disc)) / a;
  if (t <= 0) return kInf;
  const double z = o.z() + t * d.z();
  return z >= c.z0_mm && z <= c.z1_mm ? t : kInf;
}

double GroundHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const ScanGround& g, double t_max) {
  auto above = [&](double t) {
    const Eigen::Vector3d p = o + t * d;
    return p.z() - g.Height(p.x(), p.y());
  };
  if (above(0) < 0) return kInf;
  double t = 0;
  while (t < t_max) {
    const double step = std::max(50.0, 0.02 * t);
    const double next = std::min(t + step, t_max);
    if (above(next) < 0) {
      double lo = t, hi = next;
      for (int i = 0; i < 30; ++i) {
        const double mid = 0.5 * (lo + hi);
        (above(mid) < 0 ? hi : lo) = mid;
      }
      return 0.5 * (lo + hi);
    }
    t = next;
  }
  return kInf;
}

// The range at which the beam from `o` along `d` stops, or infinity.
double Cast(const ScanScene& s, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, RayRandom& rng) {
  double best = t_max;
  auto leafy = [&](double t0, double t1, double shell, double clipped, double gaps) {
    if (t0 < 0 || t0 >= best) return;
    if (gaps > 0 && rng.Uniform() < gaps) return;
    best = std::min(best, std::min(t0 + LeafDepth(rng, shell, clipped), 0.5 * (t0 + t1)));
  };
  double t0 = 0, t1 = 0;
  for (const auto& b : s.balls) {
    if (SphereSpan(o, d, b.center_mm, b.radius_mm, &t0, &t1)) leafy(t0, t1, b.shell_mm, b.clipped_share, 0);
  }
  for (const auto& e : s.topiary) {
    if (SpheroidSpan(o, d, e, &t0, &t1)) leafy(t0, t1, e.shell_mm, e.clipped_share, 0);
  }
  for (const auto& b : s.blobs) {
    if (SphereSpan(o, d, b.center_mm, b.radius_mm, &t0, &t1)) leafy(t0, t1, b.shell_mm, b.clipped_share, b.gap_share);
  }
  for (const auto& b : s.boxes) {
    if (BoxSpan(o, d, b, &t0, &t1)) leafy(t0, t1, b.shell_mm, 0.3, b.gap_share);
  }
  for (const auto& c : s.cylinders) best = std::min(best, CylinderHit(o, d, c));
  if (d.z() < 0.05) best = std::min(best, GroundHit(o, d, s.ground, best));
  return best < t_max ? best : kInf;
}

struct Ray {
  Eigen::Vector3d origin, dir;
  double noise_mm;
};

cloud::PointCloud CastAll(const ScanScene& scene, const std::vector<Ray>& rays, const ScanOptions& o, double t_max) {
  std::vector<Eigen::Vector3f> hit(rays.size(), Eigen::Vector3f::Constant(std::nanf("")));
  auto work = [&](std::size_t from, std::size_t to) {
    for (std::size_t i = from; i < to; ++i) {
      RayRandom rng{o.seed * 0x2545F4914F6CDD1DULL + i};
      if (rng.Uniform() < o.dropout) continue;
      const Ray& r = rays[i];
      double t = Cast(scene, r.origin, r.dir, t_max, rng);
      if (!std::isfinite(t)) continue;
      const bool photo = o.sensor == Sensor::kPhotogrammetry || o.sensor == Sensor::kAerial;
      t += r.noise_mm * (photo ? t / 5000 : 1.0) * rng.Normal();
      if (photo && rng.Uniform() < o.outlier_share) t += 300 * rng.Normal();
      hit[i] = (r.origin + t * r.dir).cast<float>();
    }
  };
  const std::size_t half = rays.size() / 2;
  std::thread other(work, half, rays.size());
  work(0, half);
  other.join();
  cloud::PointCloud c;
  for (const auto& p : hit) if (p.allFinite()) c.points_mm.push_back(p);
  c.Flatten();
  return c;
}

// A pinhole camera's rays, one per pixel of a width x height image with focal length f (px).
void CameraRays(const Eigen::Vector3d& eye, const Eigen::Vector3d& forward, const Eigen::Vector3d& right, int width,
                int height, double f, double noise_mm, std::vector<Ray>* rays) {
  const Eigen::Vector3d down = forward.cross(right);
  for (int v = 0; v < height; ++v) {
    for (int w = 0; w < width; ++w) {
      const Eigen::Vector3d d = (forward * f + right * (w - width / 2.0) + down * (v - height / 2.0)).normalized();
      rays->push_back({eye, d, noise_mm});
    }
  }
}

Eigen::Vector3d Direction(double azimuth, double elevation) {
  return {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
}

}  // namespace

double ScanGround::Height(double x, double y) const {
  return slope_x * x + slope_y * y +
         bump_mm * 0.5 * (std::sin(2 * M_PI * x / wavelength_mm + phase_x) + std::sin(2 * M_PI * y / (0.8 * wavelength_mm) + phase_y));
}

ScanScene RandomScanGarden(std::uint64_t seed) {
  std::mt19937_64 rng(seed * 7919 + 17);
  std::uniform_real_distribution<double> u(0, 1);
  auto in = [&](double lo, double hi) { return lo + (hi - lo) * u(rng); };
  ScanScene s;
  s.ground.slope_x = in(-0.06, 0.06), s.ground.slope_y = in(-0.06, 0.06);
  s.ground.bump_mm = in(20, 50), s.ground.wavelength_mm = in(4000, 7000);
  s.ground.phase_x = in(0, 6.28), s.ground.phase_y = in(0, 6.28);
  auto ground = [&](double x, double y) { return s.ground.Height(x, y); };
  auto ball = [&](double x, double y, double r, double sink) {
    ScanSphere b;
    b.radius_mm = r;
    b.center_mm = Eigen::Vector3d(x, y, ground(x, y) + r * (1 - 2 * sink));
    b.shell_mm = in(20, 60);
    b.clipped_share = in(0.35, 0.6);
    s.balls.push_back(b);
  };
  // Leafy blobs, clumped: a rose bush's foliage clusters along canes arching out of its base, or a
  // crown's sprays; each is small (`lo`-`hi` of the clump's size: 2-14 cm, as leaf clusters are),
  // gappy and deep, so the clump has no clipped ball's smooth envelope.
  auto clump = [&](const Eigen::Vector3d& base, double size, int n, double lo, double hi, double gaps, double depth) {
    for (int k = 0; k < n; ++k) {
      const double az = in(0, 2 * M_PI), el = in(0.35, 1.4), reach = in(0.3, 1.0) * size;
      ScanSphere b;
      b.center_mm = base + reach * Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      b.radius_mm = size * in(lo, hi);
      b.shell_mm = depth;
      b.clipped_share = 0.05;
      b.gap_share = gaps;
      s.blobs.push_back(b);
    }
  };
  double x = 1500;
  // 1-2: free balls; a touching pair; a rose; a ball pressed against a hedge row; a tree; a dome;
  // a second rose; a bench; a last ball; a fence along the back.
  const double r1 = in(300, 700);
  ball(x + r1, in(2500, 4500), r1, 0);
  x += 2 * r1 + in(1200, 2000);
  const double r2 = in(500, 900);
  ball(x + r2, in(2500, 4500), r2, in(0, 0.1));
  x += 2 * r2 + in(1200, 2000);
  const double ra = in(350, 600), rb = in(350, 600), yp = in(2500, 4000);
  ball(x + ra, yp, ra, 0);
  ball(x + 2 * ra + rb - 0.03 * (ra + rb), yp + in(-200, 200), rb, 0);
  x += 2 * (ra + rb) + in(1200, 2000);
  const double rose = in(400, 700);
  clump(Eigen::Vector3d(x + rose, 3500, ground(x + rose, 3500) + 0.2 * rose), rose, 60, 0.06, 0.15, 0.35, 80);
  s.others.push_back({"rose", Eigen::Vector3d(x + rose, 3500, ground(x + rose, 3500) + rose)});
  x += 2 * rose + in(1200, 2000);
  {
    ScanBox row;
    const double y0 = 5000, y1 = 5900, len = in(3500, 5000);
    row.min_mm = Eigen::Vector3d(x, y0, ground(x + len / 2, y0) - 100);
    row.max_mm = Eigen::Vector3d(x + len, y1, ground(x + len / 2, y0) + in(1200, 1600));
    row.shell_mm = 60;
    s.boxes.push_back(row);
    s.others.push_back({"hedge row", 0.5 * (row.min_mm + row.max_mm)});
    const double rr = in(350, 600);
    ball(x + len / 2, y0 - rr + 0.05 * rr, rr, 0);
    x += len + in(1200, 2000);
  }
  {
    const double crown = in(900, 1300), tx = x + crown, ty = in(3000, 6000);
    ScanCylinder trunk;
    trunk.xy_mm = Eigen::Vector2d(tx, ty);
    trunk.radius_mm = in(80, 150);
    trunk.z0_mm = ground(tx, ty) - 100;
    trunk.z1_mm = ground(tx, ty) + in(1600, 2200);
    s.cylinders.push_back(trunk);
    clump(Eigen::Vector3d(tx, ty, trunk.z1_mm), crown, 120, 0.05, 0.11, 0.4, 120);
    s.others.push_back({"tree", Eigen::Vector3d(tx, ty, trunk.z1_mm)});
    x += 2 * crown + in(1000, 1800);
  }
  const double rd = in(700, 950);
  ball(x + rd, in(2500, 4500), rd, in(0.25, 0.4));
  x += 2 * rd + in(1200, 2000);
  const double rose2 = in(350, 600);
  clump(Eigen::Vector3d(x + rose2, 3000, ground(x + rose2, 3000) + 0.2 * rose2), rose2, 50, 0.06, 0.15, 0.35, 80);
  s.others.push_back({"rose", Eigen::Vector3d(x + rose2, 3000, ground(x + rose2, 3000) + rose2)});
  x += 2 * rose2 + in(1200, 2000);
  {
    ScanBox bench;
    const double y = in(2500, 4000);
    bench.min_mm = Eigen::Vector3d(x, y, ground(x + 750, y + 250) + 400);
    bench.max_mm = Eigen::Vector3d(x + 1500, y + 450, ground(x + 750, y + 250) + 460);
    s.boxes.push_back(bench);
    for (double lx : {x + 100, x + 1400}) {
      ScanCylinder leg;
      leg.xy_mm = Eigen::Vector2d(lx, y + 225);
      leg.radius_mm = 40;
      leg.z0_mm = ground(lx, y + 225) - 50;
      leg.z1_mm = bench.min_mm.z();
      s.cylinders.push_back(leg);
    }
    s.others.push_back({"bench", 0.5 * (bench.min_mm + bench.max_mm)});
    x += 1500 + in(1200, 2000);
  }
  const double rl = in(300, 600);
  ball(x + rl, in(2500, 4500), rl, 0);
  x += 2 * rl + 1500;
  s.extent_mm = Eigen::Vector2d(x, 10000);
  {
    ScanBox fence;
    fence.min_mm = Eigen::Vector3d(0, 9000, ground(x / 2, 9000) - 300);
    fence.max_mm = Eigen::Vector3d(x, 9080, ground(x / 2, 9000) + 1200);
    // A fence follows the slope: split into 2 m panels, each at its own ground.
    for (double fx = 0; fx < x; fx += 2000) {
      ScanBox panel = fence;
      panel.min_mm.x() = fx, panel.max_mm.x() = std::min(x, fx + 2000);
      const double gz = ground(fx + 1000, 9000);
      panel.min_mm.z() = gz - 200, panel.max_mm.z() = gz + 1200;
      s.boxes.push_back(panel);
    }
    s.others.push_back({"fence", Eigen::Vector3d(x / 2, 9040, ground(x / 2, 9000) + 600)});
  }
  return s;
}

ScanScene RandomTopiaryBed(std::uint64_t seed) {
  std::mt19937_64 rng(seed * 104729 + 31);
  std::uniform_real_distribution<double> u(0, 1);
  auto in = [&](double lo, double hi) { return lo + (hi - lo) * u(rng); };
  ScanScene s;
  s.ground.slope_x = in(-0.04, 0.04), s.ground.slope_y = in(-0.04, 0.04);
  s.ground.bump_mm = in(10, 30), s.ground.wavelength_mm = in(4000, 7000);
  s.ground.phase_x = in(0, 6.28), s.ground.phase_y = in(0, 6.28);
  auto ground = [&](double x, double y) { return s.ground.Height(x, y); };
  // The bed: a row of squat shapes along x at y = 3 m; the next one's footprint starts `gap`
  // after this one's (a pair touches: gap 0, their leaves pressed together).
  double x = 1500;
  const int n = 4 + int(u(rng) * 3);
  const int touching = int(u(rng) * (n - 1));
  for (int k = 0; k < n; ++k) {
    ScanSpheroid e;
    const double a = in(250, 450);
    const bool elliptic = u(rng) < 0.4;
    e.axes_mm = Eigen::Vector3d(a, elliptic ? a * in(0.7, 0.85) : a, a * in(0.5, 0.85));
    e.heading_rad = elliptic ? in(0, M_PI) : 0;
    // Their tops 0.35-0.6 m above the lawn (the real garden's are 0.35-0.5 m): the centre stands
    // up to c above it (a squat spheroid on the lawn) or a little below (a dome cut by it).
    const double top = std::clamp(in(0.9, 1.4) * a, 350.0, 600.0);
    const double lift = std::max(top - e.axes_mm.z(), -0.2 * e.axes_mm.z());
    const double half_width = e.axes_mm.x();  // a bound of the footprint along x, whatever the heading
    const double y = 3000 + in(-300, 300);
    e.center_mm = Eigen::Vector3d(x + half_width, y, ground(x + half_width, y) + lift);
    e.shell_mm = in(15, 40);
    e.clipped_share = in(0.4, 0.65);
    s.topiary.push_back(e);
    double gap = k == touching ? 0.0 : in(150, 600);
    // Between some, a rose bush (foliage clumps on arching canes, as RandomScanGarden's).
    if (gap > 450 && u(rng) < 0.6) {
      const double rose = in(250, 350);
      const Eigen::Vector3d base(x + 2 * half_width + gap / 2, y + in(500, 800), ground(x + 2 * half_width + gap / 2, y + 650));
      for (int c = 0; c < 45; ++c) {
        const double az = in(0, 2 * M_PI), el = in(0.35, 1.4), reach = in(0.3, 1.0) * rose;
        ScanSphere b;
        b.center_mm = base + Eigen::Vector3d(0, 0, 0.3 * rose) +
                      reach * Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        b.radius_mm = rose * in(0.06, 0.15);
        b.shell_mm = 60;
        b.clipped_share = 0.05;
        b.gap_share = 0.35;
        s.blobs.push_back(b);
      }
      s.others.push_back({"rose", base + Eigen::Vector3d(0, 0, rose)});
    }
    x += 2 * half_width + gap;
  }
  // A low box hedge row behind the bed, a post and a small free ball in front.
  {
    ScanBox row;
    const double len = in(3000, 4500), y0 = 5200;
    row.min_mm = Eigen::Vector3d(1500, y0, ground(1500 + len / 2, y0) - 100);
    row.max_mm = Eigen::Vector3d(1500 + len, y0 + in(400, 550), ground(1500 + len / 2, y0) + in(350, 500));
    row.shell_mm = 40;
    s.boxes.push_back(row);
    s.others.push_back({"hedge row", 0.5 * (row.min_mm + row.max_mm)});
  }
  {
    ScanCylinder post;
    post.xy_mm = Eigen::Vector2d(x + 500, 1500);
    post.radius_mm = 60;
    post.z0_mm = ground(x + 500, 1500) - 50;
    post.z1_mm = ground(x + 500, 1500) + in(800, 1200);
    s.cylinders.push_back(post);
    s.others.push_back({"post", Eigen::Vector3d(x + 500, 1500, post.z1_mm / 2)});
  }
  {
    ScanSphere b;
    b.radius_mm = in(300, 400);
    b.center_mm = Eigen::Vector3d(2500, 1300, ground(2500, 1300) + b.radius_mm);
    b.shell_mm = in(20, 40);
    b.clipped_share = in(0.4, 0.6);
    s.balls.push_back(b);
  }
  s.extent_mm = Eigen::Vector2d(x + 1500, 7000);
  return s;
}

const char* SensorName(Sensor s) {
  switch (s) {
    case Sensor::kLidar16: return "lidar16";
    case Sensor::kLidar32: return "lidar32";
    case Sensor::kTerrestrial: return "terrestrial";
    case Sensor::kPhotogrammetry: return "photogrammetry";
    case Sensor::kAerial: return "aerial";
  }
  return "?";
}

Sensor ParseSensor(const std::string& name) {
  for (Sensor s : {Sensor::kLidar16, Sensor::kLidar32, Sensor::kTerrestrial, Sensor::kPhotogrammetry, Sensor::kAerial}) {
    if (name == SensorName(s)) return s;
  }
  throw Error("unknown sensor '" + name + "'; choose lidar16, lidar32, terrestrial, photogrammetry or aerial");
}

namespace {
// The aerial cameras' ground target: the garden's middle.
Eigen::Vector3d Middle(const ScanScene& scene) {
  const double ex = scene.extent_mm.x(), ey = scene.extent_mm.y();
  return Eigen::Vector3d(ex / 2, ey / 2, scene.ground.Height(ex / 2, ey / 2));
}
}  // namespace

std::vector<Eigen::Vector3d> ScanStations(const ScanScene& scene, const ScanOptions& o) {
  std::vector<Eigen::Vector3d> at;
  const double ex = scene.extent_mm.x(), ey = scene.extent_mm.y();
  const Eigen::Vector3d middle = Middle(scene);
  switch (o.sensor) {
    case Sensor::kLidar16:
    case Sensor::kLidar32:
      // Driving past along y = -1.5 m, a sweep every metre.
      for (double px = -2000; px <= ex + 2000; px += 1000) at.emplace_back(px, -1500, scene.ground.Height(px, -1500) + o.height_mm);
      break;
    case Sensor::kTerrestrial:
      for (double sx : {0.3 * ex, 0.7 * ex}) at.emplace_back(sx, -2500, scene.ground.Height(sx, -2500) + o.height_mm);
      break;
    case Sensor::kAerial:
      // A drone: 3 x 3 stations 6 m above the lawn over the garden.
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) at.emplace_back(ex * (0.1 + 0.4 * i), ey * (0.1 + 0.4 * j), middle.z() + 6000);
      }
      break;
    case Sensor::kPhotogrammetry:
      // 10 cameras on an ellipse around the garden, 4 m up.
      for (int k = 0; k < 10; ++k) {
        const double a = 2 * M_PI * k / 10;
        at.emplace_back(middle.x() + (ex / 2 + 4000) * std::cos(a), middle.y() + (ey / 2 + 4000) * std::sin(a), middle.z() + 4000);
      }
      break;
  }
  if (o.station >= 0) {
    if (std::size_t(o.station) >= at.size()) {
      throw Error(pipeline::Format("scan station %d: this sensor stands at %zu stations (0-%zu)", o.station, at.size(), at.size() - 1));
    }
    at = {at[std::size_t(o.station)]};
  }
  return at;
}

cloud::PointCloud ScanGarden(const ScanScene& scene, const ScanOptions& o) {
  std::vector<Ray> rays;
  const std::vector<Eigen::Vector3d> stations = ScanStations(scene, o);
  if (o.sensor == Sensor::kLidar16 || o.sensor == Sensor::kLidar32) {
    std::vector<double> elevations;
    if (o.sensor == Sensor::kLidar16) {
      for (int k = 0; k < 16; ++k) elevations.push_back((-15 + 2 * k) * kDeg);
    } else {
      for (int k = 0; k < 32; ++k) elevations.push_back((-30.67 + 1.333 * k) * kDeg);
    }
    const double step = (o.step_deg > 0 ? o.step_deg : 0.2) * kDeg;
    for (const auto& origin : stations) {
      for (double az = 0; az < 2 * M_PI; az += step) {
        for (double el : elevations) rays.push_back({origin, Direction(az, el), o.noise_mm});
      }
    }
    return CastAll(scene, rays, o, 40000);
  }
  if (o.sensor == Sensor::kTerrestrial) {
    const double step = (o.step_deg > 0 ? o.step_deg : 0.15) * kDeg;
    for (const auto& origin : stations) {
      // Facing the garden: azimuth 0-180 deg (the half behind holds no garden).
      for (double az = 0; az < M_PI; az += step) {
        for (double el = -50 * kDeg; el < 30 * kDeg; el += step) rays.push_back({origin, Direction(az, el), o.noise_mm});
      }
    }
    return CastAll(scene, rays, o, 60000);
  }
  const Eigen::Vector3d middle = Middle(scene);
  if (o.sensor == Sensor::kAerial) {
    // Each camera looks down 25 degrees off nadir towards the garden's middle (the centre one
    // straight down); 90-degree field of view.
    const int width = 400, height = 400;
    const double f = 200 * (o.step_deg > 0 ? 0.15 / o.step_deg : 1.0);
    for (const auto& eye : stations) {
      Eigen::Vector3d toward = Eigen::Vector3d(middle.x() - eye.x(), middle.y() - eye.y(), 0);
      Eigen::Vector3d forward(0, 0, -1);
      if (toward.norm() > 1) forward = (std::cos(25 * kDeg) * forward + std::sin(25 * kDeg) * toward.normalized()).normalized();
      const Eigen::Vector3d right = (std::abs(forward.z()) > 0.999 ? Eigen::Vector3d::UnitX()
                                                                  : forward.cross(Eigen::Vector3d::UnitZ()).normalized());
      CameraRays(eye, forward, right, width, height, f, o.noise_mm, &rays);
    }
    return CastAll(scene, rays, o, 30000);
  }
  // Photogrammetry: the cameras look at the garden's middle.
  const int width = 480, height = 300;
  const double f = 300 * (o.step_deg > 0 ? 0.15 / o.step_deg : 1.0);
  for (const auto& eye : stations) {
    const Eigen::Vector3d forward = (middle - eye).normalized();
    CameraRays(eye, forward, forward.cross(Eigen::Vector3d::UnitZ()).normalized(), width, height, f, o.noise_mm, &rays);
  }
  return CastAll(scene, rays, o, 80000);
}

void WriteScanTruth(const std::string& path, const ScanScene& scene) {
  nlohmann::json j;
  j["frame"] = "world, z up, mm";
  j["hedges"] = nlohmann::json::array();
  for (const auto& b : scene.balls) {
    j["hedges"].push_back({{"center_mm", {b.center_mm.x(), b.center_mm.y(), b.center_mm.z()}},
                           {"radius_mm", b.radius_mm},
                           {"shell_mm", b.shell_mm},
                           {"ground_mm", scene.ground.Height(b.center_mm.x(), b.center_mm.y())}});
  }
  j["topiary"] = nlohmann::json::array();
  for (const auto& e : scene.topiary) {
    j["topiary"].push_back({{"center_mm", {e.center_mm.x(), e.center_mm.y(), e.center_mm.z()}},
                            {"axes_mm", {e.axes_mm.x(), e.axes_mm.y(), e.axes_mm.z()}},
                            {"heading_deg", e.heading_rad * 180 / M_PI},
                            {"shell_mm", e.shell_mm},
                            {"ground_mm", scene.ground.Height(e.center_mm.x(), e.center_mm.y())}});
  }
  j["others"] = nlohmann::json::array();
  for (const auto& o : scene.others) {
    j["others"].push_back({{"kind", o.kind}, {"center_mm", {o.center_mm.x(), o.center_mm.y(), o.center_mm.z()}}});
  }
  cloud::WriteTextFileAtomic(path, j.dump(2) + "\n");
}

}  // namespace hedgefit::sim
