// Fuzzes the capture image loader (readers.stereo's): any bytes are an 8-bit BGR image or a
// hedgefit::Error naming the file. The extension does not matter to OpenCV, which sniffs the
// content, so one harness covers PNG, JPEG and the other decoders.

#include <cstdint>

#include "pipeline/error.hpp"
#include "fuzz/fuzz_common.hpp"
#include "stereo/stereo_stages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = hedgefit::fuzz::AsFile(data, size, ".png");
  try {
    const cv::Mat m = hedgefit::stereo::ReadCaptureImage(path);
    if (m.type() != CV_8UC3) __builtin_trap();
  } catch (const hedgefit::Error&) {
  }
  return 0;
}
