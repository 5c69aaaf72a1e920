#pragma once
// The cloud file formats, one file each (format_pcd.cpp, format_ply.cpp, format_xyz.cpp);
// the table in cloud_io.cpp lists them. Private to cloud/.

#include <pcl/PCLPointCloud2.h>

#include "cloud/cloud_io.hpp"

namespace hedgefit::cloud::internal {

CloudFormat PcdFormat();
CloudFormat PlyFormat();
CloudFormat XyzFormat();

/// Reads a PCL blob's points (PCD and PLY share it): fields, origin, header encoding.
PointCloud FromBlob(const pcl::PCLPointCloud2& blob, const std::string& path, CloudFileHeader* header);

}  // namespace hedgefit::cloud::internal
