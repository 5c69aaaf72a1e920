#pragma once
// The benches' --sgbm-mode: stereo.sgbm's `mode` (which of OpenCV's SGBM variants, with how many
// paths), so the speed and the accuracy of each can be measured on the benches' own data.

#include <string>
#include <vector>

#include "pipeline/option_table.hpp"
#include "stereo/matching.hpp"

namespace hedgefit::bench {

/// `table` with option `sgbm_mode`, bound to the SgbmOptions that `sgbm` (O& -> SgbmOptions&)
/// reaches; its names and help are stereo.sgbm's `mode`'s.
template <class O, class Access>
pipeline::OptionTable<O>& WithSgbmMode(pipeline::OptionTable<O>& table, Access sgbm) {
  const pipeline::OptionTable<stereo::SgbmOptions>* inner = &stereo::SgbmOptions::Table();
  pipeline::OptionSpec mode;
  for (const pipeline::OptionSpec& s : inner->Specs()) {
    if (s.name == "mode") mode = s;
  }
  return table
      .AddCustom(
          "sgbm_mode", pipeline::OptionType::kString,
          "SGBM's " + mode.help + " (stereo.sgbm's mode; hh is the paper's and the default)", "",
          [inner, sgbm](const O& o) { return inner->Values(sgbm(const_cast<O&>(o))).at("mode"); },
          [inner, sgbm](O& o, const pipeline::OptionValue& v) { inner->Apply({{"mode", v}}, &sgbm(o)); })
      .Choices(mode.choices);
}

}  // namespace hedgefit::bench
