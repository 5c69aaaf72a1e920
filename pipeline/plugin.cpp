#include "pipeline/plugin.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "pipeline/version.hpp"

namespace hedgefit::pipeline {

namespace fs = std::filesystem;

std::vector<std::string> PluginSearchPath() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("HEDGEFIT_PLUGIN_PATH")) {
    std::stringstream ss(env);
    std::string dir;
    while (std::getline(ss, dir, ':')) {
      if (!dir.empty()) dirs.push_back(dir);
    }
  }
  // Relocatable installs: <prefix>/bin/hedgefit looks in <prefix>/lib/hedgefit/plugins.
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back((exe.parent_path().parent_path() / kPluginInstallSubdir).string());
  dirs.push_back(kPluginInstallDir);
  // The same directory may appear twice (installed prefix == exe prefix).
  std::vector<std::string> unique;
  for (const auto& d : dirs) {
    if (std::find(unique.begin(), unique.end(), d) == unique.end()) unique.push_back(d);
  }
  return unique;
}

PluginReport LoadPlugin(Registry& registry, const std::string& path) {
  PluginReport report;
  report.path = path;
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* err = dlerror();
    report.message = std::string("cannot be opened: ") + (err ? err : "unknown dlopen error");
    return report;
  }
  using Entry = const HedgefitPluginInfo* (*)();
  dlerror();
  auto entry = reinterpret_cast<Entry>(dlsym(handle, HEDGEFIT_PLUGIN_ENTRY_SYMBOL));
  if (entry == nullptr) {
    report.message = "has no '" HEDGEFIT_PLUGIN_ENTRY_SYMBOL
                     "' entry point; build it with HEDGEFIT_PLUGIN(...) from cloud/plugin.hpp";
    dlclose(handle);
    return report;
  }
  const HedgefitPluginInfo* info = entry();
  if (info == nullptr) {
    report.message = "entry point returned no plugin info";
    dlclose(handle);
    return report;
  }
  report.name = info->name ? info->name : "";
  report.version = info->version ? info->version : "";
  if (info->abi_version != HEDGEFIT_PLUGIN_ABI_VERSION) {
    report.message = "plugin ABI version " + std::to_string(info->abi_version) + " but hedgefit " +
                     kVersion + " needs " + std::to_string(HEDGEFIT_PLUGIN_ABI_VERSION) +
                     "; rebuild the plugin against this hedgefit";
    dlclose(handle);
    return report;
  }
  if (info->register_stages == nullptr) {
    report.message = "plugin info has no register function";
    dlclose(handle);
    return report;
  }
  // Register into a scratch registry first, so a plugin that fails halfway adds nothing.
  Registry scratch;
  try {
    info->register_stages(&scratch);
    for (const auto& d : scratch.stages()) {
      if (const StageDescriptor* existing = registry.Find(d.info.name)) {
        throw Error("stage '" + d.info.name + "' is already registered by " + existing->origin +
                    "; rename the plugin's stage");
      }
    }
    for (const auto& d : scratch.stages()) registry.Add(d.info, d.make, path);
  } catch (const std::exception& e) {
    report.message = std::string("registration failed: ") + e.what();
    return report;
  }
  for (const auto& d : scratch.stages()) report.stages.push_back(d.info.name);
  report.loaded = true;
  // The handle is deliberately never closed: registered factories point into it.
  return report;
}

void LoadPlugins(Registry& registry, const std::vector<std::string>& directories) {
  for (const auto& dir : directories) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<std::string> files;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      if (entry.path().extension() == ".so") files.push_back(entry.path().string());
    }
    std::sort(files.begin(), files.end());  // deterministic order
    for (const auto& f : files) {
      bool seen = false;
      for (const auto& r : registry.plugin_reports) seen = seen || r.path == f;
      if (!seen) registry.plugin_reports.push_back(LoadPlugin(registry, f));
    }
  }
}

}  // namespace hedgefit::pipeline
