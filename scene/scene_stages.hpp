#pragma once
/// scene/'s stage: segment.hedges, the hedge finder in a pipeline (scene::FindHedges). It labels
/// the cloud's points with hedge_id (each ball's id, 0 elsewhere), object_id and ground, so the
/// fitters.* stages after it fit each ball on its own.

#include "pipeline/registry.hpp"

namespace hedgefit::scene {

/// Adds segment.hedges to `registry`.
void RegisterSceneStages(pipeline::Registry& registry);

}  // namespace hedgefit::scene
