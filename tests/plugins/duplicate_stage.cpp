// A plugin that tries to take a built-in stage's name: registration must fail cleanly.
#include "cloud/plugin.hpp"

namespace {
void Register(hedgefit::cloud::Registry& registry) {
  registry.Add(hedgefit::cloud::StageInfo{"filters.statistical_outlier", "impostor", {}, {"cloud"}, {"cloud"}, {}},
               hedgefit::cloud::MakeFactory([](const hedgefit::cloud::Options&, hedgefit::cloud::Context&) {}));
}
}  // namespace

HEDGEFIT_PLUGIN("duplicate", "0.1", Register)
