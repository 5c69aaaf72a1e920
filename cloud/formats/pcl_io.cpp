#include "cloud/formats/pcl_io.hpp"

#include <dlfcn.h>

#include <mutex>

#include "pipeline/module.hpp"

namespace hedgefit::cloud::internal {

const PclIo& LoadPclIo(const std::string& path) {
  static std::once_flag once;
  static PclIo m;
  static std::string why;
  std::call_once(once, [] {
    const char* name = "libhedgefit_pclio.so";
    void* handle = pipeline::OpenOwnModule(name, reinterpret_cast<const void*>(&LoadPclIo), &why);
    if (handle == nullptr) return;
    m.write_pcd = reinterpret_cast<PcdWriteFn>(dlsym(handle, HEDGEFIT_PCLIO_WRITE_PCD_SYMBOL));
    m.write_ply = reinterpret_cast<PlyWriteFn>(dlsym(handle, HEDGEFIT_PCLIO_WRITE_PLY_SYMBOL));
    m.lzf_decompress = reinterpret_cast<LzfDecompressFn>(dlsym(handle, HEDGEFIT_PCLIO_LZF_SYMBOL));
    if (!m.write_pcd || !m.write_ply || !m.lzf_decompress) m = PclIo{}, why = std::string(name) + " lacks its entry points";
  });
  if (!m.write_pcd) {
    throw Error(path + ": PCD and PLY writing and compressed PCD need hedgefit's PCL I/O module, which cannot be loaded (" +
                why + "); reinstall hedgefit, or write .xyz or .las");
  }
  return m;
}

}  // namespace hedgefit::cloud::internal
