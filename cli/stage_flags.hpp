#pragma once
// Command-line flags generated from declared options (pipeline::OptionSpec): one flag per option,
// spelled FlagName(option) ("mean_k" -> "--mean-k"), with the declaration's help, unit and
// default. What the user typed is parsed and checked by the same code as a pipeline's JSON,
// and messages name the flag as typed.

#include <CLI/CLI.hpp>

#include <map>
#include <string>
#include <vector>

#include "pipeline/stage.hpp"

namespace hedgefit::cli {

/// "option 'block_size': why" -> "--block-size: why": a declaration's message as the command
/// line spells each option it names. Other messages are returned as they are.
std::string AsFlagMessage(const std::string& message);

class StageFlags {
 public:
  /// Adds a flag for each of `specs` (all, or only those named in `only`). An option already
  /// added (same name, e.g. min_z of two stages) keeps its first flag, which then sets both.
  /// `group` is the heading the flags are listed under in --help; `flag_names` spells some flags
  /// otherwise than FlagName(option) (compare's RANSAC "method" is --estimator there).
  void Add(CLI::App* cmd, const std::vector<pipeline::OptionSpec>& specs, const std::vector<std::string>& only = {},
           const std::string& group = "", const std::map<std::string, std::string>& flag_names = {});

  /// The options the user gave, parsed and checked against their declarations; throws
  /// hedgefit::Error naming the flag ("--block-size: 40 is out of range; ...").
  std::map<std::string, pipeline::OptionValue> Given() const;

  /// Given() restricted to the options `specs` declares: what to pass to one stage.
  std::map<std::string, pipeline::OptionValue> For(const std::vector<pipeline::OptionSpec>& specs) const;

 private:
  struct Flag {
    pipeline::OptionSpec spec;
    CLI::Option* option = nullptr;
    std::string text;
  };
  std::vector<std::unique_ptr<Flag>> flags_;
};

}  // namespace hedgefit::cli
