// libhedgefit_pclio.so (cloud/formats/pcl_io_module.hpp): PCL's writers and LZF decoder.

#include "cloud/formats/pcl_io_module.hpp"

#include <pcl/io/lzf.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <exception>

extern "C" int hedgefit_pclio_write_pcd_v1(const char* path, const pcl::PCLPointCloud2* blob, int encoding, int precision) {
  try {
    const Eigen::Vector4f origin = Eigen::Vector4f::Zero();
    const Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
    pcl::PCDWriter writer;
    switch (encoding) {
      case 0: return writer.writeASCII(path, *blob, origin, orientation, precision) < 0 ? 1 : 0;
      case 1: return writer.writeBinary(path, *blob, origin, orientation) < 0 ? 1 : 0;
      default: return writer.writeBinaryCompressed(path, *blob, origin, orientation) < 0 ? 1 : 0;
    }
  } catch (const std::exception&) {
    return 1;
  }
}

extern "C" int hedgefit_pclio_write_ply_v1(const char* path, const pcl::PCLPointCloud2* blob) {
  try {
    pcl::PLYWriter writer;
    return writer.writeBinary(path, *blob, Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity(), false) < 0 ? 1 : 0;
  } catch (const std::exception&) {
    return 1;
  }
}

extern "C" int hedgefit_pclio_lzf_decompress_v1(const void* packed, unsigned packed_size, void* unpacked, unsigned unpacked_size) {
  return pcl::lzfDecompress(packed, packed_size, unpacked, unpacked_size) == unpacked_size ? 0 : 1;
}
