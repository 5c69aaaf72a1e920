#pragma once
// The command line's small value syntaxes, parsed in one place: "COLSxROWS" sizes and
// comma-separated numbers. Errors name the flag, the text and an example.

#include <CLI/CLI.hpp>

#include <string>
#include <utility>
#include <vector>

namespace hedgefit::apps {

/// "640x480" (or "640X480") -> {640, 480}; each at least `min`. `what` and `example` make the
/// message: "--size '64x': give WIDTHxHEIGHT in px, e.g. 640x480".
std::pair<int, int> ParseCount2(const std::string& text, const std::string& flag, int min, const std::string& what,
                                const std::string& example);

/// "1,2,3" -> {1, 2, 3}: exactly `n` finite numbers.
std::vector<double> ParseNumbers(const std::string& text, std::size_t n, const std::string& flag);

/// Lists `cmd`'s flags under headings in --help: {"Inputs", {"--left", "--right"}}, ... in order.
/// A flag named here that the command lacks is a programming error (CLI11 throws at start-up,
/// and the docs test, which runs every --help, fails).
void GroupFlags(CLI::App* cmd, const std::vector<std::pair<std::string, std::vector<std::string>>>& groups);

}  // namespace hedgefit::apps
