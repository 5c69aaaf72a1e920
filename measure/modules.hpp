#pragma once
/// The one list of hedgefit's stage modules: every program, the Python module and the benches
/// register their stages through it, so a module added here is known everywhere.

#include "pipeline/registry.hpp"

namespace hedgefit::measure {

/// Adds every built-in stage module to `registry` (cloud, fitting, measure, render, scene,
/// stereo), each once (Registry::AddModule); plugins are loaded apart (pipeline/plugin.hpp).
void AddStageModules(pipeline::Registry& registry);

}  // namespace hedgefit::measure
