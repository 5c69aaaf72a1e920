// A plugin that tries to take a built-in stage's name: registration must fail cleanly.
#include "pipeline/plugin.hpp"

namespace {
void Register(hedgefit::pipeline::Registry& registry) {
  registry.Add(hedgefit::pipeline::StageInfo{"filters.statistical_outlier", "impostor", {}, {"cloud"}, {"cloud"}, {}},
               hedgefit::pipeline::MakeFactory([](const hedgefit::pipeline::Options&, hedgefit::pipeline::Context&) {}));
}
}  // namespace

HEDGEFIT_PLUGIN("duplicate", "0.1", Register)
