#pragma once
/// Around the hedge: several captures, each with the pose of its left camera in a common frame,
/// fused into one measurement per hedge.
///  1. Each capture is measured alone (views.hpp): its hedges' points, outlines and envelope fits,
///     in its own camera frame.
///  2. Match: a hedge is the same hedge in every capture that puts its centre, through the given
///     pose, within `match_gate_radii` of its radius of the others'.
///  3. Register: the given poses (odometry: centimetres and a degree or two off) are corrected so
///     that every capture's hedge centres agree, each capture's fitted centre weighted by its own
///     standard errors, with the given pose as a prior (`prior_translation_mm`,
///     `prior_rotation_deg`) and each step between consecutive given poses (in time, when every
///     capture has one) as a between-factor (`step_translation_share`, `step_rotation_deg`); the
///     first capture fixes the frame. What the hedges cannot pin (one ball: the turn of a capture
///     about it) stays where the given poses and their steps hold it, and the correction's
///     standard deviations (the hedges' and the prior's) say so. Optionally the corrected poses
///     are refined by PCL's generalized ICP on the hedges' surfaces. A capture whose correction exceeds the limits or
///     whose hedges match no other capture's is left out, with the reason.
///  4. Fit each hedge to all its points: the leafy envelope (fitting::FitEnvelope, each point
///     seen from its own capture's camera, every capture's outline), with standard errors from
///     the likelihood and from leaving out each capture in turn (the views' disagreement), the
///     larger kept.
///  5. Coverage: the share of the sphere's directions (equal-area cells about the vertical) that
///     hold points, per capture and together.

#include <Eigen/Geometry>

#include <optional>
#include <string>
#include <vector>

#include "cloud/outline_rays.hpp"
#include "cloud/point_cloud.hpp"
#include "fitting/envelope_fit.hpp"
#include "pipeline/option_table.hpp"

namespace hedgefit::around {

/// One hedge as one capture measured it, in that capture's camera frame (mm).
struct ViewHedge {
  int id = 0;                                  ///< the capture's hedge_id
  std::vector<Eigen::Vector3d> points_mm;      ///< cleaned
  std::vector<double> pixel_mm;                ///< per point, or empty
  std::vector<cloud::TangentRay> outline;      ///< both views' tangent rays, or empty
  fitting::SphereFitResult fit;                ///< the capture's own envelope fit (std_error_mm set)
};

/// One capture measured alone, with its given pose.
struct View {
  std::string name;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  ///< given, mm
  /// when it was taken (s), if known: the steps between given poses follow time when every
  /// capture has one, else the order the captures are given in
  std::optional<double> time_s;
  std::vector<ViewHedge> hedges;
  std::string failed;  ///< why the capture gave no hedge ("" = it did)
};

struct FuseOptions {
  std::string registration = "centres";  ///< none, centres, or centres+gicp
  double match_gate_radii = 0.6;          ///< centres within this many radii are one hedge
  double prior_translation_mm = 150;      ///< the given poses' error, 1 sigma (odometry: cm)
  double prior_rotation_deg = 3;          ///< ... and of their orientation
  /// The given poses' steps: each capture's pose relative to the previous one (in time when
  /// every capture has a time, else in the order given) is good to this share of the step's
  /// length (at least 10 mm) and this turn, 1 sigma. An odometry's error accumulates along the
  /// path (wheel odometry drifts 1-5 % of the distance, a degree or so a turn), so neighbours
  /// are better known relative to each other than each is alone. 0 for either: the steps are not
  /// used (poses with independent errors).
  double step_translation_share = 0.05;
  double step_rotation_deg = 1;
  double max_correction_mm = 600;         ///< a larger correction leaves the capture out
  double max_correction_deg = 15;
  double max_centre_residual_mm = 25;     ///< a capture's centre further from the hedge's after registration is left out
  double gicp_max_distance_mm = 20;       ///< generalized ICP's correspondence distance
  int fit_points = 30000;                 ///< points of a hedge the fused fit uses at most (every n-th per capture)
  double cell_deg = 10;                   ///< coverage cells, about this wide
  int cell_min_points = 3;                ///< a cell with fewer is not covered
  bool jackknife = true;                  ///< standard errors also from leaving out each capture
  /// A fused hedge is unconfirmed (FusedHedge::unconfirmed says why) when fewer captures than
  /// this saw it while more were used, when the captures together cover less than
  /// `min_coverage` of its sphere, when its radius is outside [min_radius, max_radius], or when
  /// its interval could not be computed. One capture's view of a ball at 2-3 m covers 20-35 % of
  /// it (the around benches); a fence post, a shrub's lobe or a stretch of lawn taken for a hedge
  /// by one capture covers a few percent.
  int confirm_captures = 2;
  double confirm_coverage = 0.1;
  double confirm_min_radius_mm = 150, confirm_max_radius_mm = 2000;
  void Check() const;
  static const pipeline::OptionTable<FuseOptions>& Table();
};

/// A capture's pose as registration left it.
struct PoseResult {
  std::string name;
  bool used = true;
  std::string left_out;                   ///< why not ("" = used)
  Eigen::Isometry3d given = Eigen::Isometry3d::Identity(), refined = Eigen::Isometry3d::Identity();
  double correction_mm = 0, correction_deg = 0;       ///< |refined given^-1|: the camera centre's move, the turn
  /// Of the 6 degrees of freedom of its pose, how many the hedges pinned (one ball: 3, its turn
  /// about the ball held at the given pose; two balls: 5; 0 without registration).
  int determined_dof = 0;
  double sigma_mm = 0, sigma_deg = 0;     ///< standard deviation (largest axis) of the pinned part: camera centre, turn
  double centre_residual_mm = 0;          ///< its hedge centres' largest distance from the fused ones
  double gicp_rms_mm = 0;                 ///< generalized ICP's fitness (RMS), 0 without it
  int hedges = 0;                         ///< hedges it saw that matched
};

struct FusedHedge {
  int id = 0;                              ///< 1, 2, ...: by x of the world frame
  fitting::EnvelopeFit fit;                ///< all captures together, world frame
  Eigen::Vector4d std_error_mm = Eigen::Vector4d::Constant(NAN);       ///< cx, cy, cz, R: the largest of the three below
  Eigen::Vector4d likelihood_se_mm = Eigen::Vector4d::Constant(NAN);   ///< the fit's own (sandwich)
  Eigen::Vector4d jackknife_se_mm = Eigen::Vector4d::Constant(NAN);    ///< leaving out each capture
  /// Where the registration could put the centre (the first capture held): the captures' centres'
  /// errors through the poses, and what only the given poses' prior pins. NaN without registration.
  Eigen::Vector3d registration_se_mm = Eigen::Vector3d::Constant(NAN);
  std::vector<int> views;                  ///< indices of the captures that saw it
  std::vector<Eigen::Vector3d> view_centres_mm;  ///< each capture's own centre, world frame (refined poses)
  std::vector<double> view_radii_mm;
  std::vector<double> view_coverage;       ///< each capture's share of the sphere
  double coverage = 0;                     ///< all together
  std::size_t points = 0;
  /// Why this hedge is not confirmed (FuseOptions::confirm_captures ...): reported apart from the
  /// hedges, never as one; "" = confirmed.
  std::string unconfirmed;
};

struct FuseResult {
  std::vector<PoseResult> poses;
  std::vector<FusedHedge> hedges;
  /// All captures' hedge points in the world frame: fields hedge_id (the fused hedge), capture
  /// (1-based index), pixel_mm, and view_x/y/z_mm (the camera each point was seen from).
  cloud::PointCloud cloud;
  Eigen::Vector3d up = -Eigen::Vector3d::UnitY();  ///< the world's vertical (from the cameras)
  std::vector<std::string> warnings;
};

/// Fuses the captures. Throws hedgefit::Error when no capture gave a hedge.
FuseResult Fuse(const std::vector<View>& views, const FuseOptions& options = {});

/// The share of the sphere `center` covered by `points_mm`: equal-area cells about `up`, about
/// `cell_deg` wide, with at least `min_points` points.
double CoveredShare(const std::vector<Eigen::Vector3d>& points_mm, const Eigen::Vector3d& center, const Eigen::Vector3d& up,
                    double cell_deg, int min_points);

}  // namespace hedgefit::around
