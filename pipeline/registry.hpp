#pragma once
/// Maps stage type names to factories. Built-in stages are added by explicit
/// Register*Stages() calls (so no linker can drop them); plugins add theirs
/// through the entry point declared in pipeline/plugin.hpp.

#include <string>
#include <vector>

#include "pipeline/stage.hpp"

namespace hedgefit::pipeline {

/// Inputs a stage needs only with some options, each with why (fitters.geometric with
/// initial = previous needs 'fits'); a pipeline checks them like StageInfo::inputs.
using OptionInputs = std::function<std::vector<std::pair<std::string, std::string>>(const Options&)>;

struct StageDescriptor {
  StageInfo info;
  StageFactory make;
  std::string origin = "builtin";  ///< "builtin" or the plugin file that added it
  OptionInputs option_inputs;      ///< may be empty
};

/// What happened to one plugin file on the search path.
struct PluginReport {
  std::string path;
  std::string name;     ///< plugin's own name, when it could be read
  std::string version;  ///< plugin's own version, when it could be read
  bool loaded = false;
  std::string message;  ///< why it was skipped, or "" when loaded
  std::vector<std::string> stages;  ///< stage names it added
};

class Registry {
 public:
  /// Adds a stage; throws Error if the name is taken or the declaration is invalid.
  void Add(StageInfo info, StageFactory make, const std::string& origin = "builtin");
  /// Declares the inputs stage `name` needs only with some options (see OptionInputs).
  void SetOptionInputs(const std::string& name, OptionInputs fn);
  /// nullptr if unknown.
  const StageDescriptor* Find(const std::string& name) const;
  /// Throws Error with a "did you mean" when `name` is unknown; `where` prefixes the message.
  const StageDescriptor& Get(const std::string& name, const std::string& where) const;
  /// The reader (or writer) whose extensions include `path`'s extension, or nullptr.
  const StageDescriptor* ForExtension(const std::string& path, bool writer) const;
  /// The registered readers' (or writers') formats by their first extension: ".pcd, .ply or .xyz".
  std::string ExtensionList(bool writer) const;
  const std::vector<StageDescriptor>& stages() const { return stages_; }
  std::vector<std::string> Names() const;
  /// Runs `add(*this)` unless a module of that name was added before: how a library adds its
  /// built-in stages to a registry that others (the CLI, Python, a library call) may fill too.
  void AddModule(const std::string& module, void (*add)(Registry&));

  std::vector<PluginReport> plugin_reports;  ///< filled by LoadPlugins

  /// The process-wide registry. It starts empty: each library's Register*Stages()
  /// (cloud/cloud_stages.hpp, stereo/stereo_stages.hpp, ...) and LoadPlugins() fill it.
  static Registry& Global();

 private:
  std::vector<StageDescriptor> stages_;
  std::vector<std::string> modules_;
};

}  // namespace hedgefit::pipeline
