#pragma once
// PCL's writers and LZF decoder, from libhedgefit_pclio.so (pcl_io_module.hpp). Private to cloud/.

#include <string>

#include "cloud/formats/pcl_io_module.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::cloud::internal {

struct PclIo {
  PcdWriteFn write_pcd = nullptr;
  PlyWriteFn write_ply = nullptr;
  LzfDecompressFn lzf_decompress = nullptr;
};

/// The module's entry points, loaded on the first call. Throws hedgefit::Error naming `path` (the
/// file being read or written) when the module cannot be loaded.
const PclIo& LoadPclIo(const std::string& path);

}  // namespace hedgefit::cloud::internal
