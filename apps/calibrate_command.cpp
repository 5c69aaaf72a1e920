// hedgefit calibrate: stereo calibration from chessboard pairs -> rig YAML. The work is
// stereo::CalibrateWithReport (stereo/calibration_report.hpp).

#include <iostream>

#include "cli/capture_flags.hpp"
#include "apps/commands.hpp"
#include "pipeline/output_check.hpp"
#include "cli/parse.hpp"
#include "stereo/calibration_report.hpp"
#include "stereo/image_io.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::apps {

namespace {

struct CalibrateArgs {
  std::string left, right, list, board = "9x6", model = "k1k2p1p2k3", output = "rig.yaml", coverage, charuco,
      dictionary = "5x5_100";
  double marker = 0;
  double square = 1.0, alpha = stereo::CalibrationOptions{}.alpha, reject = 3.0;
  bool fix_pp = false, fix_aspect = false, json = false, keep_intrinsics = false;
};

// The options first: a bad --board fails before any file is touched.
stereo::CalibrationOptions Options(const CalibrateArgs& a) {
  stereo::CalibrationOptions o;
  if (!a.charuco.empty()) {
    const auto [w, h] = ParseCount2(a.charuco, "--charuco", 3, "squares as COLSxROWS", "12x9");
    o.board.inner_corners = cv::Size(w - 1, h - 1);
    o.board.type = stereo::BoardType::kCharuco;
    o.board.marker_mm = a.marker;
    o.board.dictionary = a.dictionary;
  } else {
    const auto [w, h] = ParseCount2(a.board, "--board", 2, "inner corners as COLSxROWS", "9x6");
    o.board.inner_corners = cv::Size(w, h);
  }
  o.board.square_mm = a.square;
  o.model = a.model == "k1k2p1p2"   ? stereo::DistortionModel::kK1K2P1P2
            : a.model == "rational" ? stereo::DistortionModel::kRational
                                    : stereo::DistortionModel::kK1K2P1P2K3;
  o.fix_principal_point = a.fix_pp;
  o.fix_aspect_ratio = a.fix_aspect;
  o.alpha = a.alpha;
  o.reject_factor = a.reject;
  o.refine_intrinsics = !a.keep_intrinsics;
  try {
    o.Check();
  } catch (const Error& e) {
    throw Error(std::string("--") + e.what());
  }
  return o;
}

int RunCalibrate(const CalibrateArgs& a) {
  const stereo::CalibrationOptions o = Options(a);
  if (!a.coverage.empty()) pipeline::CheckImageOutput("--coverage", a.coverage, {".png", ".jpg", ".jpeg"});
  if (a.list.empty() && (a.left.empty() || a.right.empty())) throw Error("give --left and --right globs, or --list FILE");
  const auto pairs = a.list.empty() ? stereo::PairsFromGlobs(a.left, a.right) : stereo::ReadPairList(a.list);
  const stereo::CalibrationReport r = stereo::CalibrateWithReport(pairs, o, a.json ? nullptr : &std::cerr);
  if (!a.coverage.empty()) stereo::WriteImageAtomic(a.coverage, r.coverage_picture);
  stereo::WriteRig(a.output, r.rig);
  if (a.json) {
    std::cout << stereo::CalibrationReportJson(r, a.output) << "\n";
    for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
    return kExitOk;
  }
  stereo::PrintCalibrationReport(std::cout, r, a.coverage);
  std::cout << "wrote " << a.output << "\n";
  return kExitOk;
}

}  // namespace

void AddCalibrateCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("calibrate", "Stereo calibration from chessboard pairs: Zhang per camera, stereo, Bouguet rectification");
  cmd->footer(
      "Examples:\n"
      "  hedgefit calibrate --left 'data/calib_chessboard/left*.jpg' \\\n"
      "      --right 'data/calib_chessboard/right*.jpg' --board 9x6 --square 1 -o build/opencv_rig.yaml\n"
      "  hedgefit calibrate --list pairs.txt --board 12x11 --square 30 --model rational -o rig.yaml --json\n"
      "  hedgefit calibrate --left 'l*.png' --right 'r*.png' --charuco 12x9 --square 40 --marker 30 -o rig.yaml\n"
      "Pairs are matched by sorted order; a list file has one 'LEFT RIGHT' pair per line.\n");
  auto a = std::make_shared<CalibrateArgs>();
  cmd->add_option("--left", a->left, "glob of left images (quote it)");
  cmd->add_option("--right", a->right, "glob of right images");
  cmd->add_option("--list", a->list, "file of 'LEFT RIGHT' lines instead of --left/--right");
  auto* board_opt = cmd->add_option("--board", a->board, "chessboard: inner corners COLSxROWS")->capture_default_str();
  cmd->add_option("--charuco", a->charuco,
                  "a ChArUco board instead: squares COLSxROWS (as cv::aruco::CharucoBoard::create); partly seen boards count")
      ->excludes(board_opt);
  cmd->add_option("--marker", a->marker, "ChArUco: marker side, in --square's unit (0 = 0.75 square)")->capture_default_str();
  cmd->add_option("--dictionary", a->dictionary, "ChArUco: ArUco dictionary, 4x4_50 .. 7x7_1000")->capture_default_str();
  cmd->add_option("--square", a->square, "square size (mm, or the unit the rig should use)")->capture_default_str();
  cmd->add_option("--model", a->model, "distortion: k1k2p1p2, k1k2p1p2k3 or rational")
      ->check(CLI::IsMember({"k1k2p1p2", "k1k2p1p2k3", "rational"}))
      ->capture_default_str();
  cmd->add_flag("--fix-principal-point", a->fix_pp, "keep cx, cy at the image centre");
  cmd->add_flag("--fix-aspect", a->fix_aspect, "fx = fy");
  cmd->add_option("--alpha", a->alpha, "rectification scaling: 0 crop to valid pixels, 1 keep all, -1 OpenCV's default")->capture_default_str();
  cmd->add_option("--reject-factor", a->reject, "reject pairs above this many times the median RMS, then recalibrate (0 = never)")
      ->capture_default_str();
  cmd->add_flag("--keep-intrinsics", a->keep_intrinsics, "do not refine per-camera intrinsics in the stereo step");
  cmd->add_option("-o,--output", a->output, "rig file to write (OpenCV YAML)")->capture_default_str();
  cmd->add_flag("--json", a->json, "print the result as JSON");
  cmd->add_option("--coverage", a->coverage,
                  "also draw where the corners fell in each image (PNG): uncovered cells of an 8 x 8 grid are hatched");
  GroupFlags(cmd, {{"Inputs", {"--left", "--right", "--list"}}, {"Board", {"--board", "--charuco", "--marker", "--dictionary", "--square"}}, {"Calibration", {"--model", "--fix-principal-point", "--fix-aspect", "--alpha", "--reject-factor", "--keep-intrinsics"}}, {"Outputs", {"--output", "--coverage"}}, {"Output format", {"--json"}}});
  cmd->callback([=]() { *run = [=]() { return RunCalibrate(*a); }; });
}

}  // namespace hedgefit::apps
