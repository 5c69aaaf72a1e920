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

/// The same with the points' spacing (MedianSpacing) as a second witness: a cloud spanning up to
/// 2000 units whose neighbouring points lie under 0.2 units apart is in metres too (a scan of a
/// room or a garden in metres spans 50-2000 m, at centimetres; a millimetre cloud of that span
/// has its points a millimetre or more apart).
std::string GuessUnits(double extent, double spacing);

/// The median distance from a point to its nearest neighbour, in the cloud's units (from up to
/// 2000 points, against up to 200,000; a thinned cloud's spacing scaled back as a surface's is).
/// 0 with fewer than 2 finite points.
double MedianSpacing(const PointCloud& cloud);

/// The scale to read `cloud` in mm: 1000 when GuessUnits(extent, spacing) says metres, else 1.
double GuessScale(const PointCloud& cloud);

/// The units policy, written once: hedgefit measures in millimetres, and points that span less
/// than kMetreExtentLimit units end to end (the largest side of their bounds) are in metres: a
/// hedge of 300 mm or more spans more. Returns "" when `extent` is fine, else why, ending in
/// "; " + `fix` (e.g. "read it with --scale 1000"). compare, render and trim refuse such a cloud
/// unless --scale was given, the fit stages refuse such points (so does Python's fit).
std::string MetresReason(double extent, const std::string& fix);

/// The rings of a spinning LiDAR's scan in its own frame: each laser sweeps a cone of one
/// elevation about the scanner, so seen from the file's origin (points plus `offset`) almost all
/// points lie at a few elevations. Returns the number of rings when at least 95 % of the finite
/// points (1000 or more, away from the origin) fall in 4 to 128 groups of elevations, each at
/// most 0.3 degrees across; 0 otherwise (a scan moved into a map's frame, a terrestrial
/// scanner's fine steps, a photogrammetry model: their elevations spread). The origin is then
/// where the scanner stood.
int ScannerRings(const PointCloud& cloud);

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
  /// In the file's frame (a global shift added back: PointCloud::offset).
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< the shift applied on reading
  double extent = 0;        ///< the bounds' largest side
  double spacing = 0;       ///< MedianSpacing
  int scanner_rings = 0;    ///< ScannerRings: a spinning LiDAR's scan in its own frame when > 0
};

/// Reads `path` and describes it; throws Error as ReadCloud does.
CloudDescription DescribeCloud(const std::string& path);

/// As `info --json` prints it.
std::string DescriptionJson(const CloudDescription& d);

/// As `info` prints it.
void PrintDescription(std::ostream& out, const CloudDescription& d);

}  // namespace hedgefit::cloud
