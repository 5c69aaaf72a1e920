#pragma once
// libhedgefit_pclio.so: PCL's PCD and PLY writers and its LZF decoder. pcl_io loads VTK, OpenNI,
// Boost and MPI's libraries at start-up (a tenth of a second on this project's machine), so it
// lives in a module of its own, which cloud/formats/pcl_io.cpp loads the first time a PCD or PLY
// file is written or a compressed PCD read. Every entry point returns 0 on success.

#include <pcl/PCLPointCloud2.h>

#define HEDGEFIT_PCLIO_WRITE_PCD_SYMBOL "hedgefit_pclio_write_pcd_v1"
#define HEDGEFIT_PCLIO_WRITE_PLY_SYMBOL "hedgefit_pclio_write_ply_v1"
#define HEDGEFIT_PCLIO_LZF_SYMBOL "hedgefit_pclio_lzf_decompress_v1"

namespace hedgefit::cloud::internal {

/// `encoding`: 0 ascii (with `precision` digits), 1 binary, 2 binary_compressed.
using PcdWriteFn = int (*)(const char* path, const pcl::PCLPointCloud2* blob, int encoding, int precision);
/// Binary little-endian PLY.
using PlyWriteFn = int (*)(const char* path, const pcl::PCLPointCloud2* blob);
/// `packed` (LZF) into `unpacked`, which must take exactly `unpacked_size` bytes.
using LzfDecompressFn = int (*)(const void* packed, unsigned packed_size, void* unpacked, unsigned unpacked_size);

}  // namespace hedgefit::cloud::internal
