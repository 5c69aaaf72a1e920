#pragma once
/// Options declared once, PDAL's way: each option is bound to a field of an algorithm's
/// parameter struct, with its name, help, unit, range and choices; its default is the field's
/// default in the struct. A stage's option list, its parsing, the struct's Check(), the CLI
/// flags a command exposes and `plugins --json` all come from one OptionTable.
///
///   const pipeline::OptionTable<VoxelGridOptions>& VoxelGridOptions::Table() {
///     static const auto table = pipeline::OptionTable<VoxelGridOptions>()
///         .Add("leaf", &VoxelGridOptions::leaf_mm, "voxel edge length", "mm").Min(1e-6);
///     return table;
///   }

#include <Eigen/Core>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "pipeline/stage.hpp"

namespace hedgefit::pipeline {

/// The name of `value` in an enum's name list (the one AddEnum takes), or "?".
template <class E>
const char* EnumName(const std::vector<std::pair<std::string, E>>& names, E value) {
  for (const auto& [name, v] : names) {
    if (v == value) return name.c_str();
  }
  return "?";
}

/// "mean_k" -> "--mean-k": the command-line spelling of an option.
std::string FlagName(const std::string& option);

template <class P>
class OptionTable {
 public:
  /// Binds option `name` to `field` (bool, integral, floating point, std::string, or a 3-vector).
  template <class T>
  OptionTable& Add(std::string name, T P::*field, std::string help, std::string unit = "") {
    return Bind<T>(std::move(name), [field](P& p) -> T& { return p.*field; }, std::move(help), std::move(unit));
  }

  /// Binds an option to a field reached through `access` (P& -> T&), e.g. a nested struct's field.
  template <class T, class Access>
  OptionTable& Bind(std::string name, Access access, std::string help, std::string unit = "") {
    Binding b;
    b.spec.name = std::move(name);
    b.spec.help = std::move(help);
    b.spec.unit = std::move(unit);
    b.spec.type = TypeOf<T>();
    if constexpr (IsVector3<T>()) b.spec.list_size = 3;
    b.get = [access](const P& p) { return ToValue(access(const_cast<P&>(p))); };
    b.set = [access](P& p, const OptionValue& v) { FromValue(v, &access(p)); };
    return Push(std::move(b));
  }

  /// Binds a string option to an enum field through its names (the choices, in order).
  template <class E>
  OptionTable& AddEnum(std::string name, E P::*field, std::vector<std::pair<std::string, E>> names, std::string help) {
    Binding b;
    b.spec.name = std::move(name);
    b.spec.help = std::move(help);
    b.spec.type = OptionType::kString;
    for (const auto& n : names) b.spec.choices.push_back(n.first);
    b.get = [field, names](const P& p) -> OptionValue {
      for (const auto& n : names) {
        if (p.*field == n.second) return n.first;
      }
      return std::string("?");
    };
    b.set = [field, names](P& p, const OptionValue& v) {
      for (const auto& n : names) {
        if (std::get<std::string>(v) == n.first) p.*field = n.second;
      }
    };
    return Push(std::move(b));
  }

  /// An option with its own conversion, for a field whose type is not a plain one (a list of
  /// enum values, an array): `set` may throw hedgefit::Error("option 'NAME': ...").
  OptionTable& AddCustom(std::string name, OptionType type, std::string help, std::string unit,
                         std::function<OptionValue(const P&)> get, std::function<void(P&, const OptionValue&)> set) {
    Binding b;
    b.spec.name = std::move(name);
    b.spec.type = type;
    b.spec.help = std::move(help);
    b.spec.unit = std::move(unit);
    b.get = std::move(get);
    b.set = std::move(set);
    return Push(std::move(b));
  }

  /// Adds `inner`'s options, bound to the nested struct `field` (except those named in `skip`).
  template <class Q>
  OptionTable& Nest(const OptionTable<Q>& inner, Q P::*field, const std::vector<std::string>& skip = {}) {
    for (const auto& b : inner.bindings_) {
      if (std::find(skip.begin(), skip.end(), b.spec.name) != skip.end()) continue;
      Binding nb;
      nb.spec = b.spec;
      nb.get = [get = b.get, field](const P& p) { return get(p.*field); };
      nb.set = [set = b.set, field](P& p, const OptionValue& v) { set(p.*field, v); };
      Push(std::move(nb));
    }
    return *this;
  }

  /// Required length of the list option added last.
  OptionTable& ListSize(std::size_t n) { bindings_.back().spec.list_size = n; return *this; }

  /// Limits of the option added last (inclusive; numbers and each list element).
  OptionTable& Range(double lo, double hi) { bindings_.back().spec.Range(lo, hi); return *this; }
  OptionTable& Min(double lo) { bindings_.back().spec.Min(lo); return *this; }
  /// Allowed strings of the option added last.
  OptionTable& Choices(std::vector<std::string> c) { bindings_.back().spec.Choices(std::move(c)); return *this; }

  /// The declarations, defaults taken from a default-constructed P.
  std::vector<OptionSpec> Specs() const {
    std::vector<OptionSpec> out;
    for (const auto& b : bindings_) out.push_back(b.spec);
    return out;
  }

  /// Resolved options (every declared one present) into a struct: starts from P's defaults.
  P FromOptions(const Options& options) const {
    P p{};
    for (const auto& b : bindings_) {
      auto it = options.values().find(b.spec.name);
      if (it != options.values().end()) b.set(p, it->second);
    }
    return p;
  }

  /// Sets the options in `given` (already checked: CheckOptionValue) on `p`, leaving the rest.
  void Apply(const std::map<std::string, OptionValue>& given, P* p) const {
    for (const auto& b : bindings_) {
      auto it = given.find(b.spec.name);
      if (it != given.end()) b.set(*p, it->second);
    }
  }

  /// The struct's values as options, e.g. to build a stage from a struct.
  std::map<std::string, OptionValue> Values(const P& p) const {
    std::map<std::string, OptionValue> out;
    for (const auto& b : bindings_) out[b.spec.name] = b.get(p);
    return out;
  }

  /// Checks every bound field against its declaration; the message names the option through
  /// `name_of` ("option 'mean_k'" by default). Cross-field rules stay in the struct's Check().
  void Validate(const P& p, const OptionNamer& name_of = StageOptionNamer("")) const {
    for (const auto& b : bindings_) CheckOptionValue(b.spec, b.get(p), name_of);
  }

 private:
  template <class>
  friend class OptionTable;

  struct Binding {
    OptionSpec spec;
    std::function<OptionValue(const P&)> get;
    std::function<void(P&, const OptionValue&)> set;
  };

  OptionTable& Push(Binding b) {
    static const P defaults{};
    b.spec.default_value = b.get(defaults);
    bindings_.push_back(std::move(b));
    return *this;
  }

  template <class T>
  static constexpr bool IsVector3() {
    return std::is_same_v<T, Eigen::Vector3f> || std::is_same_v<T, Eigen::Vector3d>;
  }
  template <class T>
  static constexpr bool IsList() {
    return std::is_same_v<T, std::vector<double>>;
  }

  template <class T>
  static constexpr OptionType TypeOf() {
    if constexpr (std::is_same_v<T, bool>) return OptionType::kBool;
    else if constexpr (std::is_integral_v<T>) return OptionType::kInt;
    else if constexpr (std::is_floating_point_v<T>) return OptionType::kDouble;
    else if constexpr (std::is_same_v<T, std::string>) return OptionType::kString;
    else {
      static_assert(IsVector3<T>() || IsList<T>(), "OptionTable: unsupported field type");
      return OptionType::kDoubleList;
    }
  }

  template <class T>
  static OptionValue ToValue(const T& v) {
    if constexpr (std::is_same_v<T, bool>) return v;
    else if constexpr (std::is_integral_v<T>) return static_cast<std::int64_t>(v);
    else if constexpr (std::is_floating_point_v<T>) return static_cast<double>(v);
    else if constexpr (std::is_same_v<T, std::string>) return v;
    else if constexpr (IsList<T>()) return v;
    else return std::vector<double>{double(v[0]), double(v[1]), double(v[2])};
  }

  template <class T>
  static void FromValue(const OptionValue& v, T* out) {
    if constexpr (std::is_same_v<T, bool>) {
      *out = std::get<bool>(v);
    } else if constexpr (std::is_integral_v<T>) {
      *out = static_cast<T>(std::get<std::int64_t>(v));
    } else if constexpr (std::is_floating_point_v<T>) {
      const auto* i = std::get_if<std::int64_t>(&v);
      *out = static_cast<T>(i ? double(*i) : std::get<double>(v));
    } else if constexpr (std::is_same_v<T, std::string>) {
      *out = std::get<std::string>(v);
    } else if constexpr (IsList<T>()) {
      *out = std::get<std::vector<double>>(v);
    } else {
      const auto& l = std::get<std::vector<double>>(v);
      for (int k = 0; k < 3; ++k) (*out)[k] = static_cast<typename T::Scalar>(l[std::size_t(k)]);
    }
  }

  std::vector<Binding> bindings_;
};

}  // namespace hedgefit::pipeline

namespace hedgefit::pipeline {

/// A stage's declarations: P's table, then `extra` stage-only options (a seed that defaults to
/// the pipeline's, an output switch, ...).
template <class P>
std::vector<OptionSpec> TableOptions(std::vector<OptionSpec> extra = {}) {
  std::vector<OptionSpec> out = P::Table().Specs();
  for (auto& e : extra) out.push_back(std::move(e));
  return out;
}

/// A factory for a stage whose options are P's table: P is built from the options and checked
/// once, when the pipeline is built (so bad values fail before anything runs), then
/// run(params, options, ctx) runs for each run.
template <class P, class RunFn>
StageFactory TableFactory(std::string stage, RunFn run) {
  return [stage, run](const Options& o) -> std::unique_ptr<Stage> {
    const P params = CheckedParams(P::Table().FromOptions(o), stage);
    return std::make_unique<LambdaStage>(o, [params, run](const Options& opts, Context& ctx) { run(params, opts, ctx); });
  };
}

}  // namespace hedgefit::pipeline
