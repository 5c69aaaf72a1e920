#pragma once
/// The trim plan: how far each point of a hedge sticks out past the shape the gardener wants
/// (a target sphere), how much of the surface needs cutting, and the volume to remove.
///
/// Cut depth of a point p: |p - c| - R for the target centre c and radius R, in mm; positive
/// = outside the target (to cut), negative = inside (a gap that no cut fills).
///
/// Volume: the directions from the target centre are binned on an equal-area grid (rings of
/// equal cos(theta) about a pole, equal sectors of phi). The pole is the camera's vertical
/// (y) axis, so the side the camera sees lies about the grid's equator, where the bins are
/// nearly square (about a pole they are long thin wedges). In each bin seen by at
/// least `min_bin_points` points the hedge's surface radius is the median of their distances
/// to c (the median, so sensor noise neither inflates nor shrinks it), and the bin's volume
/// outside the target is dOmega (r^3 - R^3) / 3 where r - R exceeds the tolerance (a bin on
/// target is not cut; counting its noise would add volume). A bin on the edge of the seen
/// part (a neighbour unseen) counts half its solid angle: on average it is half covered. The sum covers only what the
/// camera saw; `seen_share` says how much of the sphere that is, and `volume_all_round_l` scales
/// the seen volume to the whole sphere on the assumption that the unseen side sticks out as the
/// seen side does; `volume_unseen_max_l` bounds the unseen rest: what it would hold if every
/// unseen direction stuck out as far as the farthest seen one. Each bin is kept (`bins`), so a
/// caller can mark the directions no point came from as unseen rather than extrapolate to them.
///
/// A leafy hedge's points lie at and below its envelope (the leaves the shears cut flush with it,
/// and deeper ones seen through gaps): a bin's radius is then the (1 - w / 2) quantile of its
/// points' distances, w the share on the envelope (the envelope fit's clipped_share): the middle
/// of the leaves on the envelope, where the shears cut. w = 1 (the default) is the median.

#include <Eigen/Core>

#include <vector>

#include <ostream>
#include <string>

#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

struct TrimOptions {
  double tolerance_mm = 5.0;  ///< cut depths up to this count as "on target" (a trimmer's resolution)
  /// Angular size of a volume bin at the equator, degrees; 0 = automatic (about 20 points per
  /// bin over the part seen, between 0.5 and 15 degrees).
  double bin_deg = 0.0;
  int min_bin_points = 3;     ///< a bin with fewer points is unseen
  double clipped_share = 1.0; ///< share of a bin's points on the envelope (see above); 1 = the median
  /// A clipped shape as the target instead of a sphere: semi-axes along the heading, across it
  /// and along the pole (the vertical), mm; zero = the sphere of the target's radius. Cut depth
  /// is then along the ray from the target's centre: the point's distance less the shape's
  /// radius in its direction, as the volume's bins read it.
  Eigen::Vector3d axes_mm = Eigen::Vector3d::Zero();
  /// The first semi-axis' direction: degrees counter-clockwise about the pole from the cloud's x
  /// axis laid flat (its y axis when x is the pole).
  double heading_deg = 0;
  /// What `axes_mm` are the semi-axes of: "ellipsoid" (a ball or spheroid when they are equal),
  /// "cylinder" (a drum: radius axes x = y, half-height z, its axis along the pole), "cuboid" (a
  /// box: half-sides along the heading, across it and the pole) or "cone" (base radius x = y at
  /// half-height z below the centre, apex as far above), each about the target's centre. A bin
  /// reads the target's radius at its centre: across a shape's edge, rim or apex that is coarse
  /// unless the bins are small (bin_deg; see tests/fitting/trim_test.cpp).
  std::string shape = "ellipsoid";
};

/// One volume bin of a plan: a direction from the target centre and the cell about it.
struct TrimBin {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  ///< the cell's centre, unit
  double solid_angle_sr = 0;  ///< the whole cell's
  int points = 0;
  bool seen = false;          ///< at least min_bin_points points
  double weight = 0;          ///< the share of its solid angle the plan counted: 1, 0.5 on the seen part's edge, 0 unseen
  double radius_mm = 0;       ///< the surface's distance from the target centre (seen bins only)
};

struct TrimPlan {
  int hedge_id = 0;  ///< which hedge of a capture (0: the cloud is one hedge)
  Sphere target;     ///< its centre; its radius, or for a shape the radius of its volume
  Eigen::Vector3d target_axes_mm = Eigen::Vector3d::Zero();  ///< a shape's semi-axes (zero for a sphere)
  double target_heading_deg = 0;
  std::string target_shape;      ///< TrimOptions::shape for a shaped target, "" for a sphere
  std::vector<float> depth_mm;   ///< per input point, signed (NaN for non-finite points)
  std::size_t points = 0;        ///< finite points
  std::size_t points_to_cut = 0; ///< depth > tolerance
  /// Share of the seen surface (solid angle of the seen bins) whose median depth > tolerance.
  double cut_share = 0;
  /// Percentiles of the depth of the points to cut (50, 90, 99 %) and the largest, mm; 0 if none.
  double cut_p50_mm = 0, cut_p90_mm = 0, cut_p99_mm = 0, cut_max_mm = 0;
  double seen_share = 0;          ///< solid angle of the seen bins / 4 pi
  double volume_seen_l = 0;       ///< litres outside the target, over the seen bins
  double volume_all_round_l = 0;  ///< volume_seen_l / seen_share (see above); 0 if nothing seen
  /// The most the unseen rest could hold: every unseen direction as far out as the farthest seen
  /// bin (0 when no seen bin needs cutting).
  double volume_unseen_max_l = 0;
  /// How much of the volume seen the bins' size leaves unread: each cut bin takes the target's
  /// radius at its centre, and across a shape's edge, rim or apex the target differs within it
  /// (0 for a sphere; small for a smooth ellipsoid).
  double volume_binning_l = 0;
  double bin_deg = 0;             ///< the bin size used, degrees
  /// What makes the plan doubtful, one sentence each (bins too coarse for the target's shape).
  std::vector<std::string> warnings;
  std::vector<TrimBin> bins;      ///< every cell of the grid, seen or not
  Eigen::Vector3d pole = Eigen::Vector3d::UnitY();  ///< the grid's pole (the vertical)
};

/// Plans the trim of one hedge's points (mm) to `target`. `pole` is the axis the bins' rings
/// are taken about (the camera's vertical by default). Throws hedgefit::Error for a target
/// with a non-positive or non-finite radius or centre, or bad options.
TrimPlan PlanTrim(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& target, const TrimOptions& options = {},
                  const Eigen::Vector3d& pole = Eigen::Vector3d::UnitY());

/// The trim plans as `trim --format json` prints them: {"cloud": ..., "hedges": [...]}, to the
/// micrometre.
std::string TrimPlansJson(const std::string& cloud, const std::vector<TrimPlan>& plans);

/// The trim plans as `trim` prints them: a table, one row per hedge.
void PrintTrimTable(std::ostream& out, const std::vector<TrimPlan>& plans);

}  // namespace hedgefit::fitting
