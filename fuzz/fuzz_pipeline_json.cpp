// Fuzzes pipeline JSON: parsing, stage lookup and every stage's option validation, as
// `hedgefit pipeline` does before anything runs. Nothing is run (a pipeline reads and writes
// files), so this covers everything a pipeline file can do before its first stage.

#include <cstdint>
#include <string>

#include "pipeline/error.hpp"
#include "cloud/cloud_stages.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "fitting/fitting_stages.hpp"
#include "stereo/stereo_stages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const hedgefit::pipeline::Registry registry = [] {
    hedgefit::pipeline::Registry r;
    hedgefit::cloud::RegisterCloudStages(r);
    hedgefit::fitting::RegisterFittingStages(r);
    hedgefit::stereo::RegisterStereoStages(r);
    return r;
  }();
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    hedgefit::pipeline::Pipeline::FromJson(text, "fuzz.json", registry);
  } catch (const hedgefit::Error&) {
  }
  return 0;
}
