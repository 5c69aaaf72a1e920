// Fuzzes the cloud readers (PCD, PLY, XYZ, LAS): any bytes either read into a consistent cloud or are
// refused with hedgefit::Error. The format comes from HEDGEFIT_FUZZ_EXTENSION (".pcd", ...).

#include <cstdint>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "fuzz/fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = hedgefit::fuzz::AsFile(data, size, HEDGEFIT_FUZZ_EXTENSION);
  try {
    const hedgefit::cloud::PointCloud c = hedgefit::cloud::ReadCloud(path);
    c.CheckConsistent(path);  // what was read must hold together
  } catch (const hedgefit::Error&) {
  }
  return 0;
}
