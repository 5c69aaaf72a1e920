// A plugin built for another ABI: the host must refuse it without calling register.
#include <cstdlib>

#include "pipeline/plugin.hpp"

namespace {
void MustNotBeCalled(hedgefit::pipeline::Registry*) { std::abort(); }
}  // namespace

extern "C" __attribute__((visibility("default"))) const HedgefitPluginInfo* hedgefit_plugin_entry() {
  static const HedgefitPluginInfo info{HEDGEFIT_PLUGIN_ABI_VERSION + 1000, "wrong_abi", "0.0", &MustNotBeCalled};
  return &info;
}
