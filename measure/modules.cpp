#include "measure/modules.hpp"

#include "cloud/cloud_stages.hpp"
#include "fitting/fitting_stages.hpp"
#include "measure/measure_stages.hpp"
#include "render/render_stages.hpp"
#include "scene/scene_stages.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::measure {

void AddStageModules(pipeline::Registry& registry) {
  registry.AddModule("cloud", &cloud::RegisterCloudStages);
  registry.AddModule("fitting", &fitting::RegisterFittingStages);
  registry.AddModule("measure", &RegisterMeasureStages);
  registry.AddModule("render", &render::RegisterRenderStages);
  registry.AddModule("scene", &scene::RegisterSceneStages);
  registry.AddModule("stereo", &stereo::RegisterStereoStages);
}

}  // namespace hedgefit::measure
