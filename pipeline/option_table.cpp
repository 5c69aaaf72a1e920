#include "pipeline/option_table.hpp"

namespace hedgefit::pipeline {

std::string FlagName(const std::string& option) {
  std::string out = "--" + option;
  for (char& c : out) {
    if (c == '_') c = '-';
  }
  return out;
}

}  // namespace hedgefit::pipeline
