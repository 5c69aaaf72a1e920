#pragma once
/// What a cloud file holds, as `hedgefit info` (like `pdal info`) reports it: format, encoding,
/// points, fields, organisation, colour, non-finite points, bounds, and a guess at its units.

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "cloud/cloud_io.hpp"

namespace hedgefit::cloud {

/// Clouds in metres rarely span more than ~200 units; in millimetres, rarely less than ~50.
constexpr double kMetreExtentLimit = 50.0;

/// "m" when the largest extent is under kMetreExtentLimit units, "mm" otherwise, "unknown" when
/// every point coincides.
std::string GuessUnits(double extent);

/// The units policy, written once: hedgefit measures in millimetres, and points that span less
/// than kMetreExtentLimit units end to end (the largest side of their bounds) are in metres: a
/// hedge of 300 mm or more spans more. Returns "" when `extent` is fine, else why, ending in
/// "; " + `fix` (e.g. "read it with --scale 1000"). compare, render and trim refuse such a cloud
/// unless --scale was given, the fit stages refuse such points (so does Python's fit).
std::string MetresReason(double extent, const std::string& fix);

/// The largest side of the bounds of the finite points of `cloud` (0 when none).
double LargestExtent(const PointCloud& cloud);
double LargestExtent(const std::vector<Eigen::Vector3d>& points_mm);

struct CloudDescription {
  std::string file;
  CloudFileHeader header;
  std::size_t points = 0, nonfinite = 0;
  bool organized = false, has_color = false;
  std::uint32_t width = 0, height = 0;
  bool has_bounds = false;  ///< false when no point is finite
  Eigen::Vector3f min = Eigen::Vector3f::Zero(), max = Eigen::Vector3f::Zero();
  double extent = 0;        ///< the bounds' largest side
};

/// Reads `path` and describes it; throws Error as ReadCloud does.
CloudDescription DescribeCloud(const std::string& path);

/// As `info --json` prints it.
std::string DescriptionJson(const CloudDescription& d);

/// As `info` prints it.
void PrintDescription(std::ostream& out, const CloudDescription& d);

}  // namespace hedgefit::cloud
