#pragma once
/// `hedgefit bench around`: rings and arcs of captures around a hedge ball and around a row of
/// two, rendered by hedgefit's renderer or POV-Ray, each with its true pose and with odometry-like
/// pose errors; every set measured capture by capture and fused (around::Fuse), and scored against
/// the scene's truth: the envelope's radius and centre, the share of the sphere covered, each
/// capture's pose after registration, and (on a ball with a bulge on its far side) the trim plan's
/// volume against the geometry's.

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/option_table.hpp"

namespace hedgefit::bench {

struct AroundBenchOptions {
  std::string renderer = "hedgefit";    ///< hedgefit or povray
  std::string scenes = "single,bulge,row";  ///< comma-separated: single, bulge, row
  std::string layouts = "ring,arc";     ///< ring (all round), arc (half round), pass (a robot driving by on one side)
  std::string captures = "4,8";         ///< captures per set, comma-separated (3-8)
  std::string poses = "exact,odometry"; ///< exact and/or odometry (1-3 % of the distance, 1-2 degrees of heading)
  std::string registration = "centres";  ///< around::FuseOptions::registration
  double scale = 1.0;                   ///< image scale (0.5: a quarter of the pixels, for quick runs)
  /// The odometry errors', the camera noise's and the leaves' seed. 1: the sets the fusion was
  /// developed on; any other draws another garden's leaves (held-back sets, docs/around.md).
  std::uint64_t seed = 1;
  std::string dir = "build/around";     ///< captures, manifests and truths are written here (reused while stamped, bench/render_stamp.hpp)
  double trim_depth_mm = 40;            ///< the trim target: the true envelope less this
  static const pipeline::OptionTable<AroundBenchOptions>& Table();
};

struct AroundBenchRow {
  std::string renderer, scene, layout, poses;
  int captures = 0, used = 0;
  int hedges_true = 0, hedges_found = 0;
  int phantoms = 0;                  ///< fused hedges reported as hedges that are none of the true ones
  int unconfirmed = 0;               ///< fused hedges reported as unconfirmed (FusedHedge::unconfirmed)
  double radius_error_mm = 0;        ///< worst |envelope radius - truth| over the hedges
  double center_error_mm = 0;        ///< worst centre distance
  double radius_se_mm = 0;           ///< the stated standard error of the worst
  double inside_share = 0;           ///< share of (x, y, z, r) within their stated 95 % intervals
  double coverage = 0;               ///< least share of a hedge's sphere covered, all captures
  double view_coverage = 0;          ///< mean share one capture covers
  double single_radius_error_mm = 0; ///< mean |radius error| of the captures measured alone
  double single_center_error_mm = 0;
  double given_pose_mm = 0, given_pose_deg = 0;  ///< worst error of the given poses
  double pose_mm = 0, pose_deg = 0;  ///< worst error of the poses after registration
  double trim_volume_l = 0, trim_truth_l = 0;    ///< bulge: the plan's volume over what was seen, the geometry's
  double trim_unseen_max_l = 0, seen_share = 0;
  double seconds = 0;                ///< fusion (the captures' own measurement excluded)
  double measure_seconds = 0;        ///< the captures measured alone, all of them
};

struct AroundBenchResult {
  std::vector<AroundBenchRow> rows;
};

AroundBenchResult RunAroundBench(const AroundBenchOptions& options);
void PrintAroundBench(const AroundBenchResult& result);
std::string AroundBenchJson(const AroundBenchResult& result);

}  // namespace hedgefit::bench
