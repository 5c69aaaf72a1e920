// hedgefit plugins: every registered stage with its options, and what happened
// to each plugin file on the search path.

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>

#include "apps/commands.hpp"
#include "cloud/plugin.hpp"

namespace hedgefit::apps {

void AddPluginsCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("plugins", "List every stage with its options, and the plugins found (or skipped, and why)");
  cmd->footer(
      "Examples:\n"
      "  hedgefit plugins\n"
      "  HEDGEFIT_PLUGIN_PATH=build/tests/plugins/decimate hedgefit plugins --json\n");
  auto as_json = std::make_shared<bool>(false);
  cmd->add_flag("--json", *as_json, "print JSON instead of text");
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      const cloud::Registry& registry = cloud::Registry::Global();
      std::vector<const cloud::StageDescriptor*> stages;
      for (const auto& name : registry.Names()) stages.push_back(registry.Find(name));
      if (*as_json) {
        nlohmann::json j;
        j["search_path"] = cloud::PluginSearchPath();
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
            oj["type"] = cloud::TypeName(o.type);
            oj["default"] = nlohmann::json::parse(cloud::ToString(o.default_value));
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
        std::cout << j.dump(2) << "\n";
        return kExitOk;
      }
      for (const auto* d : stages) {
        std::printf("%s%s\n  %s\n", d->info.name.c_str(),
                    d->origin == "builtin" ? "" : ("  [plugin " + d->origin + "]").c_str(), d->info.description.c_str());
        for (const auto& o : d->info.options) {
          std::string range;
          if (o.min && o.max) range = " in [" + cloud::ToString(*o.min) + ", " + cloud::ToString(*o.max) + "]";
          else if (o.min) range = " >= " + cloud::ToString(*o.min);
          if (!o.choices.empty()) {
            range = " one of";
            for (const auto& c : o.choices) range += " " + c;
          }
          std::printf("    %-22s %-8s default %s%s%s. %s\n", o.name.c_str(), cloud::TypeName(o.type),
                      cloud::ToString(o.default_value).c_str(), o.unit.empty() ? "" : (" " + o.unit).c_str(),
                      range.c_str(), o.help.c_str());
        }
      }
      std::printf("\nplugin search path:");
      for (const auto& p : cloud::PluginSearchPath()) std::printf(" %s", p.c_str());
      std::printf("\n");
      if (registry.plugin_reports.empty()) std::printf("no plugin files found\n");
      for (const auto& r : registry.plugin_reports) {
        if (r.loaded) {
          std::string names;
          for (const auto& s : r.stages) names += " " + s;
          std::printf("loaded   %s (%s %s):%s\n", r.path.c_str(), r.name.c_str(), r.version.c_str(), names.c_str());
        } else {
          std::printf("skipped  %s: %s\n", r.path.c_str(), r.message.c_str());
        }
      }
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
