#pragma once
// The command line's small value syntaxes, parsed in one place: "COLSxROWS" sizes and
// comma-separated numbers. Errors name the flag, the text and an example.

#include <CLI/CLI.hpp>

#include <string>
#include <utility>
#include <vector>

namespace hedgefit::cli {

/// "640x480" (or "640X480") -> {640, 480}; each at least `min`. `what` and `example` make the
/// message: "--size '64x': give WIDTHxHEIGHT in px, e.g. 640x480".
std::pair<int, int> ParseCount2(const std::string& text, const std::string& flag, int min, const std::string& what,
                                const std::string& example);

/// "1,2,3" -> {1, 2, 3}: exactly `n` finite numbers.
std::vector<double> ParseNumbers(const std::string& text, std::size_t n, const std::string& flag);

/// A seed: a whole number of 0 or more. An unsigned option takes "-1" as 2^64 - 1 without a
/// word; this says "--seed: -1: give a whole number of 0 or more".
inline CLI::Validator Seed() {
  return CLI::Validator(
      [](std::string& text) {
        return !text.empty() && text.find_first_not_of("0123456789") == std::string::npos
                   ? std::string()
                   : text + ": give a whole number of 0 or more";
      },
      "SEED");
}

/// Lists `cmd`'s flags under headings in --help: {"Inputs", {"--left", "--right"}}, ... in order.
/// A flag named here that the command lacks is a programming error (CLI11 throws at start-up,
/// and the docs test, which runs every --help, fails).
void GroupFlags(CLI::App* cmd, const std::vector<std::pair<std::string, std::vector<std::string>>>& groups);

}  // namespace hedgefit::cli
