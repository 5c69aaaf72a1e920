// Fuzzes the rig reader: any bytes are a usable, checked rig or a hedgefit::Error.

#include <cstdint>

#include "pipeline/error.hpp"
#include "fuzz/fuzz_common.hpp"
#include "stereo/rig.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = hedgefit::fuzz::AsFile(data, size, ".yaml");
  try {
    hedgefit::stereo::ReadRig(path);
  } catch (const hedgefit::Error&) {
  }
  return 0;
}
