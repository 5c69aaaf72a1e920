#include "cli/run.hpp"
#include "measure/modules.hpp"
#include "pipeline/plugin.hpp"

namespace hedgefit::cli {

void PrepareRegistry(bool load_plugins) {
  pipeline::Registry& registry = pipeline::Registry::Global();
  measure::AddStageModules(registry);
  if (load_plugins) pipeline::LoadPlugins(registry, pipeline::PluginSearchPath());
}

}  // namespace hedgefit::cli
