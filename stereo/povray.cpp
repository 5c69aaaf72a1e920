#include "stereo/povray.hpp"
#include "stereo/stereo_stages.hpp"

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cloud/cloud_io.hpp"
#include "cloud/error.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

namespace {

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

cv::Mat RenderPovray(const SimRig& rig, bool right, const std::string& kind, const BoardScene& board,
                     const SphereScene& sphere, const std::string& work_dir) {
  namespace fs = std::filesystem;
  if (!HavePovray()) throw Error("povray: not found; install Debian's povray package (scripts/setup.sh does)");
  const SimCamera& cam = right ? rig.right : rig.left;
  const Canvas canvas = CanvasOf(cam);
  const std::string scene =
      kind == "board" ? PovrayBoardScene(rig, right, board, canvas.size) : PovraySphereScene(rig, right, sphere, canvas.size);
  const std::string stem = (fs::path(work_dir) / (std::string(".pov_") + (right ? "right" : "left"))).string();
  cloud::WriteTextFileAtomic(stem + ".pov", scene);
  // Adaptive anti-aliasing (method 2, threshold 0.05, depth 3), both cores, no display.
  std::ostringstream cmd;
  cmd << "cd '" << work_dir << "' && povray +I'" << fs::path(stem).filename().string() << ".pov' +O'"
      << fs::path(stem).filename().string() << ".png' +W" << canvas.size.width << " +H" << canvas.size.height
      << " +A0.05 +AM2 +R3 +FN8 +Q9 -D -V -GA +WT2 > '" << fs::path(stem).filename().string() << ".log' 2>&1";
  if (std::system(cmd.str().c_str()) != 0) throw Error(stem + ".log: POV-Ray failed; see its log");
  const cv::Mat full = cv::imread(stem + ".png", cv::IMREAD_COLOR);
  if (full.empty()) throw Error(stem + ".png: POV-Ray wrote no image; see " + stem + ".log");
  // The camera's image within the canvas: its principal point lands where K puts it.
  const int ox = std::abs(canvas.dx) - canvas.dx, oy = std::abs(canvas.dy) - canvas.dy;
  return full(cv::Rect(ox, oy, cam.size.width, cam.size.height)).clone();
}

std::vector<std::string> WritePovrayLab(const std::string& dir, double scale, const CameraModel& camera,
                                        std::uint64_t seed) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec)) throw Error(dir + ": cannot create the output directory");
  const SimRig rig = PovrayRig(scale);
  std::vector<std::string> written;
  cloud::WriteTextFileAtomic((fs::path(dir) / "rig_truth.json").string(), RigJson(rig) + "\n");
  WriteRig((fs::path(dir) / "rig.yaml").string(), RigFromSimulation(rig));
  written.push_back((fs::path(dir) / "rig_truth.json").string());
  std::uint64_t view = seed * 1000;
  auto save = [&](const std::string& name, bool right, const std::string& kind, const BoardScene& b,
                  const SphereScene& s) {
    const cv::Mat img = ApplyCameraModel(RenderPovray(rig, right, kind, b, s, dir), camera, right, view++ / 2);
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

}  // namespace hedgefit::stereo
