#pragma once
/// Pipeline stages, PDAL-style: a stage has a type name, a one-line description
/// and declared options. Help text, JSON parsing and validation all come from
/// that one declaration (StageInfo); a stage itself is a thin adapter around a
/// free function.

#include <any>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "pipeline/error.hpp"

namespace hedgefit::pipeline {

enum class OptionType { kBool, kInt, kDouble, kString, kDoubleList };

/// The JSON-ish name of a type, for help and error messages ("integer", ...).
const char* TypeName(OptionType type);

using OptionValue = std::variant<bool, std::int64_t, double, std::string, std::vector<double>>;

/// Renders a value as JSON text (strings quoted, lists bracketed).
std::string ToString(const OptionValue& value);

/// One declared option: everything help, parsing and validation need.
struct OptionSpec {
  std::string name;
  OptionType type = OptionType::kString;
  OptionValue default_value;  ///< used when the pipeline omits the option
  std::string help;           ///< one line
  std::string unit;           ///< "mm", "px", "points", ... or empty
  std::optional<double> min;  ///< inclusive lower bound (numbers; each list element)
  std::optional<double> max;  ///< inclusive upper bound
  std::vector<std::string> choices;  ///< allowed strings, empty = any
  std::size_t list_size = 0;         ///< kDoubleList: required length, 0 = any

  OptionSpec& Range(double lo, double hi) { min = lo; max = hi; return *this; }
  OptionSpec& Min(double lo) { min = lo; return *this; }
  OptionSpec& Choices(std::vector<std::string> c) { choices = std::move(c); return *this; }
};

OptionSpec BoolOption(std::string name, bool def, std::string help);
OptionSpec IntOption(std::string name, std::int64_t def, std::string help, std::string unit = "");
OptionSpec DoubleOption(std::string name, double def, std::string help, std::string unit = "");
OptionSpec StringOption(std::string name, std::string def, std::string help);
OptionSpec ListOption(std::string name, std::vector<double> def, std::size_t size, std::string help,
                      std::string unit = "");

/// What a stage is: name, description, options, and the artifacts it reads and
/// writes (so a pipeline can be checked before anything runs).
struct StageInfo {
  std::string name;         ///< "filters.statistical_outlier"
  std::string description;  ///< one line
  std::vector<OptionSpec> options;
  std::vector<std::string> inputs;      ///< artifacts it needs, e.g. {"cloud"}
  std::vector<std::string> outputs;     ///< artifacts it produces
  std::vector<std::string> extensions;  ///< readers/writers: ".pcd", ...; chosen for bare filenames

  const OptionSpec* FindOption(const std::string& option) const;
};

/// Option values after validation: every declared option has a value.
class Options {
 public:
  Options() = default;
  explicit Options(std::map<std::string, OptionValue> values) : values_(std::move(values)) {}

  bool GetBool(const std::string& name) const;
  std::int64_t GetInt(const std::string& name) const;
  double GetDouble(const std::string& name) const;  ///< also accepts an integer value
  const std::string& GetString(const std::string& name) const;
  const std::vector<double>& GetList(const std::string& name) const;
  const std::map<std::string, OptionValue>& values() const { return values_; }

 private:
  const OptionValue& At(const std::string& name) const;
  std::map<std::string, OptionValue> values_;
};

/// How messages name an option: "stage 'filters.x', option 'mean_k'" in a pipeline, "--mean-k" on
/// a command line, "option 'mean_k'" in a parameter struct's Check().
using OptionNamer = std::function<std::string(const std::string& option)>;

/// "stage 'LABEL', option 'NAME'", or "option 'NAME'" when the label is empty.
OptionNamer StageOptionNamer(std::string stage_label);

/// Checks one value against its declaration (type, finite, range, choices, list length) and
/// returns it in the declared type (an integral number for an integer option, ...).
OptionValue CheckOptionValue(const OptionSpec& spec, const OptionValue& given, const OptionNamer& name_of);

/// Checks `given` against `info`: unknown option (with a "did you mean"), wrong
/// type, out of range, bad choice. Fills in defaults. Throws Error naming
/// `stage_label` and the option.
Options ResolveOptions(const StageInfo& info, const std::map<std::string, OptionValue>& given,
                       const std::string& stage_label);

/// Parses a command-line string ("30", "true", "[1,2,3]") as the option's declared type.
OptionValue ParseOptionString(const OptionSpec& spec, const std::string& text,
                              const std::string& stage_label);
OptionValue ParseOptionString(const OptionSpec& spec, const std::string& text, const OptionNamer& name_of);

/// Closest candidate by edit distance, or "" if none is close enough to suggest.
std::string DidYouMean(const std::string& word, const std::vector<std::string>& candidates);

/// The named artifacts that flow between stages: clouds, images, disparity maps,
/// fit results. Stored type-erased so cloud/ needs no OpenCV or fitting types.
class Context {
 public:
  template <class T>
  void Put(const std::string& name, T value) {
    if constexpr (HasSize<T>::value) {
      sizes_[name] = [](const std::any& a) { return static_cast<std::int64_t>(std::any_cast<const T&>(a).size()); };
    } else {
      sizes_.erase(name);
    }
    artifacts_[name] = std::move(value);
  }
  /// The artifact's size() (a cloud's points), or -1 when it is absent or has no size().
  std::int64_t SizeOf(const std::string& name) const {
    auto it = artifacts_.find(name);
    auto s = sizes_.find(name);
    return it == artifacts_.end() || s == sizes_.end() ? -1 : s->second(it->second);
  }
  bool Has(const std::string& name) const { return artifacts_.count(name) > 0; }
  /// The artifact, or nullptr if absent or of another type.
  template <class T>
  T* Find(const std::string& name) {
    auto it = artifacts_.find(name);
    return it == artifacts_.end() ? nullptr : std::any_cast<T>(&it->second);
  }
  /// The artifact; throws Error naming the current stage if it is missing.
  template <class T>
  T& Get(const std::string& name) {
    T* value = Find<T>(name);
    if (value == nullptr) {
      throw Error("stage '" + current_stage + "': needs a '" + name +
                  "' artifact, but no earlier stage produced one; add a stage that does");
    }
    return *value;
  }
  void Erase(const std::string& name) {
    artifacts_.erase(name);
    sizes_.erase(name);
  }

  /// Where a writer should write `path`: while a pipeline runs, a hidden file beside it (same
  /// extension) that Pipeline::Run renames to `path` only once every stage has succeeded, and
  /// removes otherwise, so a failed run leaves every existing file as it was. Outside a
  /// pipeline run, `path` itself.
  std::string OutputPath(const std::string& path);

  /// Records a fact about the current stage for the run's metadata.
  void Note(const std::string& key, OptionValue value) { notes[current_stage][key] = std::move(value); }

  std::string current_stage;  ///< label of the running stage (set by the pipeline)
  std::uint64_t seed = 42;    ///< base seed; stages that draw random numbers derive theirs from it
  bool quiet = false;         ///< stages print nothing when true
  std::map<std::string, std::map<std::string, OptionValue>> notes;
  bool stage_outputs = false;  ///< set by Pipeline::Run: OutputPath stages files until the end
  std::vector<std::pair<std::string, std::string>> staged_outputs;  ///< (hidden file, final path)

 private:
  template <class T, class = void>
  struct HasSize : std::false_type {};
  template <class T>
  struct HasSize<T, std::enable_if_t<std::is_integral_v<decltype(std::declval<const T&>().size())>>>
      : std::true_type {};  // a count (a cloud's points), not cv::Mat's Size

  std::map<std::string, std::any> artifacts_;
  std::map<std::string, std::int64_t (*)(const std::any&)> sizes_;
};

/// A configured stage, ready to run.
class Stage {
 public:
  virtual ~Stage() = default;
  /// Reads its inputs from `ctx` and writes its outputs. Throws Error on bad input.
  virtual void Run(Context& ctx) = 0;
};

using StageFactory = std::function<std::unique_ptr<Stage>(const Options&)>;

/// Adapts a plain function into a Stage: `fn(options, ctx)`.
class LambdaStage : public Stage {
 public:
  using Fn = std::function<void(const Options&, Context&)>;
  LambdaStage(Options options, Fn fn) : options_(std::move(options)), fn_(std::move(fn)) {}
  void Run(Context& ctx) override { fn_(options_, ctx); }

 private:
  Options options_;
  Fn fn_;
};

/// Calls params.Check() and prefixes its error with the stage name, so a message such as
/// "mean_k: must be >= 1" becomes "stage 'filters.x', option mean_k: must be >= 1".
template <class Params>
Params CheckedParams(Params params, const std::string& stage) {
  try {
    params.Check();
  } catch (const Error& e) {
    const std::string what = e.what();
    throw Error("stage '" + stage + "', " + (what.rfind("option '", 0) == 0 ? "" : "option ") + what);
  }
  return params;
}

/// A factory for a LambdaStage around `fn`.
StageFactory MakeFactory(LambdaStage::Fn fn);

/// A factory that converts Options into an algorithm's parameter struct once,
/// when the pipeline is built (so `to_params` can reject bad combinations before
/// anything runs), then calls `run(params, ctx)` for each run.
template <class Params, class ToParams, class RunFn>
StageFactory MakeParamsFactory(ToParams to_params, RunFn run) {
  return [to_params, run](const Options& options) -> std::unique_ptr<Stage> {
    Params params = to_params(options);
    return std::make_unique<LambdaStage>(
        options, [params, run](const Options&, Context& ctx) { run(params, ctx); });
  };
}

}  // namespace hedgefit::pipeline
