#pragma once
/// Maps stage type names to factories. Built-in stages are added by explicit
/// Register*Stages() calls (so no linker can drop them); plugins add theirs
/// through the entry point declared in cloud/plugin.hpp.

#include <string>
#include <vector>

#include "cloud/stage.hpp"

namespace hedgefit::cloud {

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
  const std::vector<StageDescriptor>& stages() const { return stages_; }
  std::vector<std::string> Names() const;

  std::vector<PluginReport> plugin_reports;  ///< filled by LoadPlugins

  /// The process-wide registry with cloud/'s built-in stages registered.
  static Registry& Global();

 private:
  std::vector<StageDescriptor> stages_;
};

/// Adds readers.*, writers.* and filters.* (cloud/'s built-ins) to `registry`.
void RegisterCloudStages(Registry& registry);

}  // namespace hedgefit::cloud
