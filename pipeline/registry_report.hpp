#pragma once
/// What a registry holds, as `hedgefit plugins` shows it: every stage with its options, the
/// plugin search path, and each plugin file loaded or skipped (and why).

#include <ostream>
#include <string>

#include "pipeline/registry.hpp"

namespace hedgefit::pipeline {

/// {"search_path": [...], "stages": [{name, description, origin, inputs, outputs, extensions,
/// options: [{name, type, default, help, unit, min, max, choices}]}], "plugins": [...]}.
std::string RegistryJson(const Registry& registry);

/// The same as text, one stage per paragraph.
void PrintRegistry(std::ostream& out, const Registry& registry);

}  // namespace hedgefit::pipeline
