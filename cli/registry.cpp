#include "cli/run.hpp"
#include "cloud/cloud_stages.hpp"
#include "pipeline/plugin.hpp"
#include "fitting/fitting_stages.hpp"
#include "render/render_stages.hpp"
#include "scene/scene_stages.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::cli {

void PrepareRegistry(bool load_plugins) {
  pipeline::Registry& registry = pipeline::Registry::Global();
  registry.AddModule("cloud", &cloud::RegisterCloudStages);
  registry.AddModule("fitting", &fitting::RegisterFittingStages);
  registry.AddModule("render", &render::RegisterRenderStages);
  registry.AddModule("scene", &scene::RegisterSceneStages);
  registry.AddModule("stereo", &stereo::RegisterStereoStages);
  if (load_plugins) pipeline::LoadPlugins(registry, pipeline::PluginSearchPath());
}

}  // namespace hedgefit::cli
