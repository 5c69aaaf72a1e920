// hedgefit check-rig: does a rig file still fit a pair? The rectified rows' residual vertical
// disparity, over the whole frame.

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>

#include "cli/capture_flags.hpp"
#include "apps/commands.hpp"
#include "cli/parse.hpp"
#include "stereo/capture.hpp"
#include "stereo/rig_check.hpp"
#include "stereo/rig.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::apps {

void AddCheckRigCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand(
      "check-rig", "Check that a rig file still fits a pair: how far apart the rectified rows are (vertical disparity)");
  cmd->footer(
      "Examples (the demo's rig and one of its captures):\n"
      "  hedgefit check-rig --rig build/demo/rig.yaml --left build/demo/lab/sphere_2300_left.png \\\n"
      "      --right build/demo/lab/sphere_2300_right.png\n"
      "  hedgefit check-rig --rig rig.yaml --left l.png --right r.png --min-z 1500 --max-z 8000 --json\n"
      "Exit 0 when the rows agree within --tolerance, 2 when they do not (recalibrate), 1 on bad input.\n");
  struct Args {
    std::string rig, left, right;
    // The whole scene, not only the hedge's working range: windows matched outside the range
    // searched are mismatches, and a wall behind the hedge is most of a lab frame. At half
    // resolution the wide search is cheap.
    double min_z = 1000, max_z = 20000, tolerance = 0.5;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--rig", a->rig, "rig file (hedgefit calibrate)")->required();
  cmd->add_option("--left", a->left, "left image, as captured")->required();
  cmd->add_option("--right", a->right, "right image, as captured")->required();
  cmd->add_option("--min-z", a->min_z, "nearest scene depth, mm (sets the disparities searched)")
      ->capture_default_str();
  cmd->add_option("--max-z", a->max_z, "farthest scene depth, mm")->capture_default_str();
  cmd->add_option("--tolerance", a->tolerance,
                  "largest vertical disparity accepted, px (SGBM's own matching suffers beyond about half a pixel)")
      ->check(CLI::Range(0.001, 100.0))
      ->capture_default_str();
  cmd->add_flag("--json", a->json, "print one JSON object instead of text");
  GroupFlags(cmd, {{"Inputs", {"--rig", "--left", "--right"}}, {"Check", {"--min-z", "--max-z", "--tolerance"}}, {"Output format", {"--json"}}});
  cmd->callback([=]() {
    *run = [=]() {
      if (!(a->min_z > 0 && a->max_z > a->min_z)) throw Error("--min-z/--max-z: need 0 < min-z < max-z (mm)");
      const stereo::StereoRig rig = stereo::ReadRig(a->rig);
      stereo::CheckRowSearchRange(rig, a->min_z, a->max_z);
      stereo::CheckCaptureImages(a->left, a->right);
      const stereo::RigCheck c =
          stereo::CheckRigOnPair(rig, stereo::ReadCaptureImage(a->left), stereo::ReadCaptureImage(a->right), a->min_z,
                                 a->max_z, a->tolerance, a->left + ", " + a->right + " with " + a->rig);
      const stereo::VerticalDisparity& v = c.rows;
      if (a->json) {
        const nlohmann::ordered_json j{{"offset_px", std::round(v.offset_px * 1e4) / 1e4},
                                       {"slope_x_px", std::round(v.slope_x_px * 1e4) / 1e4},
                                       {"slope_y_px", std::round(v.slope_y_px * 1e4) / 1e4},
                                       {"max_abs_px", std::round(c.max_abs_px * 1e4) / 1e4},
                                       {"windows", v.samples},
                                       {"tolerance_px", a->tolerance},
                                       {"fits", c.fits}};
        std::printf("%s\n", j.dump().c_str());
      } else {
        std::printf("rectified rows (right row - left row): %+.3f px at the centre, %+.3f across, %+.3f down; "
                    "at most %.3f px (%d windows)\n",
                    v.offset_px, v.slope_x_px, v.slope_y_px, c.max_abs_px, v.samples);
        if (c.fits) {
          std::printf("the rig fits this pair (tolerance %.2f px)\n", a->tolerance);
        } else {
          std::printf("the rows disagree by up to %.2f px (tolerance %.2f px): the rig file is not these cameras', or "
                      "they moved since calibration; recalibrate (hedgefit calibrate)\n",
                      c.max_abs_px, a->tolerance);
        }
      }
      return c.fits ? kExitOk : kExitProcessing;
    };
  });
}

}  // namespace hedgefit::apps
