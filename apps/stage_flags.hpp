#pragma once
// Command-line flags generated from declared options (cloud::OptionSpec): one flag per option,
// spelled FlagName(option) ("mean_k" -> "--mean-k"), with the declaration's help, unit and
// default. What the user typed is parsed and checked by the same code as a pipeline's JSON,
// and messages name the flag as typed.

#include <CLI/CLI.hpp>

#include <map>
#include <string>
#include <vector>

#include "cloud/stage.hpp"

namespace hedgefit::apps {

/// "option 'block_size': why" -> "--block-size: why": a declaration's message as the command
/// line spells the option. Other messages are returned as they are.
std::string AsFlagMessage(const std::string& message);

class StageFlags {
 public:
  /// Adds a flag for each of `specs` (all, or only those named in `only`). An option already
  /// added (same name, e.g. min_z of two stages) keeps its first flag, which then sets both.
  void Add(CLI::App* cmd, const std::vector<cloud::OptionSpec>& specs, const std::vector<std::string>& only = {});

  /// The options the user gave, parsed and checked against their declarations; throws
  /// hedgefit::Error naming the flag ("--block-size: 40 is out of range; ...").
  std::map<std::string, cloud::OptionValue> Given() const;

  /// Given() restricted to the options `specs` declares: what to pass to one stage.
  std::map<std::string, cloud::OptionValue> For(const std::vector<cloud::OptionSpec>& specs) const;

 private:
  struct Flag {
    cloud::OptionSpec spec;
    CLI::Option* option = nullptr;
    std::string text;
  };
  std::vector<std::unique_ptr<Flag>> flags_;
};

}  // namespace hedgefit::apps
