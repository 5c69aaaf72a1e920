#include "pipeline/registry_report.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>

#include "pipeline/plugin.hpp"
#include "pipeline/print.hpp"

namespace hedgefit::pipeline {

namespace {

std::vector<const StageDescriptor*> Sorted(const Registry& registry) {
  std::vector<const StageDescriptor*> stages;
  for (const auto& name : registry.Names()) stages.push_back(registry.Find(name));
  return stages;
}

}  // namespace

std::string RegistryJson(const Registry& registry) {
  const std::vector<const StageDescriptor*> stages = Sorted(registry);
  nlohmann::json j;
  j["search_path"] = PluginSearchPath();
  for (const auto* d : stages) {
    nlohmann::json s;
    s["name"] = d->info.name;
    s["description"] = d->info.description;
    s["origin"] = d->origin;
    s["inputs"] = d->info.inputs;
    s["outputs"] = d->info.outputs;
    s["extensions"] = d->info.extensions;
    s["options"] = nlohmann::json::array();
    for (const auto& o : d->info.options) {
      nlohmann::json oj;
      oj["name"] = o.name;
      oj["type"] = TypeName(o.type);
      oj["default"] = nlohmann::json::parse(ToString(o.default_value));
      oj["help"] = o.help;
      if (!o.unit.empty()) oj["unit"] = o.unit;
      if (o.min) oj["min"] = *o.min;
      if (o.max) oj["max"] = *o.max;
      if (!o.choices.empty()) oj["choices"] = o.choices;
      s["options"].push_back(oj);
    }
    j["stages"].push_back(s);
  }
  j["plugins"] = nlohmann::json::array();
  for (const auto& r : registry.plugin_reports) {
    j["plugins"].push_back({{"path", r.path}, {"name", r.name}, {"version", r.version}, {"loaded", r.loaded},
                            {"message", r.message}, {"stages", r.stages}});
  }
  return j.dump(2);
}

void PrintRegistry(std::ostream& out, const Registry& registry) {
  const std::vector<const StageDescriptor*> stages = Sorted(registry);
  for (const auto* d : stages) {
    Print(out, "%s%s\n  %s\n", d->info.name.c_str(),
                d->origin == "builtin" ? "" : ("  [plugin " + d->origin + "]").c_str(), d->info.description.c_str());
    for (const auto& o : d->info.options) {
      std::string range;
      if (o.min && o.max) range = " in [" + ToString(*o.min) + ", " + ToString(*o.max) + "]";
      else if (o.min) range = " >= " + ToString(*o.min);
      if (!o.choices.empty()) {
        range = " one of";
        for (const auto& c : o.choices) range += " " + c;
      }
      Print(out, "    %-22s %-8s default %s%s%s. %s\n", o.name.c_str(), TypeName(o.type),
                  ToString(o.default_value).c_str(), o.unit.empty() ? "" : (" " + o.unit).c_str(),
                  range.c_str(), o.help.c_str());
    }
  }
  out << "\nplugin search path:";
  for (const auto& p : PluginSearchPath()) Print(out, " %s", p.c_str());
  out << "\n";
  if (registry.plugin_reports.empty()) Print(out, "no plugin files found\n");
  for (const auto& r : registry.plugin_reports) {
    if (r.loaded) {
      std::string names;
      for (const auto& s : r.stages) names += " " + s;
      Print(out, "loaded   %s (%s %s):%s\n", r.path.c_str(), r.name.c_str(), r.version.c_str(), names.c_str());
    } else {
      Print(out, "skipped  %s: %s\n", r.path.c_str(), r.message.c_str());
    }
  }
}

}  // namespace hedgefit::pipeline
