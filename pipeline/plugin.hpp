#pragma once
/// Runtime plugins: shared libraries found on HEDGEFIT_PLUGIN_PATH (and the
/// default install directory) that export one extern "C" entry point,
/// `hedgefit_plugin_entry`, returning a HedgefitPluginInfo. The host checks
/// `abi_version` before calling anything else in the plugin.
///
/// A plugin source file needs only:
///   #include "pipeline/plugin.hpp"
///   static void Register(hedgefit::pipeline::Registry& r) { r.Add(...); }
///   HEDGEFIT_PLUGIN("my_plugin", "1.0", Register)

#include <string>
#include <vector>

#include "pipeline/registry.hpp"

/// Bumped whenever Registry, Stage, Context or PointCloud change layout.
#define HEDGEFIT_PLUGIN_ABI_VERSION 5

extern "C" {
struct HedgefitPluginInfo {
  int abi_version;        ///< must equal the host's HEDGEFIT_PLUGIN_ABI_VERSION
  const char* name;       ///< plugin name, for reports
  const char* version;    ///< plugin's own version string
  void (*register_stages)(hedgefit::pipeline::Registry* registry);
};
}

#define HEDGEFIT_PLUGIN_ENTRY_SYMBOL "hedgefit_plugin_entry"

#define HEDGEFIT_PLUGIN(NAME, VERSION, REGISTER_FN)                                      \
  static void hedgefit_plugin_register_(hedgefit::pipeline::Registry* registry) {           \
    REGISTER_FN(*registry);                                                              \
  }                                                                                      \
  extern "C" __attribute__((visibility("default"))) const HedgefitPluginInfo*            \
  hedgefit_plugin_entry() {                                                              \
    static const HedgefitPluginInfo info{HEDGEFIT_PLUGIN_ABI_VERSION, NAME, VERSION,     \
                                         &hedgefit_plugin_register_};                    \
    return &info;                                                                        \
  }

namespace hedgefit::pipeline {

/// Directories searched for plugins: HEDGEFIT_PLUGIN_PATH (colon-separated),
/// then the default install directory.
std::vector<std::string> PluginSearchPath();

/// Loads every *.so in `directories` into `registry`. A file that cannot be
/// opened, lacks the entry point, has another ABI version or fails to register
/// is reported in registry.plugin_reports and skipped; this never throws.
void LoadPlugins(Registry& registry, const std::vector<std::string>& directories);

/// Loads one plugin file; the report says what happened.
PluginReport LoadPlugin(Registry& registry, const std::string& path);

}  // namespace hedgefit::pipeline
