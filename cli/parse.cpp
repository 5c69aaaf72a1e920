#include "cli/parse.hpp"

#include <cmath>
#include <sstream>

#include "pipeline/error.hpp"

namespace hedgefit::cli {

std::pair<int, int> ParseCount2(const std::string& text, const std::string& flag, int min, const std::string& what,
                                const std::string& example) {
  long long w = 0, h = 0;
  char x = 0;
  std::istringstream ss(text);
  if (!(ss >> w >> x >> h) || (x != 'x' && x != 'X') || !ss.eof() || w < min || h < min || w > 1000000 ||
      h > 1000000) {
    throw Error(flag + " '" + text + "': give " + what + (min > 1 ? ", each at least " + std::to_string(min) : "") +
                ", e.g. " + example);
  }
  return {int(w), int(h)};
}

std::vector<double> ParseNumbers(const std::string& text, std::size_t n, const std::string& flag) {
  std::vector<double> v;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size() || !std::isfinite(v.back())) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw Error(flag + " '" + text + "': '" + item + "' is not a finite number");
    }
  }
  if (v.size() != n) throw Error(flag + " '" + text + "': expected " + std::to_string(n) + " comma-separated numbers");
  return v;
}

void GroupFlags(CLI::App* cmd, const std::vector<std::pair<std::string, std::vector<std::string>>>& groups) {
  for (const auto& [heading, flags] : groups) {
    for (const auto& flag : flags) cmd->get_option(flag)->group(heading);
  }
}

}  // namespace hedgefit::cli
