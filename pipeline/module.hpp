#pragma once
// hedgefit's own modules: MODULE libraries loaded on first use (image codecs, video, PCL's
// writers, VTK's renderer), so that a command that needs none of them does not load their
// dependencies at start-up.

#include <string>

namespace hedgefit::pipeline {

/// Opens module `name` (e.g. "libhedgefit_video.so"): beside the library that holds `anchor` (the
/// build tree's folder, or the install's lib/), then on the loader's path, then beside the
/// executable. Never unloaded (its code outlives the call). nullptr, with `why` saying why, when
/// none of these opens.
void* OpenOwnModule(const char* name, const void* anchor, std::string* why);

}  // namespace hedgefit::pipeline
