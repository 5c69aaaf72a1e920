#pragma once
/// Every hedge in any cloud: a LiDAR scan, a photogrammetry model, a robot's map or a stereo
/// capture. The steps, each a measure a reader can check:
///  1. Up: +z, or -y for a camera's cloud (organised, or with a "pixel_mm" field), or as given;
///     a camera's up is then refined to the normal of the ground it sees.
///  2. Ground (ground.hpp): a terrain model that follows slopes and bumps; every object's ground
///     height is read off it.
///  3. Objects: the points above the ground, clustered in the top view (cells joined across gaps
///     under `gap_mm`), so a hedge seen as separate scan rings is one object.
///  4. Balls, peeled off each object one by one: a sphere found by sample consensus, refined on its
///     shell, and judged by what a clipped ball has and a rose bush, a tree, a hedge row or a wall
///     has not:
///       - lumpiness: the spread, from patch to patch of the sphere, of where the outermost points
///         lie (clipped leaves end on one envelope), over the radius;
///       - crowding: the points just outside its shell, per point on it (a blob of a shrub or a
///         crown has its neighbours all round; a ball only where it touches another or a row);
///       - the share of the sphere seen (too little: a patch of anything fits a sphere), and how
///         well its points pin the sphere down (the radius' 95 % interval, a block jackknife);
///       - the radius within limits, the centre not below the ground by more than half a radius
///         (a ball on a stem or a stand may float above it: center_height_radii says so);
///       - the vertical against the horizontal semi-axis (a spheroid fit), where enough is seen.
///     A ball cut by the ground (its centre lower than 0.8 radii above it) is a dome.
///  5. Per ball: the geometric fit on its shell with standard errors, and the leafy envelope (the
///     outer surface where the leaves end) and mean-leaf radii.
///  6. What no ball takes is searched for clipped topiary by height (topiary.hpp): a watershed of
///     the height above the ground parts touching shapes in a bed, and each is fitted as a ball, a
///     dome, a spheroid, an ellipsoid, a cylinder or a cuboid with a vertical axis and judged against the cloud's own
///     noise and spacing (a squat dome seen from above is judged on its footprint, not as a
///     sphere).
///     What is left of each object is an object of its own: "not a ball", with the reason.

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "cloud/point_cloud.hpp"
#include "fitting/sphere_fit.hpp"
#include "pipeline/option_table.hpp"
#include "scene/ground.hpp"
#include "scene/topiary.hpp"

namespace hedgefit::scene {

struct FindOptions {
  std::string up = "auto";        ///< auto, x, y, z, -x, -y or -z: the cloud's up
  double min_radius_mm = 150;     ///< smallest hedge ball
  double max_radius_mm = 2000;    ///< largest hedge ball
  double gap_mm = 150;            ///< objects closer than this in the top view are one object before balls are split off
  int min_points = 30;            ///< fewer points are no object
  double max_lumpiness = 0.04;    ///< a ball's outermost points lie within this share of its radius of one sphere (robust spread)
  double max_crowding = 0.25;     ///< points just outside a ball's shell per point on it: more, and it is part of something
  double min_seen = 0.1;          ///< share of a ball's sphere its points must cover
  double max_radius_uncertainty = 0.08;  ///< a ball's radius is pinned down to this share of it (95 % interval)
  double max_axis_ratio = 1.3;    ///< vertical over horizontal semi-axis (or its inverse) above this: an ellipsoid
  double max_leaf_depth = 0.1;    ///< a ball's leaves lie within this share of its radius under its envelope
  bool envelope = true;           ///< fit the leafy envelope too (the outer surface; off: the geometric fit only)
  GroundOptions ground;
  TopiaryOptions topiary;         ///< clipped shapes among what no ball takes
  /// Where the sensor stood, in the cloud's frame (mm, less its offset): a scanner's stations or
  /// trajectory, a PCD's VIEWPOINT. A topiary's cover is then judged over the part of its top that
  /// faces one of them (TopiaryOptions::viewpoints_mm). Empty: seen from above.
  std::vector<Eigen::Vector3d> viewpoints_mm;
  std::uint64_t seed = 42;
  void Check() const;
  static const pipeline::OptionTable<FindOptions>& Table();  ///< the options, declared once (with the ground's)
};

/// One object standing on the ground.
struct FoundObject {
  int id = 0;                   ///< 1, 2, ...: balls first (along the scene's x), then the rest
  /// "ball", "dome", "ellipsoid" or "not_a_ball" from the ball search; "ball", "dome", "spheroid"
  /// or "ellipsoid" for topiary found by height (topiary = true, `shape` set); "undecided" for an
  /// object too sparse to judge (`undecided`)
  std::string verdict;
  bool ball = false;            ///< a ball or dome from the ball search: a hedge measured as a sphere
  bool topiary = false;         ///< a clipped shape (every ball is one; so is a topiary found by height)
  /// An object judged as a clipped shape by height (found or refused: `topiary` says which): its
  /// shape in the scene frame (up +z; FindResult::scene_from_cloud turns the cloud into it) with
  /// its intervals, and the measures its verdict rests on.
  std::optional<TopiaryShape> shape;
  double covered = 0;           ///< share of its footprint's top-view cells holding points
  double covered_lower = 0;     ///< its lower 95 % bound
  /// A clipped shape fits and every test passes but the cover's bound: too few points to show a
  /// solid top (verdict "undecided", topiary false, `reason` says what spacing would decide).
  bool undecided = false;
  double roughness = 0;         ///< robust spread about its shape over the ground's noise
  double density = 0;           ///< points on its footprint over the lawn's beside it (per mm^2)
  double elongation = 0;        ///< long over short horizontal semi-axis, or vertical over short (the larger)
  std::string reason;           ///< why not a ball (or what makes it an ellipsoid); empty for a ball
  /// The measurement, in the cloud's frame: the envelope fit when it converged (sphere = centre
  /// and outer envelope radius, extras surface_radius_mm and leaf_depth_mm), else the geometric fit;
  /// converged = false for an object no sphere fits.
  fitting::SphereFitResult fit;
  std::optional<fitting::SphereFitResult> geometric;  ///< the geometric fit on the shell, when a sphere was found
  std::vector<std::size_t> indices;                    ///< the object's points, in the input cloud
  double seen_share = 0;        ///< share of the sphere's directions its points cover
  double lumpiness = 0;         ///< robust spread of the outermost points' radius per patch, over the radius
  double crowding = 0;          ///< points just outside the shell, per point on it (a neighbour pressed against it)
  /// Of the points the see-through check read (over a ball's core: from its one station, or from
  /// above), the share that passed through it; NaN when it was not read (fewer than 20 points).
  double seen_through = std::numeric_limits<double>::quiet_NaN();
  double axis_ratio = 1;        ///< vertical over horizontal semi-axis (1 when not judged)
  bool ground_seen = true;      ///< lawn was seen within a metre of a ball's foot (else the next three are NaN)
  double ground_mm = 0;         ///< the ground's height under the centre (along up; scene frame)
  double height_mm = 0;         ///< the top above the ground (balls), or the highest point above it
  double base_height_mm = 0;    ///< the centre above the ground, in radii (balls)
  double middle_mm = 0;         ///< half-way between its lowest and highest point (along up; scene frame)
  Eigen::Vector2d top_center_mm = Eigen::Vector2d::Zero();  ///< in the top view (scene x, y)
  std::vector<Eigen::Vector2d> top_outline_mm;              ///< convex hull of the points, top view
};

struct FindResult {
  std::string file;               ///< set by the caller
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  ///< the cloud's up, in its own frame
  std::string up_source;          ///< "z (default)", "-y (camera), refined to the ground", "given"
  Eigen::Matrix3d scene_from_cloud = Eigen::Matrix3d::Identity();  ///< rotation: up to +z
  double spacing_mm = 0;          ///< median distance between neighbouring points (cloud::MedianSpacing)
  std::size_t points = 0, ground_points = 0, object_points = 0;
  std::size_t viewpoints = 0;     ///< where the sensor stood, given (FindOptions::viewpoints_mm); 0: judged from above
  GroundModel ground;             ///< in the scene frame
  std::vector<FoundObject> objects;
  std::vector<std::pair<std::string, double>> timings_ms;  ///< per step
  /// What makes the result doubtful, one sentence each: no ground told apart from the objects (a
  /// cloud of one hedge alone, or the wrong up), a rough or tilted ground.
  std::vector<std::string> warnings;
  std::size_t Balls() const;
  std::size_t Topiary() const;  ///< balls, domes and every clipped shape found by height
};

/// Finds the ground, the objects on it and the balls among them in `cloud` (mm).
FindResult FindHedges(const cloud::PointCloud& cloud, const FindOptions& options = {});

/// `cloud` with "hedge_id" (the ball's id, 0 elsewhere), "object_id" (every object's id) and
/// "ground" (1 for ground points) fields, so compare, trim and render run on its balls.
cloud::PointCloud LabelCloud(const cloud::PointCloud& cloud, const FindResult& result);

/// The share of the sphere's directions (equal-area cells) that `points` cover, seen from `center`.
double SeenShare(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& center);

}  // namespace hedgefit::scene
