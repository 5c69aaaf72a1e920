#include "sim/simulate.hpp"

#include <algorithm>
#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <filesystem>

#include "pipeline/error.hpp"
#include "sim/camera_model.hpp"
#include "sim/povray.hpp"
#include "sim/simulator.hpp"
#include "sim/single_scene.hpp"

namespace hedgefit::sim {

const pipeline::OptionTable<SimulateRequest>& SimulateRequest::Table() {
  using R = SimulateRequest;
  static const auto table =
      pipeline::OptionTable<R>()
          .Add("preset", &R::preset,
               "paper-lab (the paper's lab: boards and spheres), garden (leafy hedge balls on a lawn), garden-leaves "
               "(boxwood, yew, privet and holly, each in sun and as an overcast dome) or wide-boards (12 more board "
               "pairs near the image's edges, board_17..board_28, for calibration)")
          .Choices({"", "paper-lab", "garden", "garden-leaves", "wide-boards"})
          .Add("renderer", &R::renderer,
               "the presets' renderer: hedgefit (its own ray caster) or povray (POV-Ray, an independent one)")
          .Choices({"hedgefit", "povray"})
          .Add("sphere", &R::sphere, "render a sphere: X,Y,Z,R in mm (left camera frame)")
          .Add("board", &R::board, "render a board (see --squares, --square): RX,RY,RZ (rad),TX,TY,TZ (mm)")
          .Add("squares", &R::squares, "board squares COLSxROWS (inner corners are one fewer each way)")
          .Add("charuco", &R::charuco,
               "make the board a ChArUco board of this ArUco dictionary (4x4_50 .. 7x7_1000), for `calibrate --charuco`")
          .Add("marker", &R::marker, "ChArUco marker side (0 = 0.75 square)", "mm")
          .Min(0)
          .Add("square", &R::square, "board square size", "mm")
          .Range(1, 1000)
          .Add("output", &R::output, "output directory")
          .Add("scale", &R::scale, "image scale (0.25 renders 480x300)")
          .Range(0.05, 4)
          .Add("supersample", &R::supersample, "rays per pixel per axis")
          .Range(1, 8)
          .Add("blur", &R::blur, "Gaussian blur sigma", "px")
          .Range(0, 10)
          .Add("noise", &R::noise, "sensor noise sigma", "grey levels")
          .Range(0, 100)
          .Add("seed", &R::seed, "noise seed")
          .Min(0)
          .Add("camera", &R::camera,
               "ideal (as rendered) or real: each image as a camera records it (exposure and white balance per "
               "camera, vignetting, Bayer + demosaicing, shot and read noise independent per camera)")
          .Choices({"ideal", "real"})
          .Add("jpeg", &R::jpeg, "also compress every image as JPEG of this quality (1-100; 0 = lossless)")
          .Range(0, 100);
  return table;
}

namespace {

std::string Line(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string Line(const char* fmt, ...) {
  char buf[1024];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof(buf), fmt, args);
  va_end(args);
  return buf;
}

}  // namespace

std::string Simulate(const SimulateRequest& r) {
  SimulateRequest::Table().Validate(r);
  const int modes = !r.preset.empty() + !r.sphere.empty() + !r.board.empty();
  if (modes != 1) throw Error("give exactly one of option 'preset', option 'sphere' or option 'board'");
  if (r.renderer == "povray" && r.preset.empty()) {
    throw Error("option 'renderer' povray: renders the presets (paper-lab, garden, wide-boards); drop it for option "
                "'sphere' or option 'board'");
  }
  RenderOptions ro;
  ro.supersample = r.supersample;
  ro.blur_sigma_px = r.blur;
  ro.noise_sigma = r.noise;
  ro.seed = std::uint64_t(r.seed);
  // Every argument is checked before anything is created or written.
  SphereScene sc;
  BoardScene b;
  auto count = [](const char* name, const std::vector<double>& v, std::size_t n) {
    if (v.empty() || v.size() == n) return;
    std::string text;
    for (const double x : v) text += Line(text.empty() ? "%g" : ",%g", x);
    throw Error(Line("option '%s' '%s': expected %zu comma-separated numbers", name, text.c_str(), n));
  };
  count("sphere", r.sphere, 4);
  count("board", r.board, 6);
  if (!r.sphere.empty()) {
    if (!(r.sphere[3] > 0) || !(r.sphere[2] > r.sphere[3])) {
      throw Error("option 'sphere': need R > 0 and the sphere in front of the camera (Z > R)");
    }
    sc.center = cv::Vec3d(r.sphere[0], r.sphere[1], r.sphere[2]);
    sc.radius = r.sphere[3];
  } else if (!r.board.empty()) {
    int cols = 0, rows = 0;
    char x = 0, extra = 0;
    if (std::sscanf(r.squares.c_str(), "%d%c%d%c", &cols, &x, &rows, &extra) != 3 || (x != 'x' && x != 'X') ||
        cols < 3 || rows < 3) {
      throw Error("option 'squares' '" + r.squares + "': give squares as COLSxROWS, each at least 3, e.g. 13x12");
    }
    try {
      b = PosedBoard(r.board, cv::Size(cols, rows), r.square, r.charuco, r.marker);
    } catch (const Error& e) {
      // The board's check says "marker: ..." or "dictionary: ...": name the request's option.
      const std::string m = e.what();
      const std::string name = m.rfind("dictionary:", 0) == 0 ? "charuco" : m.substr(0, m.find(':'));
      throw Error("option '" + name + "'" + m.substr(std::min(m.size(), m.find(':'))));
    }
  }
  std::error_code ec;
  std::filesystem::create_directories(r.output, ec);
  if (!std::filesystem::is_directory(r.output, ec)) throw Error(r.output + ": cannot create the output directory");
  CameraModel camera = r.camera == "real" ? CameraModel() : CameraModel::Ideal();
  camera.jpeg_quality = r.jpeg;
  const bool recorded = r.camera == "real" || r.jpeg > 0;
  const std::uint64_t seed = std::uint64_t(r.seed);
  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  const char* out = r.output.c_str();
  if (r.preset == "garden" || r.preset == "garden-leaves") {
    const auto names = r.preset == "garden" ? GardenPresetNames() : GardenLeafPresetNames();
    std::vector<std::string> files;
    if (r.renderer == "povray") {
      files = WritePovrayGarden(r.output, r.scale, camera, names, seed);
    } else {
      files = WriteGarden(r.output, r.scale, ro, names);
      if (recorded) RecordAsCamera(files, camera, seed);
    }
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "garden_" : ", garden_") + n;
    return Line("wrote %zu files to %s in %.1f s (%zu garden captures: %s)", files.size(), out, seconds(),
                names.size(), list.c_str());
  }
  if (r.preset == "wide-boards") {
    // Into the lab's directory beside board_01..16, or a directory of their own.
    WriteWideBoards(r.output, r.renderer, r.scale, ro, camera, seed);
    return Line("wrote 12 board pairs (board_17..board_28) to %s in %.1f s", out, seconds());
  }
  if (!r.preset.empty()) {
    std::vector<std::string> files;
    if (r.renderer == "povray") {
      files = WritePovrayLab(r.output, r.scale, camera, seed);
    } else {
      files = WritePaperLab(r.output, r.scale, ro);
      if (recorded) RecordAsCamera(files, camera, seed);
    }
    return Line("wrote %zu files to %s in %.1f s (23 pairs%s, %.2f s per pair)", files.size(), out, seconds(),
                r.renderer == "povray" ? " by POV-Ray" : "", seconds() / 23.0);
  }
  const SimRig rig = PaperRig(r.scale);
  if (!r.sphere.empty()) {
    WriteSphereCapture(r.output, rig, sc, ro, camera, recorded, seed);
  } else {
    WriteBoardCapture(r.output, rig, b, ro, camera, recorded, seed);
  }
  return Line("wrote a %dx%d pair to %s in %.2f s", rig.left.size.width, rig.left.size.height, out, seconds());
}

}  // namespace hedgefit::sim
