#pragma once
// The one boundary between hedgefit::cloud::PointCloud and PCL types. Private to
// hedgefit's .cpp files: public headers never include PCL.

#include <pcl/PCLPointCloud2.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud {

/// Converts a PCL blob (any field layout) to our cloud; throws Error naming `source`
/// if it has no x/y/z.
PointCloud FromPclBlob(const pcl::PCLPointCloud2& blob, const std::string& source);
/// x y z float32, then rgb (packed float, PCL convention) if coloured, then extra fields. With
/// `file_frame`, a shifted cloud's (PointCloud::offset) x y z are float64 with the shift added
/// back: a writer's blob, in the file's frame.
pcl::PCLPointCloud2 ToPclBlob(const PointCloud& cloud, bool file_frame = false);

pcl::PointCloud<pcl::PointXYZ> ToPclXyz(const PointCloud& cloud);
pcl::PointCloud<pcl::PointXYZRGB> ToPclXyzRgb(const PointCloud& cloud);
PointCloud FromPclXyz(const pcl::PointCloud<pcl::PointXYZ>& pc);
PointCloud FromPclXyzRgb(const pcl::PointCloud<pcl::PointXYZRGB>& pc);

/// Silences PCL's console output: hedgefit reports errors itself, one line each.
void QuietPcl();

}  // namespace hedgefit::cloud
