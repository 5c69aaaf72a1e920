#include "pipeline/registry.hpp"

#include <algorithm>
#include <cctype>
#include <mutex>

namespace hedgefit::pipeline {

void Registry::Add(StageInfo info, StageFactory make, const std::string& origin) {
  if (info.name.empty() || info.name.find('.') == std::string::npos) {
    throw Error("stage name '" + info.name + "' (from " + origin +
                ") must be 'kind.name', e.g. 'filters.my_filter'");
  }
  if (const StageDescriptor* existing = Find(info.name)) {
    throw Error("stage '" + info.name + "' from " + origin + " is already registered by " +
                existing->origin + "; rename one of them");
  }
  for (const OptionSpec& spec : info.options) {
    // A default that fails its own validation is a programming error in the stage.
    ResolveOptions(info, {{spec.name, spec.default_value}}, info.name);
  }
  stages_.push_back(StageDescriptor{std::move(info), std::move(make), origin, {}});
}

const StageDescriptor* Registry::Find(const std::string& name) const {
  for (const auto& d : stages_) {
    if (d.info.name == name) return &d;
  }
  return nullptr;
}

std::vector<std::string> Registry::Names() const {
  std::vector<std::string> names;
  for (const auto& d : stages_) names.push_back(d.info.name);
  std::sort(names.begin(), names.end());
  return names;
}

void Registry::SetOptionInputs(const std::string& name, OptionInputs fn) {
  for (auto& d : stages_) {
    if (d.info.name == name) {
      d.option_inputs = std::move(fn);
      return;
    }
  }
  throw Error("internal: no stage '" + name + "' to give option inputs");
}

const StageDescriptor& Registry::Get(const std::string& name, const std::string& where) const {
  if (const StageDescriptor* d = Find(name)) return *d;
  const std::string hint = DidYouMean(name, Names());
  throw Error(where + "unknown stage '" + name + "'" +
              (hint.empty() ? "" : " (did you mean '" + hint + "'?)") +
              "; `hedgefit plugins` lists every stage");
}

const StageDescriptor* Registry::ForExtension(const std::string& path, bool writer) const {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos) return nullptr;
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const std::string prefix = writer ? "writers." : "readers.";
  for (const auto& d : stages_) {
    if (d.info.name.rfind(prefix, 0) != 0) continue;
    const auto& exts = d.info.extensions;
    if (std::find(exts.begin(), exts.end(), ext) != exts.end()) return &d;
  }
  return nullptr;
}

void Registry::AddModule(const std::string& module, void (*add)(Registry&)) {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  if (std::find(modules_.begin(), modules_.end(), module) != modules_.end()) return;
  add(*this);
  modules_.push_back(module);
}

std::string Registry::ExtensionList(bool writer) const {
  const std::string prefix = writer ? "writers." : "readers.";
  std::vector<std::string> exts;
  for (const auto& d : stages_) {
    if (d.info.name.rfind(prefix, 0) != 0) continue;
    // A format's first extension names it (.xyz, not also .txt and .csv).
    if (!d.info.extensions.empty() &&
        std::find(exts.begin(), exts.end(), d.info.extensions.front()) == exts.end()) {
      exts.push_back(d.info.extensions.front());
    }
  }
  if (exts.empty()) return "a registered " + std::string(writer ? "writer" : "reader") + "'s extension";
  std::string out;
  for (std::size_t i = 0; i < exts.size(); ++i) {
    out += (i == 0 ? "" : (i + 1 == exts.size() ? " or " : ", ")) + exts[i];
  }
  return out;
}

Registry& Registry::Global() {
  static Registry* registry = [] {
    return new Registry();
  }();
  return *registry;
}

}  // namespace hedgefit::pipeline
