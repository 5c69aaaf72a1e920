// hedgefit info FILE: what a cloud file holds, like `pdal info`.


#include <iostream>

#include "apps/commands.hpp"
#include "cli/parse.hpp"
#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"

namespace hedgefit::apps {


void AddInfoCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("info", "Describe a cloud file: points, fields, organisation, bounds, NaNs, units");
  cmd->footer(
      "Examples:\n"
      "  hedgefit info sample_clouds/cap_z2300_a60_o10.pcd\n"
      "  hedgefit info --json data/pcl_test/table_scene_mug_stereo_textured.pcd\n");
  auto file = std::make_shared<std::string>();
  auto as_json = std::make_shared<bool>(false);
  cmd->add_option("FILE", *file, "cloud file (" + cloud::CloudExtensionList() + ")")->required();
  cmd->add_flag("--json", *as_json, "print JSON instead of text");
  GroupFlags(cmd, {{"Input", {"FILE"}}, {"Output format", {"--json"}}});
  cmd->callback([=]() {
    *run = [=]() {
      const cloud::CloudDescription d = cloud::DescribeCloud(*file);
      if (*as_json) {
        std::cout << cloud::DescriptionJson(d) << "\n";
      } else {
        cloud::PrintDescription(std::cout, d);
      }
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
