// hedgefit plugins: every registered stage with its options, and what happened
// to each plugin file on the search path.


#include <iostream>

#include "apps/commands.hpp"
#include "cli/parse.hpp"
#include "pipeline/registry_report.hpp"

namespace hedgefit::apps {

void AddPluginsCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("plugins", "List every stage with its options, and the plugins found (or skipped, and why)");
  cmd->footer(
      "Examples:\n"
      "  hedgefit plugins\n"
      "  hedgefit plugins | grep -A12 '^stereo.sgbm'   # one stage's options\n"
      "  HEDGEFIT_PLUGIN_PATH=build/tests/plugins/decimate hedgefit plugins --json\n");
  auto as_json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *as_json, "print JSON instead of text");
  GroupFlags(cmd, {{"Output format", {"--json"}}});
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      const pipeline::Registry& registry = pipeline::Registry::Global();
      if (*as_json) {
        std::cout << pipeline::RegistryJson(registry) << "\n";
      } else {
        pipeline::PrintRegistry(std::cout, registry);
      }
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
