// PLY: PCL's reader; binary through PCL's writer, ASCII by hand (PCL's prints 6 digits).

#include <pcl/io/ply_io.h>

#include <cstdio>
#include <fstream>

#include "cloud/cloud_formats.hpp"
#include "cloud/error.hpp"
#include "cloud/pcl_adapter.hpp"

namespace hedgefit::cloud::internal {

namespace {

PointCloud ReadPly(const std::string& path, CloudFileHeader* header) {
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  pcl::PLYReader reader;
  if (reader.read(path, blob, origin, orientation, version) < 0) {
    throw Error(path + ": malformed or truncated PLY file; expected a 'vertex' element with x, y, z");
  }
  header->encoding = "ply";
  return FromBlob(blob, path, header);
}

// ASCII PLY with full float precision (PCL's ASCII PLY writer prints 6 digits, losing
// up to 0.005 mm at 2 m).
void WritePlyAscii(const std::string& path, const PointCloud& cloud, int precision) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot be opened for writing");
  out << "ply\nformat ascii 1.0\ncomment written by hedgefit\nelement vertex " << cloud.size()
      << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (cloud.HasColor()) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  std::vector<std::pair<std::string, const std::vector<float>*>> extra;
  for (const auto& [name, values] : cloud.fields) {
    if (values.empty()) continue;
    out << "property float " << name << "\n";
    extra.emplace_back(name, &values);
  }
  out << "end_header\n";
  char buf[64];
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points_mm[i];
    out.write(buf, std::snprintf(buf, sizeof(buf), "%.*g %.*g %.*g", precision, p.x(), precision, p.y(), precision, p.z()));
    if (cloud.HasColor()) {
      out.write(buf, std::snprintf(buf, sizeof(buf), " %d %d %d", cloud.colors[i][0], cloud.colors[i][1], cloud.colors[i][2]));
    }
    for (const auto& e : extra) out.write(buf, std::snprintf(buf, sizeof(buf), " %.*g", precision, (*e.second)[i]));
    out.put('\n');
  }
  out.flush();
  if (!out) throw Error(path + ": write failed (disk full?)");
}

void WritePly(const std::string& path, const PointCloud& cloud, const WriteOptions& options) {
  if (!options.ply_binary) return WritePlyAscii(path, cloud, options.ascii_precision);
  pcl::PLYWriter writer;
  if (writer.writeBinary(path, ToPclBlob(cloud), Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity(), false) < 0) {
    throw Error(path + ": write failed; check free space and permissions");
  }
}

}  // namespace

CloudFormat PlyFormat() { return {"ply", "PLY (ascii or binary)", {".ply"}, ReadPly, WritePly, {"binary", "precision"}}; }

}  // namespace hedgefit::cloud::internal
