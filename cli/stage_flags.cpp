#include "cli/stage_flags.hpp"

#include <algorithm>

#include "pipeline/option_table.hpp"

namespace hedgefit::cli {

namespace {

std::string Help(const pipeline::OptionSpec& spec) {
  std::string out = spec.help;
  if (!spec.unit.empty()) out += ", " + spec.unit;
  if (!spec.choices.empty()) {
    std::string list;
    for (const auto& c : spec.choices) list += (list.empty() ? "" : "|") + c;
    out += " (" + list + ")";
  }
  // No default shown for an option that is unset by default (an empty text or list).
  const auto* text = std::get_if<std::string>(&spec.default_value);
  const auto* list = std::get_if<std::vector<double>>(&spec.default_value);
  if (spec.type != pipeline::OptionType::kBool && !(text && text->empty()) && !(list && list->empty())) {
    out += " [default " + pipeline::ToString(spec.default_value) + "]";
  }
  return out;
}

// What --help shows after the flag: the kind of value it takes.
std::string TypeName(const pipeline::OptionSpec& spec) {
  switch (spec.type) {
    case pipeline::OptionType::kInt: return "INT";
    case pipeline::OptionType::kDouble: return "FLOAT";
    case pipeline::OptionType::kDoubleList: return "X,Y,...";
    default: return "TEXT";
  }
}

}  // namespace

std::string AsFlagMessage(const std::string& msg) {
  // Every option the message names, as the command line spells it ("... beyond option 'min_z'").
  std::string out;
  std::size_t at = 0;
  for (std::size_t k; (k = msg.find("option '", at)) != std::string::npos;) {
    const auto end = msg.find('\'', k + 8);
    if (end == std::string::npos) break;
    out += msg.substr(at, k - at) + pipeline::FlagName(msg.substr(k + 8, end - k - 8));
    at = end + 1;
  }
  return out + msg.substr(at);
}

void StageFlags::Add(CLI::App* cmd, const std::vector<pipeline::OptionSpec>& specs, const std::vector<std::string>& only,
                     const std::string& group, const std::map<std::string, std::string>& flag_names) {
  for (const auto& spec : specs) {
    if (!only.empty() && std::find(only.begin(), only.end(), spec.name) == only.end()) continue;
    const bool taken = std::any_of(flags_.begin(), flags_.end(), [&](const auto& f) { return f->spec.name == spec.name; });
    if (taken) continue;
    auto flag = std::make_unique<Flag>();
    flag->spec = spec;
    const auto renamed = flag_names.find(spec.name);
    const std::string name = renamed != flag_names.end() ? renamed->second : pipeline::FlagName(spec.name);
    if (spec.type == pipeline::OptionType::kBool) {
      // A switch: --name sets true; an option that defaults to true is turned off by --no-name.
      const bool def = std::get<bool>(spec.default_value);
      const std::string switch_name = def ? "--no-" + name.substr(2) : name;
      flag->text = def ? "false" : "true";
      flag->option = cmd->add_flag(switch_name)->description(def ? "turn off: " + spec.help : spec.help);
    } else {
      flag->option = cmd->add_option(name, flag->text, Help(spec))->type_name(TypeName(spec));
    }
    if (!group.empty()) flag->option->group(group);
    flags_.push_back(std::move(flag));
  }
}

std::map<std::string, pipeline::OptionValue> StageFlags::Given() const {
  std::map<std::string, pipeline::OptionValue> out;
  for (const auto& f : flags_) {
    if (f->option->count() == 0) continue;
    const std::string typed = f->option->get_name().empty() ? pipeline::FlagName(f->spec.name) : "--" + f->option->get_lnames().front();
    const pipeline::OptionNamer name_of = [typed](const std::string&) { return typed; };
    out[f->spec.name] = pipeline::CheckOptionValue(f->spec, pipeline::ParseOptionString(f->spec, f->text, name_of), name_of);
  }
  return out;
}

std::map<std::string, pipeline::OptionValue> StageFlags::For(const std::vector<pipeline::OptionSpec>& specs) const {
  std::map<std::string, pipeline::OptionValue> given = Given(), out;
  for (const auto& spec : specs) {
    auto it = given.find(spec.name);
    if (it != given.end()) out[spec.name] = it->second;
  }
  return out;
}

}  // namespace hedgefit::cli
