// hedgefit calibrate: stereo calibration from chessboard pairs -> rig YAML.

#include <glob.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <optional>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "apps/capture_flags.hpp"
#include "apps/commands.hpp"
#include "apps/parse.hpp"
#include "stereo/calibration.hpp"
#include "stereo/rig.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::apps {

namespace {

// The principal point's standard deviation above which `calibrate` warns (px): 0.2 px moves a
// hedge about 0.5 mm sideways at 2.3 m on the paper's rig.
constexpr double kPrincipalPointWarnPx = 0.2;

std::vector<std::string> Glob(const std::string& pattern, const char* option) {
  glob_t g{};
  std::vector<std::string> out;
  if (glob(pattern.c_str(), 0, nullptr, &g) == 0) {
    for (std::size_t i = 0; i < g.gl_pathc; ++i) out.emplace_back(g.gl_pathv[i]);
  }
  globfree(&g);
  if (out.empty()) throw Error(std::string(option) + " '" + pattern + "': no file matches; check the pattern (quote it)");
  return out;  // glob() sorts
}

cv::Size ParseBoard(const std::string& text) {
  const auto [w, h] = ParseCount2(text, "--board", 2, "inner corners as COLSxROWS", "9x6");
  return {w, h};
}

}  // namespace

void AddCalibrateCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("calibrate", "Stereo calibration from chessboard pairs: Zhang per camera, stereo, Bouguet rectification");
  cmd->footer(
      "Examples:\n"
      "  hedgefit calibrate --left '../shared/data/calib_chessboard/left*.jpg' \\\n"
      "      --right '../shared/data/calib_chessboard/right*.jpg' --board 9x6 --square 1 -o build/opencv_rig.yaml\n"
      "  hedgefit calibrate --list pairs.txt --board 12x11 --square 30 --model rational -o rig.yaml --json\n"
      "  hedgefit calibrate --left 'l*.png' --right 'r*.png' --charuco 12x9 --square 40 --marker 30 -o rig.yaml\n"
      "Pairs are matched by sorted order; a list file has one 'LEFT RIGHT' pair per line.\n");
  struct Args {
    std::string left, right, list, board = "9x6", model = "k1k2p1p2k3", output = "rig.yaml", coverage, charuco,
        dictionary = "5x5_100";
    double marker = 0;
    double square = 1.0, alpha = stereo::CalibrationOptions{}.alpha, reject = 3.0;
    bool fix_pp = false, fix_aspect = false, json = false, keep_intrinsics = false;
  };
  auto a = std::make_shared<Args>();
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
  cmd->callback([=]() {
    *run = [=]() {
      // Options first: a bad --board fails before any file is touched.
      stereo::CalibrationOptions o;
      if (!a->charuco.empty()) {
        const auto [w, h] = ParseCount2(a->charuco, "--charuco", 3, "squares as COLSxROWS", "12x9");
        o.board.inner_corners = cv::Size(w - 1, h - 1);
        o.board.type = stereo::BoardType::kCharuco;
        o.board.marker_mm = a->marker;
        o.board.dictionary = a->dictionary;
      } else {
        o.board.inner_corners = ParseBoard(a->board);
      }
      o.board.square_mm = a->square;
      o.model = a->model == "k1k2p1p2"     ? stereo::DistortionModel::kK1K2P1P2
                : a->model == "rational" ? stereo::DistortionModel::kRational
                                         : stereo::DistortionModel::kK1K2P1P2K3;
      o.fix_principal_point = a->fix_pp;
      o.fix_aspect_ratio = a->fix_aspect;
      o.alpha = a->alpha;
      o.reject_factor = a->reject;
      o.refine_intrinsics = !a->keep_intrinsics;
      if (!a->coverage.empty()) CheckImageOutput("--coverage", a->coverage, {".png", ".jpg", ".jpeg"});
      try {
        o.Check();
      } catch (const Error& e) {
        throw Error(std::string("--") + e.what());
      }
      std::vector<std::pair<std::string, std::string>> pairs;
      if (!a->list.empty()) {
        std::ifstream in(a->list);
        if (!in) throw Error(a->list + ": cannot open the pair list");
        std::string line;
        int n = 0;
        while (std::getline(in, line)) {
          ++n;
          std::istringstream ss(line);
          std::string l, r;
          if (!(ss >> l)) continue;
          if (l[0] == '#') continue;
          if (!(ss >> r)) throw Error(a->list + ":" + std::to_string(n) + ": expected 'LEFT RIGHT'");
          pairs.emplace_back(l, r);
        }
      } else {
        if (a->left.empty() || a->right.empty()) throw Error("give --left and --right globs, or --list FILE");
        const auto l = Glob(a->left, "--left"), r = Glob(a->right, "--right");
        if (l.size() != r.size()) {
          throw Error("--left matches " + std::to_string(l.size()) + " files but --right matches " +
                      std::to_string(r.size()) + "; pairs are matched by sorted order");
        }
        for (std::size_t i = 0; i < l.size(); ++i) pairs.emplace_back(l[i], r[i]);
      }
      cv::Size size;
      const auto corners = stereo::DetectBoards(pairs, o.board, &size, a->json ? nullptr : &std::cerr);
      const stereo::StereoRig rig = stereo::CalibrateFromCorners(corners, size, o);
      // The distortion model by evidence: the same corners with one term fewer (k3, or k4..k6
      // for the rational model), and the dropped terms' size against their standard deviations.
      stereo::CalibrationOptions simpler = o;
      simpler.model = o.model == stereo::DistortionModel::kRational ? stereo::DistortionModel::kK1K2P1P2K3
                                                                  : stereo::DistortionModel::kK1K2P1P2;
      std::optional<stereo::StereoRig> other;
      if (o.model != stereo::DistortionModel::kK1K2P1P2) other = stereo::CalibrateFromCorners(corners, size, simpler);
      const std::vector<double> sd = stereo::RigStdDevs(rig);
      // Largest |term| / sd among the terms the simpler model drops.
      double z_dropped = 0;
      const std::vector<int> dropped = o.model == stereo::DistortionModel::kRational ? std::vector<int>{9, 10, 11}
                                                                                      : std::vector<int>{8};
      const auto theta = stereo::RigParameters(rig);
      for (int c = 0; c < 2 && !sd.empty() && other; ++c) {
        for (int i : dropped) {
          const std::size_t k = std::size_t(12 * c + i);
          if (sd[k] > 0) z_dropped = std::max(z_dropped, std::abs(theta[int(k)]) / sd[k]);
        }
      }
      const char* dropped_name = o.model == stereo::DistortionModel::kRational ? "k4..k6" : "k3";
      std::pair<double, double> share{0, 0};
      const cv::Mat coverage = stereo::CoveragePicture(corners, rig.pairs, size, &share);
      if (!a->coverage.empty()) stereo::WriteImageAtomic(a->coverage, coverage);
      stereo::WriteRig(a->output, rig);
      cv::Mat rvec;
      cv::Rodrigues(rig.R, rvec);
      const double angle_deg = cv::norm(rvec) * 180.0 / CV_PI;
      int used = 0;
      for (const auto& p : rig.pairs) used += p.used;
      // The principal point is what moves a hedge sideways; say when the poses leave it loose.
      std::vector<std::string> warnings;
      if (!sd.empty()) {
        if (std::min(share.first, share.second) < 0.6) {
          warnings.emplace_back("the corners cover under 60 % of the image: show the board near the corners and edges, "
                                "where distortion is largest");
        }
        const char* axis_hint[2] = {"tilt the board about the vertical axis and show it near the left and right edges",
                                    "tilt the board about the horizontal axis and show it near the top and bottom edges"};
        for (int c = 0; c < 2; ++c) {
          for (int k = 0; k < 2; ++k) {
            const double s_pp = sd[std::size_t(12 * c + 2 + k)];
            if (s_pp > kPrincipalPointWarnPx) {
              char buf[256];
              std::snprintf(buf, sizeof(buf), "%s camera's %s is loose (+-%.2f px > %.1f px): %s", c ? "right" : "left",
                            k ? "cy" : "cx", s_pp, kPrincipalPointWarnPx, axis_hint[k]);
              warnings.emplace_back(buf);
            }
          }
        }
      }
      if (a->json) {
        nlohmann::json j;
        j["rig_file"] = a->output;
        j["image_size"] = {rig.image_size.width, rig.image_size.height};
        j["pairs_used"] = used;
        j["pairs_total"] = rig.pairs.size();
        j["rms_left_px"] = rig.rms_left_px;
        j["rms_right_px"] = rig.rms_right_px;
        j["rms_stereo_px"] = rig.rms_stereo_px;
        j["baseline"] = rig.baseline_mm;
        j["baseline_std"] = stereo::BaselineStdDev(rig);
        j["rotation_deg"] = angle_deg;
        auto vec = [](const cv::Mat& m) {
          std::vector<double> v;
          for (int i = 0; i < static_cast<int>(m.total()); ++i) v.push_back(m.at<double>(i));
          return v;
        };
        j["K1"] = vec(rig.K1);
        j["D1"] = vec(rig.D1);
        j["K2"] = vec(rig.K2);
        j["D2"] = vec(rig.D2);
        j["R"] = vec(rig.R);
        j["T"] = vec(rig.T);
        if (!sd.empty()) {
          for (std::size_t k = 0; k < sd.size(); ++k) j["std"][stereo::RigParameterNames()[k]] = sd[k];
        }
        if (other) {
          j["model_check"] = {{"without", dropped_name},
                              {"rms_stereo_px_without", other->rms_stereo_px},
                              {"largest_dropped_term_in_std", z_dropped}};
        }
        j["warnings"] = warnings;
        j["corner_coverage"] = {share.first, share.second};
        for (const auto& p : rig.pairs) {
          j["pairs"].push_back({{"left", p.left}, {"right", p.right}, {"used", p.used}, {"status", p.status},
                                {"rms_left_px", p.rms_left_px}, {"rms_right_px", p.rms_right_px},
                                {"rms_stereo_px", p.rms_stereo_px}});
        }
        std::cout << j.dump(2) << "\n";
        for (const auto& w : warnings) std::cerr << "warning: " << w << "\n";
        return kExitOk;
      }
      std::printf("calibrated from %d of %zu pairs (%dx%d images)\n", used, rig.pairs.size(), rig.image_size.width,
                  rig.image_size.height);
      std::printf("  RMS reprojection: left %.3f px, right %.3f px, stereo %.3f px\n", rig.rms_left_px,
                  rig.rms_right_px, rig.rms_stereo_px);
      std::printf("  baseline %.4f +- %.4f (units of --square), rotation between cameras %.3f deg\n", rig.baseline_mm,
                  stereo::BaselineStdDev(rig), angle_deg);
      auto cam = [&](const char* name, const cv::Mat& K, const cv::Mat& D, int offset) {
        auto pm = [&](int k) { return sd.empty() ? 0.0 : sd[std::size_t(offset + k)]; };
        std::printf("  %-5s fx %.2f+-%.2f fy %.2f+-%.2f cx %.2f+-%.2f cy %.2f+-%.2f\n        dist", name,
                    K.at<double>(0, 0), pm(0), K.at<double>(1, 1), pm(1), K.at<double>(0, 2), pm(2), K.at<double>(1, 2),
                    pm(3));
        for (int i = 0; i < std::min(8, static_cast<int>(D.total())); ++i) std::printf(" %.4f+-%.4f", D.at<double>(i), pm(4 + i));
        std::printf("\n");
      };
      cam("left", rig.K1, rig.D1, 0);
      cam("right", rig.K2, rig.D2, 12);
      std::printf("  T [%.4f, %.4f, %.4f] +- [%.4f, %.4f, %.4f]\n", rig.T.at<double>(0), rig.T.at<double>(1),
                  rig.T.at<double>(2), sd.empty() ? 0 : sd[27], sd.empty() ? 0 : sd[28], sd.empty() ? 0 : sd[29]);
      std::printf("  (+- one standard deviation, from the calibration's Jacobian and its residuals)\n");
      if (other) {
        std::printf("  model: without %s the stereo RMS is %.4f px (with: %.4f px); the largest %s is %.1f standard "
                    "deviations from 0, %s\n",
                    dropped_name, other->rms_stereo_px, rig.rms_stereo_px, dropped_name, z_dropped,
                    z_dropped < 2 ? "so the data do not support it: consider the simpler --model"
                                  : "so the data support it");
      }
      std::printf("  corners fell in %.0f %% (left) and %.0f %% (right) of an 8 x 8 grid over the image%s\n",
                  100 * share.first, 100 * share.second,
                  a->coverage.empty() ? " (--coverage FILE.png draws it)" : "");
      std::printf("pairs:\n");
      for (const auto& p : rig.pairs) {
        if (p.used || p.rms_stereo_px > 0) {
          std::printf("  %-40s %-40s L %.3f R %.3f px  %s\n", p.left.c_str(), p.right.c_str(), p.rms_left_px,
                      p.rms_right_px, p.status.c_str());
        } else {
          std::printf("  %-40s %-40s %s\n", p.left.c_str(), p.right.c_str(), p.status.c_str());
        }
      }
      for (const auto& w : warnings) std::printf("warning: %s\n", w.c_str());
      std::printf("wrote %s\n", a->output.c_str());
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
