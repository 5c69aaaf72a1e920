#include "apps/stage_flags.hpp"

#include <algorithm>

#include "cloud/option_table.hpp"

namespace hedgefit::apps {

namespace {

std::string Help(const cloud::OptionSpec& spec) {
  std::string out = spec.help;
  if (!spec.unit.empty()) out += ", " + spec.unit;
  if (!spec.choices.empty()) {
    std::string list;
    for (const auto& c : spec.choices) list += (list.empty() ? "" : "|") + c;
    out += " (" + list + ")";
  }
  if (spec.type != cloud::OptionType::kBool) out += " [default " + cloud::ToString(spec.default_value) + "]";
  return out;
}

}  // namespace

std::string AsFlagMessage(const std::string& msg) {
  if (msg.rfind("option '", 0) != 0) return msg;
  const auto end = msg.find('\'', 8);
  if (end == std::string::npos) return msg;
  return cloud::FlagName(msg.substr(8, end - 8)) + msg.substr(end + 1);
}

void StageFlags::Add(CLI::App* cmd, const std::vector<cloud::OptionSpec>& specs, const std::vector<std::string>& only) {
  for (const auto& spec : specs) {
    if (!only.empty() && std::find(only.begin(), only.end(), spec.name) == only.end()) continue;
    const bool taken = std::any_of(flags_.begin(), flags_.end(), [&](const auto& f) { return f->spec.name == spec.name; });
    if (taken) continue;
    auto flag = std::make_unique<Flag>();
    flag->spec = spec;
    const std::string name = cloud::FlagName(spec.name);
    if (spec.type == cloud::OptionType::kBool) {
      // A switch: --name sets true; an option that defaults to true is turned off by --no-name.
      const bool def = std::get<bool>(spec.default_value);
      const std::string switch_name = def ? "--no-" + name.substr(2) : name;
      flag->text = def ? "false" : "true";
      flag->option = cmd->add_flag(switch_name)->description(def ? "turn off: " + spec.help : spec.help);
    } else {
      flag->option = cmd->add_option(name, flag->text, Help(spec));
    }
    flags_.push_back(std::move(flag));
  }
}

std::map<std::string, cloud::OptionValue> StageFlags::Given() const {
  std::map<std::string, cloud::OptionValue> out;
  for (const auto& f : flags_) {
    if (f->option->count() == 0) continue;
    const std::string typed = f->option->get_name().empty() ? cloud::FlagName(f->spec.name) : "--" + f->option->get_lnames().front();
    const cloud::OptionNamer name_of = [typed](const std::string&) { return typed; };
    out[f->spec.name] = cloud::CheckOptionValue(f->spec, cloud::ParseOptionString(f->spec, f->text, name_of), name_of);
  }
  return out;
}

std::map<std::string, cloud::OptionValue> StageFlags::For(const std::vector<cloud::OptionSpec>& specs) const {
  std::map<std::string, cloud::OptionValue> given = Given(), out;
  for (const auto& spec : specs) {
    auto it = given.find(spec.name);
    if (it != given.end()) out[spec.name] = it->second;
  }
  return out;
}

}  // namespace hedgefit::apps
