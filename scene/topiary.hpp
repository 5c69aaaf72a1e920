#pragma once
/// Clipped topiary among what no ball takes: the shapes box and yew are clipped to, found by
/// height rather than by gaps, and judged against the cloud's own noise and spacing.
///  1. A canopy height model (the highest point above the ground per top-view cell of twice the
///     cloud's spacing), closed over one-cell holes and smoothed by one cell.
///  2. A watershed from its peaks, flooded downwards: two peaks are one object when the ridge
///     between them stands above `merge_saddle` of the lower peak's height (a hedge row's ridge, a
///     rose's lumps), and two objects when it falls below (topiary in a bed, touching or not).
///  3. Each object's upper three quarters are fitted with three families with a vertical axis
///     (fitting/shape_fit.hpp: a ball, a spheroid, an ellipsoid with its heading, a drum or a box; the class by BIC
///     among the families whose points lie within max_roughness of them, when one does; a shape cut by the ground is
///     a dome), the horizontal semi-axes bounded by the footprint of
///     the object's upper half in the height model.
///  4. Verdict: topiary when the shape's top stands `min_height_mm` above the ground, its
///     horizontal semi-axes are at least the smallest hedge's radius, its footprint is no longer
///     than `max_elongation` times its width (a row is) nor the shape taller than that times its
///     width (a post, a stem), its top holds `min_density` as many points per mm^2 as the lawn
///     beside it, its footprint seen from above is covered (the lower 95 % bound of the share of
///     the ellipse within 0.8 of its semi-axes lying within a cell's disc of one of its points,
///     the evidence counted in cells of twice the spacing, is `min_covered` or more), and its points
///     lie on it within `max_roughness` times the ground's own noise (a clipped surface is as
///     smooth as the sensor sees the lawn; a rose's canes and a tree's lumps are not).
///  5. An object refused whose compact fitted footprint its points do not fill (cover or density)
///     may be a clipped shape with lower foliage leaning on it across a ridge above merge_saddle:
///     its last merges are undone, the half holding its peak judged again each time, and what
///     that leaves as topiary replaces it (the lower halves stay refused).
/// Heights are along +z (the caller turns the cloud, as FindHedges does); mm throughout.

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <string>
#include <vector>

#include "fitting/shape_fit.hpp"
#include "pipeline/option_table.hpp"
#include "scene/ground.hpp"

namespace hedgefit::scene {

struct TopiaryOptions {
  bool enabled = true;           ///< look for clipped shapes among the objects no ball takes
  double min_height_mm = 200;    ///< a topiary's top stands at least this far above the ground, mm
  double max_size_mm = 4000;     ///< largest horizontal semi-axis, mm (larger: a hedge, a bed, a wall)
  double merge_saddle = 0.7;     ///< peaks whose ridge stands above this share of the lower one's height are one object
  double max_elongation = 2.0;   ///< footprint's long over short semi-axis: beyond, a hedge row or a fence
  /// Share of the footprint's top-view cells (within 0.8 of its semi-axes) holding points, at
  /// least: its lower 95 % bound (Wilson), so a small object's few cells must all be held.
  double min_covered = 0.7;
  /// Points on the shape's upper three quarters per mm^2 of its footprint, over the lawn's beside
  /// it, at least: a solid top intercepts as many of a sensor's rays as the lawn would; thin
  /// vegetation, canes and a reconstruction's strays do not.
  double min_density = 0.8;
  double max_roughness = 3.5;    ///< robust spread of the points about the shape, in the ground's noise
  /// each semi-axis' 95 % half-width over the semi-axis, at most: the real garden's topiary are
  /// pinned to 0.07-0.34 of each (up to 0.62 turned, docs/accuracy.md: 0.5 lost one there), a box
  /// fitted to a slice of a bench's seat not at all
  double max_axis_uncertainty = 1.0;
  double min_noise_mm = 5;       ///< the noise roughness is judged against is at least this, mm
  double min_width_mm = 150;     ///< smallest horizontal semi-axis, mm (set from FindOptions::min_radius_mm by FindHedges)
  /// Where the sensor stood (scene frame, mm; set by FindHedges from FindOptions::viewpoints_mm):
  /// when given, the cover is read over the part of the footprint whose top faces one of them,
  /// on cells sized by the shape's own points (TopViewCover), and a topiary's envelope is measured
  /// with its noise and leaves' depth along the rays (fitting::FitClippedShape). Empty: the whole
  /// footprint, on cells of twice the cloud's spacing, and the noise about the vertical.
  std::vector<Eigen::Vector3d> viewpoints_mm;
  void Check() const;
  static const pipeline::OptionTable<TopiaryOptions>& Table();
};

/// A clipped shape with a vertical axis (fitting/shape_fit.hpp), in the scene frame (up +z).
using TopiaryShape = fitting::ClippedShape;

/// One object found by height, with what its verdict rests on.
struct TopiaryCandidate {
  std::vector<std::size_t> points;  ///< indices into the points given
  TopiaryShape shape;
  double covered = 0;          ///< share of the footprint (top view) within a cell's disc of a point
  double covered_lower = 0;    ///< its lower 95 % bound (Wilson)
  double elongation = 1;       ///< footprint's long over short semi-axis, or vertical over horizontal (the larger)
  double density = 0;          ///< points on its footprint over the lawn's beside it (per mm^2)
  double roughness = 0;        ///< roughness over the noise it is judged against
  bool topiary = false;
  /// Every test passed but the cover's bound: its footprint holds too few cells (too sparse a
  /// cloud) to show a solid top, so it is neither found nor refused; `reason` says so.
  bool undecided = false;
  double decides_at_spacing_mm = 0;  ///< when undecided: the spacing at which its cover's cells would decide
  std::string reason;          ///< why not, when not
};

/// One object of the watershed: its points and, per point, the smoothed height of its cell.
struct HeightPart {
  std::vector<std::size_t> points;   ///< indices into the points given
  std::vector<float> cell_height_mm; ///< the canopy height model's smoothed height at each point's cell
  float peak_mm = 0;                 ///< the part's highest smoothed cell
  /// The part's cells at or above half its peak: centre x, y and smoothed height, mm.
  std::vector<Eigen::Vector3d> upper_cells;
  /// The two objects the watershed merged into this one across its lowest ridge (each with its
  /// own halves), down to kSplitDepth merges; empty for one peak's basin or below that depth.
  std::vector<HeightPart> halves;
};

/// How many times a refused object's lower foliage is peeled off, at most (FindTopiary, step 5):
/// each time its last merge, across its lowest ridge, is undone. A lumpy neighbour is several
/// basins, joined one by one.
inline constexpr int kSplitDepth = 6;

/// Splits `idx` (indices into `pts`, scene frame) into objects by the watershed of their height
/// above `ground` (step 2 above), on cells of `cell_mm`.
std::vector<HeightPart> SplitByHeight(const std::vector<Eigen::Vector3d>& pts,
                                                     const std::vector<std::size_t>& idx, const GroundModel& ground,
                                                     double cell_mm, const TopiaryOptions& options);

/// fitting::FitClippedShape (step 3), as the finder calls it.
inline TopiaryShape FitTopiaryShape(const std::vector<Eigen::Vector3d>& points, double ground_mm, double noise_mm,
                                    double widest_mm = 0, std::size_t max_points = 800, bool jackknife = false,
                                    bool envelope = false, double max_spread_mm = 0, bool round = false,
                                    const std::vector<Eigen::Vector3d>& viewpoints = {}) {
  return fitting::FitClippedShape(points, ground_mm, noise_mm, widest_mm, max_points, jackknife, envelope, max_spread_mm, round,
                                  viewpoints);
}

/// The lawn's points per mm^2 about a place, from the points within the ground's band on a grid
/// of 0.5 m cells: what a solid surface seen from above would hold per mm^2 of its footprint.
class LawnDensity {
 public:
  LawnDensity(const std::vector<Eigen::Vector3d>& pts, const GroundModel& ground, double spacing_mm);
  /// In cells 0.25-1.25 m beyond `radius_mm` from `center` that hold lawn; 1 / spacing^2 when
  /// fewer than three do.
  double PerMm2Around(const Eigen::Vector2d& center, double radius_mm) const;

 private:
  static constexpr double kCell = 500;
  static std::int64_t Key(double x, double y);
  std::unordered_map<std::int64_t, std::size_t> counts_;
  double spacing_mm_;
};

/// Fits and judges one object (steps 3-4) standing on `ground`: `points` are indices into `pts`;
/// `cell_mm` the top view's cell; `widest_mm` bounds the horizontal semi-axes (0: from the
/// points); `cell_height_mm` (per point) and `peak_mm`, from SplitByHeight, choose the points in
/// the upper three quarters of its height (otherwise the points' own heights do).
TopiaryCandidate JudgeTopiary(const std::vector<Eigen::Vector3d>& pts, std::vector<std::size_t> points, const GroundModel& ground,
                              const LawnDensity& lawn, double cell_mm, const TopiaryOptions& options, double widest_mm = 0,
                              const std::vector<float>* cell_height_mm = nullptr, double peak_mm = 0);

/// Every object among `idx` by height, each fitted and judged (steps 1-4).
std::vector<TopiaryCandidate> FindTopiary(const std::vector<Eigen::Vector3d>& pts, const std::vector<std::size_t>& idx,
                                          const GroundModel& ground, double spacing_mm, const TopiaryOptions& options);

}  // namespace hedgefit::scene
