// hedgefit rig: a rig file for a pair that is already rectified, from its numbers.

#include <cstdio>
#include <sstream>

#include "apps/commands.hpp"
#include "cli/parse.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::apps {

void AddRigCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand(
      "rig", "Write a rig file for an already rectified pair from its focal length, principal point and baseline");
  cmd->footer(
      "Examples:\n"
      "  hedgefit rig --size 1920x1200 --focal 933.3 --cx 960 --cy 600 --baseline 140 -o rig.yaml   # the paper's rig\n"
      "  hedgefit rig --size 640x480 --focal 368.5347 --cx 318.1122 --cy 224.3349 --baseline 838.7445 \\\n"
      "      -o build/pcl_outdoor_rig.yaml   # PCL's outdoor pair (its baseline's unit is not stated)\n"
      "The images are used as they are (no undistortion, identity rectification).\n");
  struct Args {
    std::string size, output;
    double focal = 0, cx = 0, cy = 0, baseline = 0;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--size", a->size, "image size WIDTHxHEIGHT, px")->required();
  cmd->add_option("--focal", a->focal, "focal length, px")->required();
  cmd->add_option("--cx", a->cx, "principal point x, px")->required();
  cmd->add_option("--cy", a->cy, "principal point y, px")->required();
  cmd->add_option("--baseline", a->baseline, "distance between the cameras, mm")->required();
  cmd->add_option("-o,--output", a->output, "rig file to write (YAML)")->required();
  GroupFlags(cmd, {{"Cameras", {"--size", "--focal", "--cx", "--cy", "--baseline"}}, {"Output", {"--output"}}});
  cmd->callback([=]() {
    *run = [=]() {
      const auto [w, h] = ParseCount2(a->size, "--size", 1, "WIDTHxHEIGHT in px", "640x480");
      stereo::StereoRig rig;
      try {
        rig = stereo::RigForRectifiedPair(cv::Size(w, h), a->focal, a->cx, a->cy, a->baseline);
      } catch (const Error& e) {
        throw Error(std::string("--") + e.what());
      }
      stereo::WriteRig(a->output, rig);
      std::printf("wrote %s: %dx%d, f %.4f px, c (%.4f, %.4f) px, baseline %.4f mm\n", a->output.c_str(), w, h,
                  a->focal, a->cx, a->cy, a->baseline);
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
