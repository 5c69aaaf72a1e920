#include "pipeline/stage.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <sstream>

#include <unistd.h>

namespace hedgefit::pipeline {

const char* TypeName(OptionType type) {
  switch (type) {
    case OptionType::kBool: return "boolean";
    case OptionType::kInt: return "integer";
    case OptionType::kDouble: return "number";
    case OptionType::kString: return "string";
    case OptionType::kDoubleList: return "array of numbers";
  }
  return "?";
}

namespace {

std::string FormatDouble(double v) {
  std::ostringstream os;
  os.precision(15);
  os << v;
  return os.str();
}

std::string QuoteJson(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string ToString(const OptionValue& value) {
  struct Visitor {
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(std::int64_t i) const { return std::to_string(i); }
    std::string operator()(double d) const { return FormatDouble(d); }
    std::string operator()(const std::string& s) const { return QuoteJson(s); }
    std::string operator()(const std::vector<double>& v) const {
      std::string out = "[";
      for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + FormatDouble(v[i]);
      return out + "]";
    }
  };
  return std::visit(Visitor{}, value);
}

OptionSpec BoolOption(std::string name, bool def, std::string help) {
  return OptionSpec{std::move(name), OptionType::kBool, def, std::move(help), "", {}, {}, {}, 0};
}
OptionSpec IntOption(std::string name, std::int64_t def, std::string help, std::string unit) {
  return OptionSpec{std::move(name), OptionType::kInt, def, std::move(help), std::move(unit), {}, {}, {}, 0};
}
OptionSpec DoubleOption(std::string name, double def, std::string help, std::string unit) {
  return OptionSpec{std::move(name), OptionType::kDouble, def, std::move(help), std::move(unit), {}, {}, {}, 0};
}
OptionSpec StringOption(std::string name, std::string def, std::string help) {
  return OptionSpec{std::move(name), OptionType::kString, std::move(def), std::move(help), "", {}, {}, {}, 0};
}
OptionSpec ListOption(std::string name, std::vector<double> def, std::size_t size, std::string help,
                      std::string unit) {
  return OptionSpec{std::move(name), OptionType::kDoubleList, std::move(def), std::move(help),
                    std::move(unit), {}, {}, {}, size};
}

const OptionSpec* StageInfo::FindOption(const std::string& option) const {
  for (const auto& spec : options) {
    if (spec.name == option) return &spec;
  }
  return nullptr;
}

const OptionValue& Options::At(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) throw Error("internal: option '" + name + "' was never declared");
  return it->second;
}
bool Options::GetBool(const std::string& name) const { return std::get<bool>(At(name)); }
std::int64_t Options::GetInt(const std::string& name) const { return std::get<std::int64_t>(At(name)); }
double Options::GetDouble(const std::string& name) const {
  const OptionValue& v = At(name);
  if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
  return std::get<double>(v);
}
const std::string& Options::GetString(const std::string& name) const {
  return std::get<std::string>(At(name));
}
const std::vector<double>& Options::GetList(const std::string& name) const {
  return std::get<std::vector<double>>(At(name));
}

namespace {

std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                        std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (same ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}


void CheckNumber(const OptionSpec& spec, double v, const OptionNamer& name_of) {
  if (!std::isfinite(v)) {
    throw Error(name_of(spec.name) + ": must be a finite number");
  }
  const bool below = spec.min && v < *spec.min;
  const bool above = spec.max && v > *spec.max;
  if (below || above) {
    std::string range = spec.min && spec.max
                            ? "in [" + FormatDouble(*spec.min) + ", " + FormatDouble(*spec.max) + "]"
                        : spec.min ? ">= " + FormatDouble(*spec.min)
                                   : "<= " + FormatDouble(*spec.max);
    throw Error(name_of(spec.name) + ": " + FormatDouble(v) + " is out of range; use a value " +
                range + (spec.unit.empty() ? "" : " " + spec.unit));
  }
}

// Checks one value's type (allowing an integer where a number is declared) and range.
OptionValue Validate(const OptionSpec& spec, const OptionValue& given, const OptionNamer& name_of) {
  auto wrong = [&](const std::string& got) {
    return Error(name_of(spec.name) + ": expected " + TypeName(spec.type) + ", got " + got);
  };
  const char* got_type = std::visit(
      [](const auto& v) -> const char* {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, bool>) return "boolean";
        if constexpr (std::is_same_v<T, std::int64_t>) return "integer";
        if constexpr (std::is_same_v<T, double>) return "number";
        if constexpr (std::is_same_v<T, std::string>) return "string";
        return "array";
      },
      given);
  switch (spec.type) {
    case OptionType::kBool:
      if (!std::holds_alternative<bool>(given)) throw wrong(got_type + (" " + ToString(given)));
      return given;
    case OptionType::kInt: {
      std::int64_t v = 0;
      if (const auto* i = std::get_if<std::int64_t>(&given)) {
        v = *i;
      } else if (const auto* d = std::get_if<double>(&given); d && std::floor(*d) == *d &&
                                                              std::fabs(*d) < 9e15) {
        v = static_cast<std::int64_t>(*d);
      } else {
        throw wrong(std::string(got_type) + " " + ToString(given));
      }
      CheckNumber(spec, static_cast<double>(v), name_of);
      return v;
    }
    case OptionType::kDouble: {
      double v = 0;
      if (const auto* i = std::get_if<std::int64_t>(&given)) {
        v = static_cast<double>(*i);
      } else if (const auto* d = std::get_if<double>(&given)) {
        v = *d;
      } else {
        throw wrong(std::string(got_type) + " " + ToString(given));
      }
      CheckNumber(spec, v, name_of);
      return v;
    }
    case OptionType::kString: {
      const auto* s = std::get_if<std::string>(&given);
      if (s == nullptr) throw wrong(std::string(got_type) + " " + ToString(given));
      if (!spec.choices.empty() &&
          std::find(spec.choices.begin(), spec.choices.end(), *s) == spec.choices.end()) {
        std::string list;
        for (const auto& c : spec.choices) list += (list.empty() ? "" : ", ") + c;
        std::string hint = DidYouMean(*s, spec.choices);
        throw Error(name_of(spec.name) + ": '" + *s + "' is not one of " + list +
                    (hint.empty() ? "" : " (did you mean '" + hint + "'?)"));
      }
      return given;
    }
    case OptionType::kDoubleList: {
      const auto* list = std::get_if<std::vector<double>>(&given);
      if (list == nullptr) throw wrong(std::string(got_type) + " " + ToString(given));
      if (spec.list_size != 0 && list->size() != spec.list_size) {
        throw Error(name_of(spec.name) + ": expected " + std::to_string(spec.list_size) +
                    " numbers, got " + std::to_string(list->size()));
      }
      for (double v : *list) CheckNumber(spec, v, name_of);
      return given;
    }
  }
  return given;
}

}  // namespace

OptionNamer StageOptionNamer(std::string stage_label) {
  return [stage_label](const std::string& option) {
    return stage_label.empty() ? "option '" + option + "'" : "stage '" + stage_label + "', option '" + option + "'";
  };
}

OptionValue CheckOptionValue(const OptionSpec& spec, const OptionValue& given, const OptionNamer& name_of) {
  return Validate(spec, given, name_of);
}

std::string DidYouMean(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const auto& c : candidates) {
    const std::size_t d = EditDistance(word, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

Options ResolveOptions(const StageInfo& info, const std::map<std::string, OptionValue>& given,
                       const std::string& stage_label) {
  std::map<std::string, OptionValue> values;
  for (const auto& [name, value] : given) {
    const OptionSpec* spec = info.FindOption(name);
    if (spec == nullptr) {
      std::vector<std::string> names;
      for (const auto& o : info.options) names.push_back(o.name);
      const std::string hint = DidYouMean(name, names);
      throw Error("stage '" + stage_label + "': unknown option '" + name + "'" +
                  (hint.empty() ? "" : " (did you mean '" + hint + "'?)") + "; see `hedgefit plugins` for " +
                  info.name + "'s options");
    }
    values[name] = Validate(*spec, value, StageOptionNamer(stage_label));
  }
  for (const auto& spec : info.options) {
    if (values.count(spec.name) == 0) values[spec.name] = spec.default_value;
  }
  return Options(std::move(values));
}

OptionValue ParseOptionString(const OptionSpec& spec, const std::string& text,
                              const std::string& stage_label) {
  return ParseOptionString(spec, text, StageOptionNamer(stage_label));
}

OptionValue ParseOptionString(const OptionSpec& spec, const std::string& text, const OptionNamer& name_of) {
  auto bad = [&]() {
    return Error(name_of(spec.name) + ": cannot read '" + text + "' as " + TypeName(spec.type));
  };
  switch (spec.type) {
    case OptionType::kBool:
      if (text == "true" || text == "1" || text == "on") return true;
      if (text == "false" || text == "0" || text == "off") return false;
      throw bad();
    case OptionType::kInt: {
      std::size_t used = 0;
      try {
        const long long v = std::stoll(text, &used);
        if (used != text.size()) throw bad();
        return static_cast<std::int64_t>(v);
      } catch (const std::logic_error&) {
        throw bad();
      }
    }
    case OptionType::kDouble: {
      std::size_t used = 0;
      try {
        const double v = std::stod(text, &used);
        if (used != text.size()) throw bad();
        return v;
      } catch (const std::logic_error&) {
        throw bad();
      }
    }
    case OptionType::kString: return text;
    case OptionType::kDoubleList: {
      std::string body = text;
      if (!body.empty() && body.front() == '[') body.erase(0, 1);
      if (!body.empty() && body.back() == ']') body.pop_back();
      std::vector<double> values;
      std::stringstream ss(body);
      std::string item;
      while (std::getline(ss, item, ',')) {
        std::size_t used = 0;
        try {
          values.push_back(std::stod(item, &used));
        } catch (const std::logic_error&) {
          throw bad();
        }
        while (used < item.size() && std::isspace(static_cast<unsigned char>(item[used]))) ++used;
        if (used != item.size()) throw bad();
      }
      return values;
    }
  }
  throw bad();
}

std::string Context::OutputPath(const std::string& path) {
  if (!stage_outputs) return path;
  const std::filesystem::path target(path);
  const std::filesystem::path staged =
      target.parent_path() / ("." + target.stem().string() + ".staged" + std::to_string(::getpid()) + "_" +
                              std::to_string(staged_outputs.size()) + target.extension().string());
  staged_outputs.emplace_back(staged.string(), path);
  return staged.string();
}

StageFactory MakeFactory(LambdaStage::Fn fn) {
  return [fn = std::move(fn)](const Options& options) -> std::unique_ptr<Stage> {
    return std::make_unique<LambdaStage>(options, fn);
  };
}

}  // namespace hedgefit::pipeline
