#include "apps/commands.hpp"
#include "cloud/plugin.hpp"

namespace hedgefit::apps {

void PrepareRegistry(bool load_plugins) {
  cloud::Registry& registry = cloud::Registry::Global();
  if (load_plugins) cloud::LoadPlugins(registry, cloud::PluginSearchPath());
}

}  // namespace hedgefit::apps
