// hedgefit bench lab: the paper's laboratory test on the simulated rig, end to end:
// render boards and spheres, calibrate from the boards (never from the simulator's
// truth), convert each sphere capture, fit with every method, and score like Table 2.

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "apps/commands.hpp"
#include "apps/fit_methods.hpp"
#include "cloud/cloud_io.hpp"
#include "fitting/evaluation.hpp"
#include "stereo/calibration.hpp"
#include "stereo/capture.hpp"
#include "stereo/simulator.hpp"

namespace hedgefit::apps {

void AddBenchCommand(CLI::App& app, CommandFn* run) {
  auto* bench = app.add_subcommand("bench", "End-to-end benchmarks");
  auto* cmd = bench->add_subcommand("lab", "The paper's lab test on the simulated rig: Table 2 per method, beside the paper's figures");
  cmd->footer(
      "Examples:\n"
      "  hedgefit bench lab                        # renders into build/lab-bench, about a minute\n"
      "  hedgefit bench lab --reuse --json lab.json\n");
  struct Args {
    std::string dir = "build/lab-bench", json;
    double scale = 1.0;
    int erode = stereo::SegmentOptions{}.erode_px, refine_radius = stereo::SgbmOptions{}.refine_radius;
    double alpha = stereo::CalibrationOptions{}.alpha;
    bool reuse = false, true_rig = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--dir", a->dir, "where the simulated captures go")->capture_default_str();
  cmd->add_option("--scale", a->scale, "image scale of the simulated rig")->check(CLI::Range(0.25, 2.0))->capture_default_str();
  cmd->add_option("--erode", a->erode, "mask erosion, px (drops the silhouette ring)")->capture_default_str();
  cmd->add_option("--refine-radius", a->refine_radius, "sub-pixel refinement window half-size, px (0 = off)")
      ->check(CLI::Range(0, 15))
      ->capture_default_str();
  cmd->add_option("--alpha", a->alpha,
                  "rectification scaling (0 = only valid pixels, -1 = OpenCV's default): a rectified focal length "
                  "that differs from the camera's varies the resampling phase over the hedge")
      ->check(CLI::Range(-1.0, 1.0))
      ->capture_default_str();
  cmd->add_flag("--reuse", a->reuse, "reuse captures already in --dir");
  cmd->add_flag("--true-rig", a->true_rig,
                "use the simulator's exact rig instead of calibrating from the boards (separates calibration "
                "error from matching error)");
  cmd->add_option("--json", a->json, "also write the table as JSON here");
  cmd->callback([=]() {
    *run = [=]() {
      namespace fs = std::filesystem;
      const auto t0 = std::chrono::steady_clock::now();
      if (!(a->reuse && fs::exists(fs::path(a->dir) / "sphere_2600_right.png"))) {
        stereo::RenderOptions ro;
        ro.supersample = 3;
        ro.blur_sigma_px = 0.5;
        stereo::WritePaperLab(a->dir, a->scale, ro);
      }
      std::vector<std::pair<std::string, std::string>> boards;
      for (int i = 1; i <= 16; ++i) {
        char l[32], r[32];
        std::snprintf(l, sizeof(l), "board_%02d_left.png", i);
        std::snprintf(r, sizeof(r), "board_%02d_right.png", i);
        boards.emplace_back((fs::path(a->dir) / l).string(), (fs::path(a->dir) / r).string());
      }
      stereo::CalibrationOptions co;
      co.board.inner_corners = cv::Size(12, 11);
      co.board.square_mm = 30;
      co.alpha = a->alpha;
      cv::Size size;
      const stereo::StereoRig rig =
          a->true_rig ? stereo::RigFromSimulation(stereo::PaperRig(a->scale))
                      : stereo::CalibrateFromCorners(stereo::DetectBoards(boards, co.board, &size), size, co);
      if (a->true_rig) {
        std::printf("using the simulator's exact rig (no calibration error), baseline %.3f mm\n", rig.baseline_mm);
      } else {
        std::printf("calibrated from the simulated boards: stereo RMS %.3f px, baseline %.3f mm\n", rig.rms_stereo_px,
                    rig.baseline_mm);
      }
      stereo::ConvertOptions cv_opts;
      cv_opts.segment.erode_px = a->erode;
      cv_opts.sgbm.refine_radius = a->refine_radius;
      nlohmann::json out;
      out["rig"] = {{"rms_stereo_px", rig.rms_stereo_px}, {"baseline_mm", rig.baseline_mm}, {"exact", a->true_rig}};
      struct Row {
        double z;
        fitting::Sphere truth;
        std::vector<fitting::SphereFitResult> fits;
        double convert_ms;
        std::size_t points;
      };
      std::vector<Row> rows;
      for (int z = 2000; z <= 2600; z += 100) {
        char name[32];
        std::snprintf(name, sizeof(name), "sphere_%04d", z);
        const fs::path base = fs::path(a->dir) / name;
        Row row;
        row.z = z;
        row.truth = fitting::ReadTruthFile(base.string() + ".truth.json");
        const stereo::ConvertResult res =
            stereo::ConvertCapture(cv::imread(base.string() + "_left.png"), cv::imread(base.string() + "_right.png"), rig, cv_opts);
        row.convert_ms = res.wall_ms;
        std::vector<Eigen::Vector3d> pts;
        for (const auto& p : res.cloud.points_mm) {
          if (cloud::IsFinite(p)) pts.push_back(p.cast<double>());
        }
        row.points = pts.size();
        FitMethodOptions fo;
        fo.ransac_threshold_mm = 15;  // ~3 sigma of depth noise at 2.6 m on this rig
        fo.min_radius_mm = 100;
        fo.max_radius_mm = 1000;
        for (const auto& m : kAllMethods) row.fits.push_back(RunFitMethod(m, pts, fo));
        rows.push_back(std::move(row));
      }
      fitting::SummaryBuilder summary;
      for (const auto& m : kAllMethods) {
        std::printf("\n%s\n  %6s %8s %8s %8s %7s %26s %26s %7s\n", m.c_str(), "Z mm", "AR mm", "MR mm", "AER mm", "RER %",
                    "AL (x, y, z) mm", "ML (x, y, z) mm", "LD mm");
        for (const auto& row : rows) {
          for (const auto& f : row.fits) {
            if (f.method != m) continue;
            summary.Add(m, f, row.truth);
            if (!f.converged) {
              std::printf("  %6.0f failed: %s\n", row.z, f.message.c_str());
              continue;
            }
            const auto e = fitting::Evaluate(f.sphere, row.truth);
            std::printf("  %6.0f %8.2f %8.2f %8.2f %7.2f   (%6.1f, %6.1f, %7.1f)   (%6.1f, %6.1f, %7.1f) %7.2f\n", row.z,
                        row.truth.radius_mm, f.sphere.radius_mm, e.aer_mm, e.rer_percent, row.truth.center_mm.x(),
                        row.truth.center_mm.y(), row.truth.center_mm.z(), f.sphere.center_mm.x(), f.sphere.center_mm.y(),
                        f.sphere.center_mm.z(), e.ld_mm);
            out["rows"].push_back({{"method", m}, {"z_mm", row.z}, {"ar_mm", row.truth.radius_mm},
                                   {"mr_mm", f.sphere.radius_mm}, {"aer_mm", e.aer_mm}, {"rer_percent", e.rer_percent},
                                   {"ld_mm", e.ld_mm},
                                   {"ml_mm", {f.sphere.center_mm.x(), f.sphere.center_mm.y(), f.sphere.center_mm.z()}}});
          }
        }
      }
      const auto stats = summary.Finish();
      std::printf("\nsummary over Z = 2000..2600 mm (7 positions)\n  %-17s %10s %10s %9s %9s %9s %9s\n", "method",
                  "mean|AER|", "max|AER|", "mean RER%", "RMSE", "mean LD", "max LD");
      for (const auto& m : kAllMethods) {
        const auto& s = stats.at(m);
        std::printf("  %-17s %10.2f %10.2f %9.3f %9.2f %9.2f %9.2f\n", m.c_str(), s.mean_abs_aer_mm, s.max_abs_aer_mm,
                    s.mean_rer_percent, s.rmse_radius_mm, s.mean_ld_mm, s.max_ld_mm);
        out["summary"][m] = {{"mean_abs_aer_mm", s.mean_abs_aer_mm}, {"max_abs_aer_mm", s.max_abs_aer_mm},
                             {"mean_rer_percent", s.mean_rer_percent}, {"rmse_radius_mm", s.rmse_radius_mm},
                             {"mean_ld_mm", s.mean_ld_mm}, {"max_ld_mm", s.max_ld_mm}, {"failures", s.failures}};
      }
      std::printf("  %-17s %10.2f %10.2f %9.3f %9.2f %9.2f %9.2f   (published, Table 2)\n", "paper", 1.58, 3.00, 0.52, 1.59,
                  15.92, 19.12);
      double ms = 0;
      for (const auto& r : rows) ms += r.convert_ms;
      std::printf("capture to cloud: %.0f ms per 1920x1200-scaled pair on average; whole run %.1f s\n",
                  ms / double(rows.size()),
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      out["paper"] = {{"mean_abs_aer_mm", 1.58}, {"mean_rer_percent", 0.52}, {"mean_ld_mm", 15.92}};
      if (!a->json.empty()) cloud::WriteTextFileAtomic(a->json, out.dump(2) + "\n");
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
