#pragma once
/// The ground under a scene, as a terrain model that follows slopes and bumps: the lowest points
/// per grid cell, cleared of whatever stands on the ground by a progressive morphological opening
/// (Zhang et al. 2003, "A progressive morphological filter for removing nonground measurements
/// from airborne LIDAR data", the method of PCL's ProgressiveMorphologicalFilter, here on the grid
/// of cell minima so a million points take milliseconds), then a smooth surface through the cells
/// left: bilinear between cell centres, holes (under hedges, behind them) filled from the
/// surrounding ground.
///
/// Heights are along +z: the caller turns the cloud so its up is +z (scene::FindHedges does).

#include <Eigen/Core>

#include <cstdint>
#include <vector>

#include "pipeline/option_table.hpp"

namespace hedgefit::scene {

struct GroundOptions {
  double cell_mm = 250;          ///< grid cell: the terrain's finest detail
  /// The widest thing the opening clears: wider than any hedge's footprint, narrower than a hill.
  double max_window_mm = 5000;
  double slope = 0.5;            ///< steepest ground, rise over run (0.5: 27 degrees)
  double step_mm = 150;          ///< a cell this far above the opened surface is never ground (PMF's initial dh)
  /// Patches of ground cells under 1.5 m^2 are dropped: the undersides of objects with no lawn
  /// about them, as in a camera's cloud of segmented hedges (set by FindHedges for a camera's
  /// cloud; a sparse scan's lawn comes in patches, so not by default).
  bool drop_small_patches = false;
  void Check() const;
  static const pipeline::OptionTable<GroundOptions>& Table();
};

/// A height field z = h(x, y) on a regular grid.
struct GroundModel {
  Eigen::Vector2d origin_mm = Eigen::Vector2d::Zero();  ///< corner of cell (0, 0)
  double cell_mm = 250;
  int nx = 0, ny = 0;
  std::vector<float> height_mm;         ///< per cell (row-major, y major), every cell filled
  std::vector<std::uint8_t> observed;   ///< 1 where the cell held ground points
  double noise_mm = 0;                  ///< robust scatter of the ground points about the surface
  std::size_t ground_points = 0;

  bool empty() const { return nx == 0 || ny == 0; }
  /// The surface's height at (x, y), bilinear between cell centres; outside the grid, the nearest
  /// edge's. NaN when the model is empty.
  double HeightAt(double x, double y) const;
  /// Whether ground was seen within `radius_mm` of (x, y) (else the height there is filled in).
  bool ObservedNear(double x, double y, double radius_mm) const;
};

/// Fits the ground to `points` (up is +z, mm; non-finite points are skipped). `is_ground`, when
/// given, receives 1 for each point within the ground's band (3 x its noise, at least 40 mm).
GroundModel FitGround(const std::vector<Eigen::Vector3f>& points, const GroundOptions& options = {},
                      std::vector<std::uint8_t>* is_ground = nullptr);

/// The band about the surface within which a point is ground, mm.
double GroundBand(const GroundModel& ground);

}  // namespace hedgefit::scene
