#include "apps/commands.hpp"
#include "cloud/plugin.hpp"
#include "fitting/fitting_stages.hpp"
#include "render/render_stages.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::apps {

void PrepareRegistry(bool load_plugins) {
  cloud::Registry& registry = cloud::Registry::Global();
  static const bool builtins = [&] {
    fitting::RegisterFittingStages(registry);
    render::RegisterRenderStages(registry);
    stereo::RegisterStereoStages(registry);
    return true;
  }();
  (void)builtins;
  if (load_plugins) cloud::LoadPlugins(registry, cloud::PluginSearchPath());
}

}  // namespace hedgefit::apps
