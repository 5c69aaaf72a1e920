// hedgefit simulate: render a stereo rig's view of a chessboard or a textured sphere.

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "apps/commands.hpp"
#include "apps/parse.hpp"
#include "sim/camera_model.hpp"
#include "sim/povray.hpp"
#include "sim/simulator.hpp"
#include "sim/single_scene.hpp"

namespace hedgefit::apps {

namespace {

struct SimulateArgs {
  std::string preset, sphere, board, out = "simulated", squares = "13x12", dictionary;
  double square = 30.0, marker = 0;
  double scale = 1.0, blur = 0.5, noise = 0.0;
  int supersample = 3, jpeg = 0;
  std::uint64_t seed = 1;
  std::string camera = "ideal", renderer = "hedgefit";
};


int RunSimulate(const SimulateArgs& a) {
  const int modes = !a.preset.empty() + !a.sphere.empty() + !a.board.empty();
  if (modes != 1) throw Error("give exactly one of --preset, --sphere or --board");
  if (a.renderer == "povray" && a.preset.empty()) {
    throw Error("--renderer povray: renders the presets (paper-lab, garden, wide-boards); drop it for --sphere or --board");
  }
  sim::RenderOptions ro;
  ro.supersample = a.supersample;
  ro.blur_sigma_px = a.blur;
  ro.noise_sigma = a.noise;
  ro.seed = a.seed;
  // Every argument is checked before anything is created or written.
  sim::SphereScene sc;
  sim::BoardScene b;
  if (a.preset.empty() && !a.sphere.empty()) {
    const auto v = ParseNumbers(a.sphere, 4, "--sphere");
    if (!(v[3] > 0) || !(v[2] > v[3])) throw Error("--sphere: need R > 0 and the sphere in front of the camera (Z > R)");
    sc.center = cv::Vec3d(v[0], v[1], v[2]);
    sc.radius = v[3];
  } else if (a.preset.empty()) {
    const auto v = ParseNumbers(a.board, 6, "--board");
    const auto [cols, rows] = ParseCount2(a.squares, "--squares", 3, "squares as COLSxROWS", "13x12");
    try {
      b = sim::PosedBoard(v, cv::Size(cols, rows), a.square, a.dictionary, a.marker);
    } catch (const Error& e) {
      throw Error(std::string("--") + e.what());
    }
  }
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (!std::filesystem::is_directory(a.out, ec)) throw Error(a.out + ": cannot create the output directory");
  sim::CameraModel camera = a.camera == "real" ? sim::CameraModel() : sim::CameraModel::Ideal();
  camera.jpeg_quality = a.jpeg;
  const bool recorded = a.camera == "real" || a.jpeg > 0;
  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  if (a.preset == "garden") {
    const auto names = sim::GardenPresetNames();
    std::vector<std::string> files;
    if (a.renderer == "povray") {
      files = sim::WritePovrayGarden(a.out, a.scale, camera, names, a.seed);
    } else {
      files = sim::WriteGarden(a.out, a.scale, ro, names);
      if (recorded) sim::RecordAsCamera(files, camera, a.seed);
    }
    std::printf("wrote %zu files to %s in %.1f s (%zu garden captures: ", files.size(), a.out.c_str(), seconds(),
                names.size());
    for (std::size_t i = 0; i < names.size(); ++i) std::printf("%s%s", i ? ", " : "", ("garden_" + names[i]).c_str());
    std::printf(")\n");
    return kExitOk;
  }
  if (a.preset == "wide-boards") {
    // Into the lab's directory beside board_01..16, or a directory of their own.
    sim::WriteWideBoards(a.out, a.renderer, a.scale, ro, camera, a.seed);
    std::printf("wrote 12 board pairs (board_17..board_28) to %s in %.1f s\n", a.out.c_str(), seconds());
    return kExitOk;
  }
  if (!a.preset.empty()) {
    std::vector<std::string> files;
    if (a.renderer == "povray") {
      files = sim::WritePovrayLab(a.out, a.scale, camera, a.seed);
    } else {
      files = sim::WritePaperLab(a.out, a.scale, ro);
      if (recorded) sim::RecordAsCamera(files, camera, a.seed);
    }
    std::printf("wrote %zu files to %s in %.1f s (23 pairs%s, %.2f s per pair)\n", files.size(), a.out.c_str(),
                seconds(), a.renderer == "povray" ? " by POV-Ray" : "", seconds() / 23.0);
    return kExitOk;
  }
  const sim::SimRig rig = sim::PaperRig(a.scale);
  if (!a.sphere.empty()) {
    sim::WriteSphereCapture(a.out, rig, sc, ro, camera, recorded, a.seed);
  } else {
    sim::WriteBoardCapture(a.out, rig, b, ro, camera, recorded, a.seed);
  }
  std::printf("wrote a %dx%d pair to %s in %.2f s\n", rig.left.size.width, rig.left.size.height, a.out.c_str(),
              seconds());
  return kExitOk;
}

}  // namespace

void AddSimulateCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("simulate", "Render a simulated stereo rig's view of a chessboard or a textured sphere, with truth");
  cmd->footer(
      "Examples:\n"
      "  hedgefit simulate --preset paper-lab -o build/lab          # 16 board pairs + spheres at Z = 2000..2600 mm\n"
      "  hedgefit simulate --sphere 70,50,2300,300 -o build/sphere  # one capture, centre x,y,z and radius (mm)\n"
      "  hedgefit simulate --board 0.3,0.2,0,-150,-150,1200 -o build/board   # rotation vector (rad), translation (mm)\n"
      "  hedgefit simulate --board 0.2,-0.3,0,-200,-150,900 --squares 8x6 --square 60 --charuco 4x4_50 --marker 45 -o build/charuco\n"
      "  hedgefit simulate --preset garden -o build/garden         # leafy balls on a lawn: row, single, outdoor\n"
      "  hedgefit simulate --preset garden --renderer povray --camera real -o build/garden-povray   # leaf discs, POV-Ray\n"
      "The rig is the paper's (1920x1200, f 933.3 px, baseline 140 mm); --scale shrinks it.\n");
  auto a = std::make_shared<SimulateArgs>();
  cmd->add_option("--preset", a->preset,
                  "paper-lab (the paper's lab: boards and spheres), garden (leafy hedge balls on a lawn) or wide-boards "
                  "(12 more board pairs near the image's edges, board_17..board_28, for calibration)")
      ->check(CLI::IsMember({"paper-lab", "garden", "wide-boards"}));
  cmd->add_option("--renderer", a->renderer, "the presets' renderer: hedgefit (its own ray caster) or povray (POV-Ray, an independent one)")
      ->check(CLI::IsMember({"hedgefit", "povray"}))
      ->capture_default_str();
  cmd->add_option("--sphere", a->sphere, "render a sphere: X,Y,Z,R in mm (left camera frame)");
  cmd->add_option("--board", a->board, "render a board (see --squares, --square): RX,RY,RZ (rad),TX,TY,TZ (mm)");
  cmd->add_option("--squares", a->squares, "board squares COLSxROWS (inner corners are one fewer each way)")
      ->capture_default_str();
  cmd->add_option("--charuco", a->dictionary,
                  "make the board a ChArUco board of this ArUco dictionary (4x4_50 .. 7x7_1000), for `calibrate --charuco`");
  cmd->add_option("--marker", a->marker, "ChArUco marker side, mm (0 = 0.75 square)")->capture_default_str();
  cmd->add_option("--square", a->square, "board square size, mm")->check(CLI::Range(1.0, 1000.0))->capture_default_str();
  cmd->add_option("-o,--output", a->out, "output directory")->capture_default_str();
  cmd->add_option("--scale", a->scale, "image scale (0.25 renders 480x300)")->check(CLI::Range(0.05, 4.0))->capture_default_str();
  cmd->add_option("--supersample", a->supersample, "rays per pixel per axis")->check(CLI::Range(1, 8))->capture_default_str();
  cmd->add_option("--blur", a->blur, "Gaussian blur sigma, px")->check(CLI::Range(0.0, 10.0))->capture_default_str();
  cmd->add_option("--noise", a->noise, "sensor noise sigma, grey levels")->check(CLI::Range(0.0, 100.0))->capture_default_str();
  cmd->add_option("--seed", a->seed, "noise seed")->check(Seed())->capture_default_str();
  cmd->add_option("--camera", a->camera,
                  "ideal (as rendered) or real: each image as a camera records it (exposure and white balance per "
                  "camera, vignetting, Bayer + demosaicing, shot and read noise independent per camera)")
      ->check(CLI::IsMember({"ideal", "real"}))
      ->capture_default_str();
  cmd->add_option("--jpeg", a->jpeg, "also compress every image as JPEG of this quality (1-100; 0 = lossless)")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  GroupFlags(cmd, {{"Scene", {"--preset", "--renderer", "--sphere", "--board", "--squares", "--charuco", "--marker", "--square"}}, {"Camera", {"--scale", "--supersample", "--blur", "--noise", "--seed", "--camera", "--jpeg"}}, {"Output", {"--output"}}});
  cmd->callback([=]() { *run = [=]() { return RunSimulate(*a); }; });
}

}  // namespace hedgefit::apps
