#pragma once
/// hedgefit's point cloud: plain Eigen/STL storage so that public headers need
/// no PCL. Coordinates are millimetres by convention.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hedgefit::cloud {

using Rgb = std::array<std::uint8_t, 3>;

struct PointCloud {
  std::vector<Eigen::Vector3f> points_mm;  ///< x y z, mm; NaN marks an invalid point
  std::vector<Rgb> colors;                 ///< empty, or one colour per point
  /// Extra per-point scalar fields (e.g. "disparity", "sigma_z"), each empty or one per point.
  std::map<std::string, std::vector<float>> fields;
  std::uint32_t width = 0;   ///< organised: columns; unorganised: size()
  std::uint32_t height = 1;  ///< organised: rows (> 1); unorganised: 1
  /// The global shift: each point is stored less this (same units as points_mm). A reader sets
  /// it when a file's coordinates are too large for single precision (kShiftAbove), as
  /// CloudCompare's global shift and LAS's offsets do; writers add it back. Positions computed
  /// from the points are in the shifted frame.
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();

  std::size_t size() const { return points_mm.size(); }
  bool empty() const { return points_mm.empty(); }
  bool HasColor() const { return !colors.empty(); }
  bool IsOrganized() const { return height > 1; }
  /// Marks the cloud unorganised (width = size, height = 1).
  void Flatten() {
    width = static_cast<std::uint32_t>(points_mm.size());
    height = 1;
  }
  /// Throws hedgefit::Error if colours or fields disagree with the point count
  /// or width*height does not match it; `what` names the source for the message.
  void CheckConsistent(const std::string& what) const;
};

/// Coordinates beyond this (in the file's units) are shifted on reading: a float's step there is
/// 1/128 of a unit (8 mm in a metre file), and UTM coordinates reach 10^7.
constexpr double kShiftAbove = 1e5;
/// Coordinates beyond this are shifted too when they lie far from the origin for the cloud's own
/// size (kShiftFarFor times its longest side): a garden 100 m across in a local grid 30 km from
/// its origin steps by 2 mm, its own noise's order. CloudCompare's global shift proposes itself
/// from 10^4; a camera's cloud in mm reaching 10-60 m spans about as far as it reaches, and is
/// not shifted.
constexpr double kShiftFarAbove = 1e4;
constexpr double kShiftFarFor = 16;

/// Stores `xyz` (a reader's double coordinates) in `cloud`'s points: as they are, or less a
/// round offset (the bounding box's centre to the nearest 1000 units) when any finite coordinate
/// exceeds kShiftAbove, or kShiftFarAbove and kShiftFarFor times the box's longest side;
/// recorded in cloud->offset.
void SetPoints(const std::vector<Eigen::Vector3d>& xyz, PointCloud* cloud);

/// True if all three coordinates are finite.
inline bool IsFinite(const Eigen::Vector3f& p) { return p.allFinite(); }

/// Copy of the points at `indices` (with colours and fields), unorganised.
PointCloud Select(const PointCloud& cloud, const std::vector<std::size_t>& indices);

/// Copy of `cloud` where points not flagged in `keep` are set to NaN, keeping
/// the organised structure (PCL's setKeepOrganized behaviour).
PointCloud MaskOrganized(const PointCloud& cloud, const std::vector<bool>& keep);

/// The per-point field that says which hedge a point belongs to (1, 2, ... left to right),
/// written by stereo.segment_garden's captures.
inline constexpr const char* kHedgeIdField = "hedge_id";

/// The per-point field that says how wide one pixel is at each point of a capture's cloud (Z / f,
/// mm: the lateral footprint of the matcher's pixel), written by the stereo reprojection.
inline constexpr const char* kPixelSizeField = "pixel_mm";

/// The per-point fields that say which pixel of the rectified left image a capture's point was
/// measured at (column, row), written by the stereo reprojection: neighbours on the image grid.
inline constexpr const char* kPixelUField = "pixel_u";
inline constexpr const char* kPixelVField = "pixel_v";

/// The values of field `name` at `indices`, as doubles; empty when the cloud has no such field.
std::vector<double> FieldAt(const PointCloud& cloud, const std::string& name, const std::vector<std::size_t>& indices);

/// The points at `indices` in double precision: one hedge's points, as the fitters take them.
std::vector<Eigen::Vector3d> PointsAt(const PointCloud& cloud, const std::vector<std::size_t>& indices);

/// One hedge's finite points.
struct HedgeGroup {
  int id = 0;                        ///< 0 when the cloud has no hedge_id field (one hedge)
  std::vector<std::size_t> indices;  ///< finite points of this hedge
};

/// The finite points grouped by hedge id, ascending (points with id 0 belong to no hedge and are
/// left out); a cloud without the field is one group with id 0.
std::vector<HedgeGroup> HedgeGroups(const PointCloud& cloud);

/// Number of points with a non-finite coordinate.
std::size_t CountNonFinite(const PointCloud& cloud);

/// Axis-aligned bounds of the finite points; returns false if there are none.
bool Bounds(const PointCloud& cloud, Eigen::Vector3f* min_mm, Eigen::Vector3f* max_mm);

}  // namespace hedgefit::cloud
