#pragma once
/// Cleaning filters on hedgefit::cloud::PointCloud. Each is a free function with
/// an options struct (Check() names the bad field) and returns what it did.

#include <cstddef>
#include <string>
#include <optional>
#include <vector>

#include "pipeline/option_table.hpp"
#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud {

/// What a filter kept, and its diagnostics.
struct FilterResult {
  PointCloud cloud;         ///< the kept points (organised, with NaN for removed points, if asked)
  std::size_t kept = 0;     ///< finite points kept
  std::size_t removed = 0;  ///< finite points removed
  std::size_t nonfinite = 0;  ///< NaN/Inf input points (dropped, or left in place when organised)
  double threshold = 0;     ///< the filter's decision threshold, where it has one (mm)
};

/// Drops points with a NaN/Inf coordinate. Unorganises the cloud.
FilterResult RemoveNonFinite(const PointCloud& cloud);

struct StatisticalOutlierOptions {
  int mean_k = 50;          ///< neighbours per point for the mean distance (points)
  double stddev_mul = 1.0;  ///< threshold = mean + stddev_mul * stddev of mean distances
  int num_threads = 0;      ///< 0 = all hardware threads
  bool keep_organized = false;  ///< removed points become NaN, structure kept
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<StatisticalOutlierOptions>& Table();  ///< the options, declared once
};

/// Per-point mean distance to the mean_k nearest neighbours (mm; 0 for non-finite
/// points), computed exactly as PCL's StatisticalOutlierRemoval does.
std::vector<float> MeanNeighbourDistances(const PointCloud& cloud, int mean_k, int num_threads);

/// Inlier flags of PCL's StatisticalOutlierRemoval decision (same kept set on
/// finite points; non-finite points are flagged false). `threshold` gets mean + k sigma.
std::vector<bool> StatisticalInliers(const PointCloud& cloud, const StatisticalOutlierOptions& options,
                                     double* threshold = nullptr);

/// Rusu et al. 2008 statistical outlier removal; same kept set as PCL, several times faster.
FilterResult StatisticalOutlierRemoval(const PointCloud& cloud, const StatisticalOutlierOptions& options);

struct RadiusOutlierOptions {
  double radius_mm = 10.0;  ///< neighbourhood radius (mm)
  int min_neighbours = 5;   ///< other points needed within radius_mm to keep a point
  int num_threads = 0;      ///< 0 = all hardware threads
  bool keep_organized = false;
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<RadiusOutlierOptions>& Table();  ///< the options, declared once
};

/// PCL RadiusOutlierRemoval's decision: keep a point with >= min_neighbours others within radius.
FilterResult RadiusOutlierRemoval(const PointCloud& cloud, const RadiusOutlierOptions& options);

struct LocalOutlierOptions {
  int k = 20;               ///< neighbours per point (Breunig's MinPts; scikit-learn's default)
  double threshold = 2.0;   ///< a point whose local outlier factor exceeds this is removed
  int num_threads = 0;      ///< 0 = all hardware threads
  bool keep_organized = false;
  /// "pixels": on a stereo capture's cloud (pixel_u / pixel_v fields) each point's neighbours are
  /// taken from the points of the pixels about it (PixelGrid: 7 x 7 for k = 20) where those
  /// surely hold the nearest (a surface facing the camera), else from a 3-D search: the same neighbours, found faster;
  /// "space": a 3-D search for every point (what 0.7.0 did).
  std::string neighbours = "pixels";
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<LocalOutlierOptions>& Table();  ///< the options, declared once
};

/// Each finite point's local outlier factor (Breunig, Kriegel, Ng and Sander 2000, as
/// scikit-learn's LocalOutlierFactor computes it with exactly k neighbours): the mean local
/// reachability density of its k nearest neighbours over its own. About 1 wherever the points
/// are as dense as their neighbours, however dense that is; well above 1 for a point far from a
/// denser surface. 0 for non-finite points. `on_pixels`: neighbours on the image grid where the
/// cloud has one (LocalOutlierOptions::neighbours).
std::vector<float> LocalOutlierFactors(const PointCloud& cloud, int k, int num_threads, bool on_pixels = false);

/// Removes points whose local outlier factor exceeds `threshold`. Unlike the statistical filter,
/// whose one threshold on the neighbour distance trims wherever the cloud is sparse (a stereo
/// cloud's far side and the outline of a rounded surface, whose point spacing grows as 1 / cos
/// of the view angle), it compares each point with its own neighbours. `threshold` in the result
/// holds the threshold.
FilterResult LocalOutlierRemoval(const PointCloud& cloud, const LocalOutlierOptions& options);

struct SpacingOutlierOptions {
  int mean_k = 30;          ///< neighbours per point for the mean distance (points)
  double max_ratio = 8.0;   ///< remove points whose spacing ratio (SpacingRatios) exceeds this
  int num_threads = 0;      ///< 0 = all hardware threads
  bool keep_organized = false;
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<SpacingOutlierOptions>& Table();  ///< the options, declared once
};

/// Each finite point's mean distance to its mean_k nearest neighbours (as MeanNeighbourDistances)
/// in units of its own pixel footprint (the kPixelSizeField, Z / f, which stereo clouds carry;
/// 1 mm where the cloud has none or a point's is not positive), over the median of that over the
/// cloud. About 1 wherever the surface faces the camera, whatever its distance; 1 / sqrt(cos) of
/// the view angle on a slanted surface (3.2 at cos 0.1); far more for a point floating off the
/// surface. 0 for non-finite points.
std::vector<float> SpacingRatios(const PointCloud& cloud, int mean_k, int num_threads);

/// Removes points whose spacing ratio exceeds `max_ratio`: mismatches floating off the surface,
/// alone or among others, while the sparse outline of a rounded surface and the far side of a
/// scene stay. `threshold` in the result holds the distance, in mm at a point of median footprint,
/// that max_ratio stands for.
FilterResult SpacingOutlierRemoval(const PointCloud& cloud, const SpacingOutlierOptions& options);

struct HedgeOutlierOptions {
  /// The filter for a cloud of hedges found by depth (leafy shells): "statistical" (30
  /// neighbours, 1 sigma: what the envelope fit was set with) or "local" (as any other cloud).
  std::string shells = "statistical";
  int num_threads = 0;  ///< 0 = all hardware threads
  std::string neighbours = "pixels";  ///< for the local outlier factor: as LocalOutlierOptions'
  /// With shells "statistical": each hedge against its own points' statistics (true), so its
  /// cleaning does not depend on what else the cloud holds, or the whole cloud's (false).
  bool per_hedge = true;
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<HedgeOutlierOptions>& Table();  ///< the options, declared once
};

/// Whether HedgeOutlierRemoval takes the local outlier factor and the spacing ratio for `cloud`
/// (else the statistical filter): a stereo capture's cloud (a pixel_mm field, as `convert`
/// writes) of one hedge found by colour, or of hedges found by depth with shells "local".
bool HedgeOutlierIsLocal(const PointCloud& cloud, const HedgeOutlierOptions& options);

/// The outlier removal of the default cleaning (DefaultCleaningJson), by what the cloud is.
/// A stereo capture's cloud (pixel_mm field) of one smooth hedge found by colour: the local
/// outlier factor (k 20, above 2), then the spacing ratio (mean_k 30, above 8), which keep a
/// sparse surface (the outline the statistical filter trims) and drop what floats off it. Any
/// other cloud: the statistical filter (mean_k 30, 1 sigma). Hedges found by depth (a hedge_id
/// field: leafy shells), because it also trims the sparse leaves seen deep through the shell's
/// gaps (on POV-Ray's real-camera gardens the envelope's centre is 1.18 mm off with it and 2.31
/// mm without); shells "local" gives them the local filters. A cloud without footprints (a
/// file from elsewhere, a scan), because without them the spacing ratio cannot tell a sparse
/// surface from mismatches scattered among each other, which the local factor misses.
FilterResult HedgeOutlierRemoval(const PointCloud& cloud, const HedgeOutlierOptions& options);

struct VoxelGridOptions {
  double leaf_mm = 5.0;           ///< cubic voxel edge (mm)
  int min_points_per_voxel = 1;   ///< voxels with fewer points are dropped
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<VoxelGridOptions>& Table();  ///< the options, declared once
};

/// One point per occupied voxel at the centroid of its points (colours and
/// extra fields averaged). Voxel indices are 64-bit, so unlike PCL's VoxelGrid
/// small leaves on large extents do not overflow. Output is unorganised, in voxel order.
FilterResult VoxelGrid(const PointCloud& cloud, const VoxelGridOptions& options);

struct CropBoxOptions {
  Eigen::Vector3f min_mm = Eigen::Vector3f::Constant(-1e9f);  ///< box corner (mm)
  Eigen::Vector3f max_mm = Eigen::Vector3f::Constant(1e9f);   ///< opposite corner (mm)
  bool negative = false;        ///< keep the points outside the box instead
  bool keep_organized = false;
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<CropBoxOptions>& Table();  ///< the options, declared once
};

/// Keeps points inside an axis-aligned box (bounds inclusive).
FilterResult CropBox(const PointCloud& cloud, const CropBoxOptions& options);

struct PassThroughOptions {
  std::string field = "z";  ///< x, y, z, range (distance from the origin) or an extra field's name
  double min = -1e30;       ///< inclusive lower limit (field's unit; mm for x y z)
  double max = 1e30;        ///< inclusive upper limit
  bool negative = false;    ///< keep the points outside [min, max]
  bool keep_organized = false;
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<PassThroughOptions>& Table();  ///< the options, declared once
};

/// Keeps points whose `field` lies in [min, max]; throws Error if the field is missing.
FilterResult PassThrough(const PointCloud& cloud, const PassThroughOptions& options);

struct PlaneRemovalOptions {
  double distance_threshold_mm = 20.0;  ///< points this close to a found plane are removed (mm)
  int min_inliers = 1000;               ///< stop when the best plane has fewer points
  int max_planes = 5;                   ///< remove at most this many planes
  int max_iterations = 1000;            ///< RANSAC samples per plane
  std::uint64_t seed = 42;              ///< RANSAC sampler seed
  void Check() const;  ///< every field against Table(), then the rules between fields
  static const pipeline::OptionTable<PlaneRemovalOptions>& Table();  ///< the options, declared once
};

/// Removes the dominant planes (floor, walls) one after another with PCL's RANSAC on
/// SACMODEL_PLANE (on centred data), so a sphere fit sees the object, not the room.
/// `threshold` in the result holds the number of planes removed.
FilterResult RemovePlanes(const PointCloud& cloud, const PlaneRemovalOptions& options);

/// A plane n.p + d = 0 with |n| = 1.
struct Plane {
  Eigen::Vector3f normal = Eigen::Vector3f::UnitY();
  float d = 0;
  std::size_t inliers = 0;
  float Distance(const Eigen::Vector3f& p) const { return normal.dot(p) + d; }  ///< signed, mm
};

struct PlaneSearch {
  Eigen::Vector3f axis = Eigen::Vector3f::UnitY();  ///< the plane's normal must lie near this axis
  double max_angle_deg = 35;                         ///< ... within this angle
  double distance_threshold_mm = 40;
  int max_iterations = 500;
  std::uint64_t seed = 42;
};

/// The plane with most points within the threshold whose normal lies within max_angle of
/// `axis` (PCL's RANSAC on SACMODEL_PERPENDICULAR_PLANE, then least squares on its inliers),
/// e.g. the ground seen by a camera. nullopt when fewer than 3 points or no such plane.
std::optional<Plane> FindPlane(const std::vector<Eigen::Vector3f>& points_mm, const PlaneSearch& search);

}  // namespace hedgefit::cloud
