#include "sim/povray.hpp"
#include "stereo/stereo_stages.hpp"

#include <opencv2/imgcodecs.hpp>  // the IMREAD_ flags

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <sstream>
#include <unordered_map>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "eval/truth_file.hpp"
#include "stereo/rig.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::sim {

using stereo::ReadImageFile;
using stereo::WriteImageAtomic;

namespace {

constexpr double kPi = 3.14159265358979323846;

// OpenCV's camera frame (x right, y down, z forward; right-handed) to POV-Ray's (x right,
// y up, z forward; left-handed): flip y. A reflection keeps POV-Ray's right = up x direction.
std::string Pov(const cv::Vec3d& v) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "<%.6f, %.6f, %.6f>", v[0], -v[1], v[2]);
  return buf;
}

// Whole-pixel principal point offsets from the image centre, and the canvas that holds them.
struct Canvas {
  int dx = 0, dy = 0;
  cv::Size size;
};

Canvas CanvasOf(const SimCamera& cam) {
  Canvas c;
  c.dx = static_cast<int>(std::lround(cam.K(0, 2) - (cam.size.width - 1) / 2.0));
  c.dy = static_cast<int>(std::lround(cam.K(1, 2) - (cam.size.height - 1) / 2.0));
  c.size = cv::Size(cam.size.width + 2 * std::abs(c.dx), cam.size.height + 2 * std::abs(c.dy));
  return c;
}

std::string Camera(const SimRig& rig, bool right, cv::Size canvas) {
  const SimCamera& cam = right ? rig.right : rig.left;
  // World = left camera frame; the right camera's axes are the rows of R, its centre -R^T T.
  const cv::Matx33d R = right ? rig.R : cv::Matx33d::eye();
  const cv::Vec3d centre = right ? cv::Vec3d(-(rig.R.t() * rig.T)) : cv::Vec3d(0, 0, 0);
  const cv::Vec3d x(R(0, 0), R(0, 1), R(0, 2)), y(R(1, 0), R(1, 1), R(1, 2)), z(R(2, 0), R(2, 1), R(2, 2));
  std::ostringstream s;
  s << "camera {\n  perspective\n  location " << Pov(centre) << "\n  right " << Pov(x * double(canvas.width))
    << "\n  up " << Pov(-y * double(canvas.height)) << "\n  direction " << Pov(z * cam.K(0, 0)) << "\n}\n";
  return s.str();
}

// Lights and settings shared by every scene: an area light above, left and in front of the
// rig (soft shadows, uneven light over a board), a weaker fill from the right, linear output.
const char* kCommon = R"(#version 3.7;
global_settings { assumed_gamma 1.0 max_trace_level 5 }
light_source { <-1800, 2600, -900> color rgb 1.05
  area_light <700, 0, 0>, <0, 0, 700>, 5, 5 adaptive 1 jitter circular orient }
light_source { <1600, 600, -1200> color rgb 0.30 shadowless }
)";

std::string Matrix(const cv::Matx33d& R, const cv::Vec3d& t) {
  // POV-Ray's matrix < r00, r01, r02, r10, ... > maps row vectors: p' = p M. With the y flip
  // F on both sides, world = F (R F q + t) for a point q given in POV-Ray's board frame.
  const cv::Matx33d F(1, 0, 0, 0, -1, 0, 0, 0, 1);
  const cv::Matx33d M = F * R * F;
  char buf[512];
  std::snprintf(buf, sizeof(buf), "matrix <%.9f, %.9f, %.9f, %.9f, %.9f, %.9f, %.9f, %.9f, %.9f, %.6f, %.6f, %.6f>",
                M(0, 0), M(1, 0), M(2, 0), M(0, 1), M(1, 1), M(2, 1), M(0, 2), M(1, 2), M(2, 2), t[0], -t[1], t[2]);
  return buf;
}

}  // namespace

SimRig PovrayRig(double scale) {
  SimRig rig = PaperRig(scale);
  for (SimCamera* c : {&rig.left, &rig.right}) {
    c->dist = cv::Vec<double, 5>(0, 0, 0, 0, 0);
    c->K(0, 2) = (c->size.width - 1) / 2.0;
    c->K(1, 2) = (c->size.height - 1) / 2.0;
  }
  // Principal points off the centre by whole pixels, differently in the two cameras.
  rig.left.K(1, 2) += std::lround(2 * scale);
  rig.right.K(0, 2) += std::lround(3 * scale);
  rig.right.K(1, 2) -= std::lround(1 * scale);
  return rig;
}

std::string PovrayBoardScene(const SimRig& rig, bool right, const BoardScene& b, cv::Size canvas) {
  const double s = b.square_mm;
  const double x_lo = -s - b.margin_mm, x_hi = (b.squares.width - 1) * s + b.margin_mm;
  const double y_lo = -s - b.margin_mm, y_hi = (b.squares.height - 1) * s + b.margin_mm;
  std::ostringstream o;
  o << kCommon << Camera(rig, right, canvas);
  // In the board's frame (OpenCV axes, y flipped for POV-Ray): the squares on z = 0, the white
  // margin a hair behind, the board's body behind that. Square (ix, iy), ix = floor(q0 / s) + 1,
  // is dark when ix + iy is even: POV-Ray's checker gives colour 1 where floor(x) + floor(y) +
  // floor(z) is even; in POV-Ray's y (= -q1) floor(y / s) has the parity of iy, so the pattern
  // moves one square in x (parity of ix) and half a square in z (floor 0 on the face).
  o << "union {\n"
    << "  box { <" << -s << ", " << -((b.squares.height - 1) * s) << ", 0>, <" << (b.squares.width - 1) * s << ", " << s
    << ", 2>\n"
    << "    texture { pigment { checker color rgb 0.06 color rgb 0.88 translate <1, 0, -0.5> scale " << s << " }\n"
    << "      finish { ambient 0.12 diffuse 0.85 specular 0.04 roughness 0.05 } } }\n"
    << "  box { <" << x_lo << ", " << -y_hi << ", 0.05>, <" << x_hi << ", " << -y_lo << ", 8>\n"
    << "    texture { pigment { color rgb 0.9 } finish { ambient 0.12 diffuse 0.85 } } }\n"
    << "  " << Matrix(b.rotation, b.translation) << "\n}\n";
  // A dim room behind the board.
  o << "plane { z, 6000 texture { pigment { color rgb <0.45, 0.42, 0.4> } finish { ambient 0.3 diffuse 0.4 } } }\n";
  return o.str();
}

std::string PovraySphereScene(const SimRig& rig, bool right, const SphereScene& sc, cv::Size canvas) {
  const double ground_y = sc.ground_y != 0 ? sc.ground_y : sc.center[1] + sc.radius;
  const double wall_z = sc.wall_z != 0 ? sc.wall_z : sc.center[2] + 2000;
  std::ostringstream o;
  o << kCommon << Camera(rig, right, canvas);
  // Foliage: a solid granite pattern in greens (both views see the same surface), small-scale
  // bumps for the light, a little specular sheen of leaves.
  o << "sphere { " << Pov(sc.center) << ", " << sc.radius << "\n"
    << "  texture {\n"
    << "    pigment { granite turbulence 0.35 color_map { [0.0 rgb <0.03, 0.12, 0.02>] [0.3 rgb <0.08, 0.30, 0.05>]\n"
    << "      [0.55 rgb <0.16, 0.46, 0.09>] [0.8 rgb <0.30, 0.60, 0.14>] [1.0 rgb <0.55, 0.75, 0.30>] } scale 70 }\n"
    << "    normal { bumps 0.45 scale 6 }\n"
    << "    finish { ambient 0.12 diffuse 0.8 specular 0.08 roughness 0.04 } } }\n";
  // Soil with stones and a brick wall, each with its own solid texture.
  o << "plane { y, " << -ground_y << "\n"
    << "  texture { pigment { bozo turbulence 0.8 color_map { [0.0 rgb <0.22, 0.16, 0.10>] [0.5 rgb <0.38, 0.29, 0.19>]\n"
    << "    [1.0 rgb <0.52, 0.45, 0.36>] } scale 25 } normal { granite 0.3 scale 20 } finish { ambient 0.12 diffuse 0.8 } } }\n";
  o << "plane { z, " << wall_z << "\n"
    << "  texture { pigment { brick color rgb <0.62, 0.60, 0.56> color rgb <0.55, 0.24, 0.16> brick_size <240, 90, 120>\n"
    << "    mortar 12 } normal { granite 0.2 scale 15 } finish { ambient 0.15 diffuse 0.7 } } }\n";
  return o.str();
}

bool HavePovray() { return std::system("command -v povray > /dev/null 2>&1") == 0; }

namespace {

// Renders `scene(canvas)` with POV-Ray in `work_dir` and crops the camera's image from the canvas.
cv::Mat RenderPovrayText(const SimRig& rig, bool right, const std::function<std::string(cv::Size)>& scene,
                         const std::string& work_dir, bool depth = false) {
  namespace fs = std::filesystem;
  if (!HavePovray()) throw Error("povray: not found; install Debian's povray package (scripts/setup.sh does)");
  const SimCamera& cam = right ? rig.right : rig.left;
  const Canvas canvas = CanvasOf(cam);
  const std::string stem = (fs::path(work_dir) / (std::string(".pov_") + (right ? "right" : "left"))).string();
  cloud::WriteTextFileAtomic(stem + ".pov", scene(canvas.size));
  // Adaptive anti-aliasing (method 2, threshold 0.05, depth 3), both cores, no display.
  std::ostringstream cmd;
  cmd << "cd '" << work_dir << "' && povray +I'" << fs::path(stem).filename().string() << ".pov' +O'"
      << fs::path(stem).filename().string() << ".png' +W" << canvas.size.width << " +H" << canvas.size.height
      << (depth ? " -A +FN16 File_Gamma=1.0" : " +A0.05 +AM2 +R3 +FN8") << " +Q9 -D -V -GA +WT2 > '"
      << fs::path(stem).filename().string() << ".log' 2>&1";
  if (std::system(cmd.str().c_str()) != 0) throw Error(stem + ".log: POV-Ray failed; see its log");
  cv::Mat full;
  try {
    full = ReadImageFile(stem + ".png", depth ? cv::IMREAD_UNCHANGED : cv::IMREAD_COLOR);
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + ": POV-Ray wrote no image; see " + stem + ".log");
  }
  // The camera's image within the canvas: its principal point lands where K puts it.
  const int ox = std::abs(canvas.dx) - canvas.dx, oy = std::abs(canvas.dy) - canvas.dy;
  return full(cv::Rect(ox, oy, cam.size.width, cam.size.height)).clone();
}

}  // namespace

cv::Mat RenderPovray(const SimRig& rig, bool right, const std::string& kind, const BoardScene& board,
                     const SphereScene& sphere, const std::string& work_dir) {
  return RenderPovrayText(
      rig, right,
      [&](cv::Size canvas) {
        return kind == "board" ? PovrayBoardScene(rig, right, board, canvas) : PovraySphereScene(rig, right, sphere, canvas);
      },
      work_dir);
}

std::vector<std::string> WritePovrayLab(const std::string& dir, double scale, const CameraModel& camera,
                                        std::uint64_t seed, const std::string& as_rendered_dir) {
  namespace fs = std::filesystem;
  const SimRig rig = PovrayRig(scale);
  std::vector<std::string> written = StartSimulationDir(dir, rig);
  std::uint64_t view = seed * 1000;
  auto save = [&](const std::string& name, bool right, const std::string& kind, const BoardScene& b,
                  const SphereScene& s) {
    const cv::Mat rendered = RenderPovray(rig, right, kind, b, s, dir);
    if (kind == "sphere" && !as_rendered_dir.empty()) {
      fs::create_directories(as_rendered_dir);
      WriteImageAtomic((fs::path(as_rendered_dir) / name).string(), rendered);
    }
    const cv::Mat img = ApplyCameraModel(rendered, camera, right, view++ / 2);
    const std::string path = (fs::path(dir) / name).string();
    WriteImageAtomic(path, img);
    written.push_back(path);
  };
  const std::vector<BoardScene> boards = PaperLabBoards();
  for (std::size_t i = 0; i < boards.size(); ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "board_%02zu", i + 1);
    save(std::string(name) + "_left.png", false, "board", boards[i], {});
    save(std::string(name) + "_right.png", true, "board", boards[i], {});
    WriteBoardTruth((fs::path(dir) / (std::string(name) + ".truth.json")).string(), boards[i]);
  }
  for (const SphereScene& sc : PaperLabSpheres()) {
    char name[64];
    std::snprintf(name, sizeof(name), "sphere_%04d", static_cast<int>(std::lround(sc.center[2])));
    save(std::string(name) + "_left.png", false, "sphere", {}, sc);
    save(std::string(name) + "_right.png", true, "sphere", {}, sc);
    WriteSphereTruth((fs::path(dir) / (std::string(name) + ".truth.json")).string(), sc);
    written.push_back((fs::path(dir) / (std::string(name) + ".truth.json")).string());
  }
  return written;
}

std::vector<std::string> WriteWideBoards(const std::string& dir, const std::string& renderer, double scale,
                                         const RenderOptions& options, const CameraModel& camera, std::uint64_t seed) {
  namespace fs = std::filesystem;
  if (renderer != "hedgefit" && renderer != "povray") throw Error("renderer: use hedgefit or povray");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec)) throw Error(dir + ": cannot create the output directory");
  const SimRig rig = renderer == "povray" ? PovrayRig(scale) : PaperRig(scale);
  std::vector<std::string> written;
  const std::vector<BoardScene> boards = WideBoards();
  std::uint64_t view = seed * 1000 + 500;  // other draws than the lab's boards
  for (std::size_t i = 0; i < boards.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "board_%02zu", i + 17);
    for (bool right : {false, true}) {
      const cv::Mat img = renderer == "povray" ? RenderPovray(rig, right, "board", boards[i], {}, dir)
                                               : RenderBoard(rig, right, boards[i], options);
      const std::string path = (fs::path(dir) / (std::string(name) + (right ? "_right.png" : "_left.png"))).string();
      WriteImageAtomic(path, ApplyCameraModel(img, camera, right, view / 2));
      ++view;
      written.push_back(path);
    }
    WriteBoardTruth((fs::path(dir) / (std::string(name) + ".truth.json")).string(), boards[i]);
  }
  cloud::WriteTextFileAtomic((fs::path(dir) / "rig_truth.json").string(), RigJson(rig) + "\n");
  return written;
}

namespace {

// A leaf of a POV-Ray hedge (level frame) and one of the scene's 9 leaf textures L0..L8 (3 depth
// bands x 3 hues): a disc of radius a about c, normal n; an elongated flat leaf, the same disc
// scaled to half-width b across e1; or a cupped leaf, a lozenge folded along its midrib (`rim`:
// tip, side, tip, side about c; two triangles in the hedge's mesh).
struct PovLeaf {
  cv::Vec3d c, n, e1;
  double a = 8, b = 8;
  int texture = 0;
  std::vector<cv::Vec3d> rim;  // empty: a disc
};

// The corners of a cupped leaf about its middle: tips at +-a along e1, sides at +-b along e2,
// the sides raised by `sag` along n (the leaf folded along its midrib, as a cupped one bends).
std::vector<cv::Vec3d> LeafRim(const cv::Vec3d& e1, const cv::Vec3d& e2, const cv::Vec3d& n, double a, double b,
                               double sag) {
  return {a * e1, b * e2 + sag * n, -a * e1, -b * e2 + sag * n};
}

// The two triangles of a cupped leaf, split along the midrib (tip to tip).
std::vector<std::array<cv::Vec3d, 3>> LeafTriangles(const PovLeaf& l) {
  return {{l.c + l.rim[0], l.c + l.rim[1], l.c + l.rim[2]}, {l.c + l.rim[0], l.c + l.rim[2], l.c + l.rim[3]}};
}

// A flat leaf's farthest point from `centre` (its rim at 64 points).
double LeafReach(const PovLeaf& l, const cv::Vec3d& centre) {
  const cv::Vec3d e2 = l.n.cross(l.e1);
  double far = 0;
  for (int j = 0; j < 64; ++j) {
    const double phi = 2 * kPi * j / 64;
    far = std::max(far, cv::norm(l.c + l.a * std::cos(phi) * l.e1 + l.b * std::sin(phi) * e2 - centre));
  }
  return far;
}

// The garden hedge of POV-Ray: real leaves, where hedgefit's own renderer has a noise-shaded
// shell. Discs of radius 6-10 mm tilted up to 55 degrees from the surface, a third of them
// clipped to touch the envelope (a clipped boxwood), the rest spread through the shell's depth,
// about 3.5 layers deep so gaps show the dark inside. Leaves facing away from the camera are
// left out (the inside body still casts the ball's shadow).
//
// Shaped leaves (LeafShape: elongated or cupped) are of the preset's size (0.75-1.25 of it):
// flat ones elliptic discs, cupped ones lozenges of the ellipse's area folded by `cup` (one way or
// the other at random), placed so that the farthest point from the centre lies exactly at R - L d
// (a triangle's farthest point is a vertex).
std::vector<PovLeaf> GardenLeaves(const GardenHedge& g, const cv::Vec3d& centre, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> uni;
  const LeafShape& shape = g.leaf;
  const bool disc = shape.width_ratio == 1 && shape.cup == 0;
  const double R = g.radius_mm, L = g.leaf_depth_mm, layers = shape.layers, a_mean = shape.size_mm / 2;
  const cv::Vec3d to_cam = -centre / cv::norm(centre);
  const auto n = static_cast<std::size_t>(layers * 4 * R * R / (a_mean * a_mean * shape.width_ratio));
  std::vector<PovLeaf> leaves;
  leaves.reserve(n * 2 / 3);
  for (std::size_t k = 0; k < n; ++k) {
    const cv::Vec3d u = cv::normalize(cv::Vec3d(gauss(rng), gauss(rng), gauss(rng)));
    const double a = a_mean * (0.75 + 0.5 * uni(rng)), tilt = 55 * kPi / 180 * std::sqrt(uni(rng));
    const double clipped = uni(rng), deep = uni(rng), hue = uni(rng);
    const cv::Vec3d w = cv::normalize(cv::Vec3d(gauss(rng), gauss(rng), gauss(rng)).cross(u));
    if (u.dot(to_cam) < -0.3) continue;
    const double d = clipped < shape.clipped_share ? 0.0 : std::pow(deep, 1.3);
    PovLeaf leaf;
    leaf.a = a;
    leaf.n = std::cos(tilt) * u + std::sin(tilt) * w;
    leaf.texture = std::min(2, static_cast<int>(d * 3)) * 3 + std::min(2, static_cast<int>(hue * 3));
    leaf.b = a;
    if (disc) {
      leaf.c = centre + (R - a * std::sin(tilt) - L * d) * u;  // its rim reaches R - L d
    } else {
      const double spin = 2 * kPi * uni(rng), sign = uni(rng) < 0.5 ? -1.0 : 1.0;
      const cv::Vec3d t1 = cv::normalize(w.cross(leaf.n)), t2 = leaf.n.cross(t1);
      leaf.e1 = std::cos(spin) * t1 + std::sin(spin) * t2;
      leaf.b = a * shape.width_ratio;
      if (shape.cup > 0) {  // a lozenge has 2 / pi of its ellipse's area
        const double stretch = std::sqrt(kPi / 2);
        leaf.rim = LeafRim(leaf.e1, leaf.n.cross(leaf.e1), leaf.n, stretch * a, stretch * leaf.b, sign * shape.cup * 2 * a);
      }
      leaf.c = centre + (R - L * d) * u;
      for (int it = 0; it < 3; ++it) {  // the farthest point onto R - L d (converges in two)
        double far = cv::norm(leaf.c - centre);
        if (leaf.rim.empty()) far = LeafReach(leaf, centre);
        for (const cv::Vec3d& v : leaf.rim) far = std::max(far, cv::norm(leaf.c + v - centre));
        leaf.c -= (far - (R - L * d)) * u;
      }
    }
    leaves.push_back(leaf);
  }
  return leaves;
}

// The body inside the leaves: dark twigs, seen through the gaps.
double InnerRadius(const GardenHedge& g) { return g.radius_mm - g.leaf_depth_mm - 8; }

// The mean leaf-surface radius of a POV-Ray hedge: radial rays from outside, over the part of the
// ball the leaves cover, the first leaf (or the inner body) each meets.
double PovLeafSurfaceRadius(const GardenHedge& g, const cv::Vec3d& centre, const std::vector<PovLeaf>& leaves) {
  double cell = 16;  // at least the largest leaf's half-length: a leaf over a ray is in a neighbouring cell
  for (const PovLeaf& l : leaves) cell = std::max(cell, l.a);
  auto key = [&](const cv::Vec3d& p) {
    const auto q = [&](double v) { return static_cast<std::int64_t>(std::floor(v / cell)) & 0x1fffff; };
    return (q(p[0]) << 42) | (q(p[1]) << 21) | q(p[2]);
  };
  std::unordered_map<std::int64_t, std::vector<std::size_t>> grid;
  for (std::size_t i = 0; i < leaves.size(); ++i) grid[key(leaves[i].c)].push_back(i);
  const cv::Vec3d to_cam = -centre / cv::norm(centre);
  const int n = 6000;
  double sum = 0;
  int used = 0;
  for (int k = 0; k < n; ++k) {
    const double z = 1 - (2.0 * k + 1) / n, r = std::sqrt(1 - z * z), phi = k * kPi * (3 - std::sqrt(5.0));
    const cv::Vec3d u(r * std::cos(phi), z, r * std::sin(phi));
    if (u.dot(to_cam) < 0) continue;  // well inside the covered part
    double best = InnerRadius(g);
    for (double t = g.radius_mm; t >= InnerRadius(g); t -= cell / 2) {
      const cv::Vec3d p = centre + t * u;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = grid.find(key(p + cell * cv::Vec3d(dx, dy, dz)));
            if (it == grid.end()) continue;
            for (std::size_t i : it->second) {
              const PovLeaf& l = leaves[i];
              if (!l.rim.empty()) {  // a mesh: its triangles (Moller-Trumbore along the radial ray)
                for (const auto& tri : LeafTriangles(l)) {
                  const cv::Vec3d e1 = tri[1] - tri[0], e2 = tri[2] - tri[0], pv = u.cross(e2);
                  const double det = e1.dot(pv);
                  if (std::abs(det) < 1e-12) continue;
                  const cv::Vec3d tv = centre - tri[0];
                  const double bu = tv.dot(pv) / det;
                  const cv::Vec3d qv = tv.cross(e1);
                  const double bv = u.dot(qv) / det, rr = e2.dot(qv) / det;
                  if (bu >= 0 && bv >= 0 && bu + bv <= 1 && rr > best) best = rr;
                }
                continue;
              }
              const double den = l.n.dot(u);
              if (std::abs(den) < 1e-9) continue;
              const double rr = l.n.dot(l.c - centre) / den;
              if (rr <= best) continue;
              const cv::Vec3d q = centre + rr * u - l.c;
              const double x = q.dot(l.e1) / l.a, y = (q - q.dot(l.e1) * l.e1).dot(l.n.cross(l.e1)) / l.b;
              if (l.a == l.b ? cv::norm(q) <= l.a : x * x + y * y <= 1) best = rr;
            }
          }
    }
    sum += best;
    ++used;
  }
  return sum / std::max(1, used);
}

}  // namespace

namespace {

// POV-Ray's matrix taking x, y, z to e1, e2, e3 and the origin to t (each in OpenCV's frame).
std::string MatrixRows(const cv::Vec3d& e1, const cv::Vec3d& e2, const cv::Vec3d& e3, const cv::Vec3d& t) {
  auto row = [](const cv::Vec3d& v) { return Pov(v).substr(1, Pov(v).size() - 2); };
  return "<" + row(e1) + ", " + row(e2) + ", " + row(e3) + ", " + row(t) + ">";
}

// A hedge's leaves in POV-Ray's language: discs (their radius times `disc_scale`), and shaped
// leaves as one mesh (POV-Ray bounds a mesh's triangles itself; a triangle per object would not).
void WriteLeaves(std::ostream& o, const std::vector<PovLeaf>& leaves, double disc_scale) {
  bool mesh = false;
  for (const PovLeaf& l : leaves) {
    if (l.rim.empty() && l.a == l.b) {
      o << "  disc { " << Pov(l.c) << ", " << Pov(l.n) << ", " << l.a * disc_scale << " texture { L" << l.texture
        << " } }\n";
      continue;
    }
    if (l.rim.empty()) {  // an elliptic disc: the unit disc scaled, then turned and moved onto the leaf
      const cv::Vec3d e2 = l.n.cross(l.e1);
      o << "  disc { <0, 0, 0>, z, 1 scale <" << l.a * disc_scale << ", " << l.b * disc_scale << ", 1> matrix "
        << MatrixRows(l.e1, e2, l.n, l.c) << " texture { L" << l.texture << " } }\n";
      continue;
    }
    if (!mesh) o << "  mesh {\n", mesh = true;
    for (const auto& t : LeafTriangles(l)) {
      o << "    triangle { " << Pov(t[0]) << ", " << Pov(t[1]) << ", " << Pov(t[2]) << " texture { L" << l.texture
        << " } }\n";
    }
  }
  if (mesh) o << "  }\n";
}

// The depth render's scale: a grey level is kDepthRangeMm / 65535 (0.12 mm) of distance from the
// camera's centre; farther (the trees) saturates.
constexpr double kDepthRangeMm = 8000;

// The garden; with `depth`, every surface's texture is its distance from the camera (no light,
// no sky) for RenderPovrayGardenSurface.
std::string GardenSceneText(const SimRig& rig, bool right, const GardenScene& sc, cv::Size canvas, bool depth) {
  const cv::Matx44d pose = GardenLevelFromCameraPose(sc);  // the camera in the garden
  const cv::Matx33d garden_from_camera = pose.get_minor<3, 3>(0, 0);
  const cv::Vec3d camera_in_garden(pose(0, 3), pose(1, 3), pose(2, 3));
  const double H = sc.camera_height_mm;  // the lawn: y = H in the level frame
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(2);
  o << "#version 3.7;\nglobal_settings { assumed_gamma 1.0 max_trace_level 6 }\n" << Camera(rig, right, canvas);
  // In the depth render every texture below is this one: the distance from the camera, in the
  // garden's frame (POV-Ray's y is the level frame's -y; a texture moves with its object).
  const std::string dx = "(x - " + std::to_string(camera_in_garden[0]) + ")",
                    dy = "(y + " + std::to_string(camera_in_garden[1]) + ")",
                    dz = "(z - " + std::to_string(camera_in_garden[2]) + ")";
  const std::string depth_texture = "texture { pigment { function { sqrt(" + dx + " * " + dx + " + " + dy + " * " + dy +
                                    " + " + dz + " * " + dz + ") / " + std::to_string(kDepthRangeMm) +
                                    " } color_map { [0 rgb 0] [1 rgb 1] } } finish { ambient 1 diffuse 0 } }";
  auto tex = [&](const std::string& texture) { return depth ? depth_texture : texture; };
  if (!depth) o << "sky_sphere { pigment { gradient y color_map { [0.0 rgb <0.80, 0.85, 0.92>] [0.25 rgb <0.50, 0.66, 0.90>]\n"
       "  [1.0 rgb <0.30, 0.45, 0.82>] } } }\n";
  // Leaf textures: three depth bands (the deeper, the darker) x three greens; boxwood is glossy.
  const double band[3] = {1.0, 0.72, 0.5};
  const cv::Vec3d hue[3] = {{0.06, 0.19, 0.035}, {0.09, 0.25, 0.045}, {0.16, 0.33, 0.07}};
  for (int b = 0; b < 3; ++b)
    for (int h = 0; h < 3; ++h) {
      const cv::Vec3d c = hue[h] * band[b];
      std::ostringstream leaf;
      leaf << "texture { pigment { rgb <" << c[2] << ", " << c[1] << ", " << c[0]
           << "> } normal { wrinkles 0.25 scale 4 } finish { ambient 0.10 diffuse 0.75 specular 0.25 roughness 0.015 } }";
      o << "#declare L" << b * 3 + h << " = " << tex(leaf.str()) << "\n";
    }
  o.precision(6);
  // Everything below is written in the level frame and turned into the camera's by one matrix.
  o << "union {\n";
  // A low sun from the right and behind (hard shadows), and the sky's fill light.
  if (!depth && !sc.overcast) {
    o << "  light_source { " << Pov(cv::normalize(cv::Vec3d(0.65, -0.6, -0.45)) * 1e7)
      << " color rgb 1.3 parallel point_at <0, 0, 0> }\n";
    o << "  light_source { " << Pov(cv::Vec3d(-3000, -8000, 1000)) << " color rgb 0.22 shadowless }\n";
  } else if (!depth) {
    // Overcast: no sun; the sky lights everything from above and around, without shadows.
    o << "  light_source { " << Pov(cv::Vec3d(0, -1e7, 2e6)) << " color rgb 0.75 shadowless }\n";
    o << "  light_source { " << Pov(cv::Vec3d(-4e6, -3e6, -6e6)) << " color rgb 0.35 shadowless }\n";
    o << "  light_source { " << Pov(cv::Vec3d(5e6, -3e6, -2e6)) << " color rgb 0.3 shadowless }\n";
  }
  // Mown lawn: blades as a fine bumpy pattern (14 mm), mowing stripes 1 m wide; the stripes'
  // scale of 2000 applies to the inner patterns too, hence their 0.007 and 0.005.
  o << "  plane { y, " << -H << "\n    "
    << tex("texture { gradient x texture_map {\n"
           "      [0.5 pigment { bozo turbulence 0.8 octaves 6 lambda 2.5 color_map { [0 rgb <0.04, 0.13, 0.02>]\n"
           "        [0.5 rgb <0.10, 0.27, 0.05>] [1 rgb <0.22, 0.40, 0.09>] } scale 0.007 }\n"
           "        normal { granite 0.5 scale 0.005 } finish { ambient 0.10 diffuse 0.8 } ]\n"
           "      [0.5 pigment { bozo turbulence 0.8 octaves 6 lambda 2.5 color_map { [0 rgb <0.05, 0.16, 0.03>]\n"
           "        [0.5 rgb <0.13, 0.31, 0.06>] [1 rgb <0.26, 0.46, 0.11>] } scale 0.007 }\n"
           "        normal { granite 0.5 scale 0.005 } finish { ambient 0.10 diffuse 0.8 } ] } scale 2000 }")
    << " }\n";
  if (sc.background && !depth) {  // behind every hedge: left out of the depth render
    // A clipped hedge row at 5.3 m, a wooden fence behind it, two round trees.
    o << "  box { <-9000, " << -H << ", 5300>, <9000, " << -H + 1400 << ", 6100>\n"
      << "    texture { pigment { granite turbulence 0.4 color_map { [0 rgb <0.03, 0.10, 0.02>] [0.6 rgb <0.08, 0.24, 0.05>]\n"
      << "      [1 rgb <0.20, 0.36, 0.08>] } scale 40 } normal { bumps 0.9 scale 9 } finish { ambient 0.1 diffuse 0.75 } } }\n";
    o << "  box { <-12000, " << -H << ", 6800>, <12000, " << -H + 1800 << ", 6860>\n"
      << "    texture { pigment { gradient x color_map { [0 rgb <0.30, 0.20, 0.11>] [0.93 rgb <0.42, 0.30, 0.18>]\n"
      << "      [0.95 rgb <0.08, 0.06, 0.04>] [1 rgb <0.08, 0.06, 0.04>] } scale 140 } normal { wood 0.3 scale 30 }\n"
      << "      finish { ambient 0.12 diffuse 0.7 } } }\n";
    const double trees[2][4] = {{-3100, 9400, 1700, 3400}, {2700, 8800, 1500, 3000}};  // x, z, crown r, crown height
    for (const auto& t : trees) {
      o << "  sphere { <" << t[0] << ", " << t[3] - H << ", " << t[1] << ">, " << t[2] << "\n"
        << "    texture { pigment { granite turbulence 0.5 color_map { [0 rgb <0.02, 0.08, 0.02>] [1 rgb <0.15, 0.32, 0.07>] }\n"
        << "      scale 90 } normal { bumps 1.0 scale 25 } finish { ambient 0.1 diffuse 0.7 } } }\n";
      o << "  cylinder { <" << t[0] << ", " << -H << ", " << t[1] << ">, <" << t[0] << ", " << t[3] - H << ", " << t[1]
        << ">, 170 texture { pigment { rgb <0.18, 0.13, 0.09> } normal { bumps 0.6 scale 20 } } }\n";
    }
  }
  if (sc.pot) {
    o << "  cylinder { <" << sc.pot_x_mm << ", " << -H << ", " << sc.pot_z_mm << ">, <" << sc.pot_x_mm << ", " << -H + 380
      << ", " << sc.pot_z_mm << ">, 180\n    "
      << tex("texture { pigment { bozo color_map { [0 rgb <0.45, 0.17, 0.07>] [1 rgb <0.60, 0.26, 0.12>] } scale 20 }\n"
             "      finish { ambient 0.1 diffuse 0.75 } }")
      << " }\n";
  }
  // Other shrubs: the same leaves, one lobe at a time (GardenScene::shrub_lobes), on a dark body.
  for (std::size_t i = 0; i < sc.shrub_lobes.size(); ++i) {
    const GardenHedge& g = sc.shrub_lobes[i];
    const cv::Vec3d c = GardenLevelCenter(sc, g);
    o << "  sphere { " << Pov(c) << ", " << InnerRadius(g) << " "
      << tex("texture { pigment { rgb <0.03, 0.05, 0.02> } finish { ambient 0.05 diffuse 0.6 } }") << " }\n";
    o.precision(2);
    WriteLeaves(o, GardenLeaves(g, c, sc.texture_seed * 7919 + 500 + i), 1.4);
    o.precision(6);
  }
  for (std::size_t i = 0; i < sc.hedges.size(); ++i) {
    const GardenHedge& g = sc.hedges[i];
    const cv::Vec3d c = GardenLevelCenter(sc, g);
    std::vector<std::pair<cv::Vec3d, GardenHedge>> balls{{c, g}};
    if (const auto bulge = GardenBulge(g, c)) {  // the same leaves on a ball of its own
      GardenHedge b = g;
      b.radius_mm = bulge->second;
      balls.emplace_back(bulge->first, b);
    }
    for (std::size_t k = 0; k < balls.size(); ++k) {
      o << "  sphere { " << Pov(balls[k].first) << ", " << InnerRadius(balls[k].second) << " "
        << tex("texture { pigment { granite color_map { [0 rgb <0.02, 0.03, 0.01>] [1 rgb <0.06, 0.09, 0.03>] } scale 15 }"
               " finish { ambient 0.05 diffuse 0.6 } }")
        << " }\n";
      o.precision(2);
      WriteLeaves(o, GardenLeaves(balls[k].second, balls[k].first, sc.texture_seed * 7919 + i + 977 * k), 1.0);
      o.precision(6);
    }
  }
  const cv::Matx33d camera_from_garden = garden_from_camera.t();
  o << "  " << Matrix(camera_from_garden, -(camera_from_garden * camera_in_garden)) << "\n}\n";
  return o.str();
}

}  // namespace

std::string PovrayGardenScene(const SimRig& rig, bool right, const GardenScene& sc, cv::Size canvas) {
  return GardenSceneText(rig, right, sc, canvas, false);
}

cv::Mat RenderPovrayGardenSurface(const SimRig& rig, const GardenScene& sc, const std::string& work_dir) {
  const cv::Mat grey = RenderPovrayText(
      rig, false, [&](cv::Size canvas) { return GardenSceneText(rig, false, sc, canvas, true); }, work_dir, true);
  if (grey.depth() != CV_16U) throw Error(work_dir + ": POV-Ray's depth render is not 16-bit");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat out(grey.size(), CV_32FC3, cv::Scalar(nan, nan, nan));
  const cv::Matx33d K_inv = rig.left.K.inv();
  for (int v = 0; v < grey.rows; ++v) {
    for (int u = 0; u < grey.cols; ++u) {
      const cv::Vec3w g = grey.channels() == 3 ? grey.at<cv::Vec3w>(v, u) : cv::Vec3w::all(grey.at<std::uint16_t>(v, u));
      if (g[1] == 0 || g[1] == 65535) continue;  // nothing hit, or beyond the range
      const double d = g[1] * kDepthRangeMm / 65535.0;
      const cv::Vec3d ray = cv::normalize(K_inv * cv::Vec3d(u, v, 1));
      out.at<cv::Vec3f>(v, u) = cv::Vec3f(float(d * ray[0]), float(d * ray[1]), float(d * ray[2]));
    }
  }
  return out;
}

cv::Mat RenderPovrayGarden(const SimRig& rig, bool right, const GardenScene& sc, const std::string& work_dir) {
  return RenderPovrayText(
      rig, right, [&](cv::Size canvas) { return PovrayGardenScene(rig, right, sc, canvas); }, work_dir);
}

std::vector<std::string> WritePovrayGarden(const std::string& dir, double scale, const CameraModel& camera,
                                           const std::vector<std::string>& presets, std::uint64_t seed) {
  const SimRig rig = PovrayRig(scale);
  std::uint64_t view = seed * 1000 + 800;
  return WriteGardenWith(
      dir, rig, presets,
      [&](const GardenScene& sc, bool right) {
        const cv::Mat img = RenderPovrayText(
            rig, right, [&](cv::Size canvas) { return PovrayGardenScene(rig, right, sc, canvas); }, dir);
        return ApplyCameraModel(img, camera, right, view++ / 2);
      },
      [](const GardenScene& sc, std::size_t i) {
        const cv::Vec3d c = GardenLevelCenter(sc, sc.hedges[i]);
        return PovLeafSurfaceRadius(sc.hedges[i], c, GardenLeaves(sc.hedges[i], c, sc.texture_seed * 7919 + i));
      });
}

}  // namespace hedgefit::sim
