#pragma once
// The cloud file formats, one file each (format_pcd.cpp, format_ply.cpp, format_xyz.cpp);
// the table in cloud_io.cpp lists them. Private to cloud/.

#include <pcl/PCLPointCloud2.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::cloud::internal {

CloudFormat PcdFormat();
CloudFormat PlyFormat();
CloudFormat XyzFormat();
CloudFormat LasFormat();

/// A coordinate as text: as `precision` significant digits, or, in a shifted cloud, with the
/// offset added back and the decimals the stored float holds (its step at the largest shifted
/// coordinate), so that nothing is printed that the float did not keep.
class CoordinateText {
 public:
  CoordinateText(const PointCloud& cloud, int precision) : offset_(cloud.offset), precision_(precision) {
    if (offset_.isZero()) return;
    float largest = 1;
    for (const auto& p : cloud.points_mm) {
      if (p.allFinite()) largest = std::max(largest, p.cwiseAbs().maxCoeff());
    }
    decimals_ = std::clamp(int(std::ceil(-std::log10(double(largest) * 1.2e-7))), 0, 9);
  }
  /// Prints point `p` as "x y z" into `buf`; returns the length.
  int Print(char* buf, std::size_t size, const Eigen::Vector3f& p) const {
    if (decimals_ < 0) return std::snprintf(buf, size, "%.*g %.*g %.*g", precision_, p.x(), precision_, p.y(), precision_, p.z());
    const Eigen::Vector3d q = p.cast<double>() + offset_;
    return std::snprintf(buf, size, "%.*f %.*f %.*f", decimals_, q.x(), decimals_, q.y(), decimals_, q.z());
  }
  bool Shifted() const { return decimals_ >= 0; }

 private:
  Eigen::Vector3d offset_;
  int precision_;
  int decimals_ = -1;
};

/// Reads a PCL blob's points (PCD and PLY share it): fields, origin, header encoding.
PointCloud FromBlob(const pcl::PCLPointCloud2& blob, const std::string& path, CloudFileHeader* header);

}  // namespace hedgefit::cloud::internal
