#pragma once
/// Spheres, fit results, and the checks every fitter shares. Units are mm.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pipeline/stage.hpp"  // OptionValue

namespace hedgefit::fitting {

struct Sphere {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();  ///< centre, mm, in the cloud's frame
  double radius_mm = 0.0;                                ///< radius, mm
};

/// What a fitter found, and whether it can be trusted. Failing is a result, not an exception.
struct SphereFitResult {
  std::string method;           ///< a name from the method table (fitting/methods.hpp)
  int hedge_id = 0;             ///< which hedge of a capture (the cloud's hedge_id field); 0 = the cloud is one hedge
  Sphere sphere;                ///< meaningful only when converged
  bool converged = false;       ///< false: `message` says why
  double rms_mm = 0.0;          ///< RMS of |p - c| - r over the points used (inliers for RANSAC), mm
  std::size_t points_used = 0;  ///< points the fit saw
  std::size_t inliers = 0;      ///< points counted as inliers (all points for non-robust fits)
  int iterations = 0;           ///< solver iterations (0 for closed-form fits)
  double wall_ms = 0.0;         ///< time spent in the fitter, ms
  /// Standard errors of (cx, cy, cz, r), mm, where the method provides them.
  std::optional<Eigen::Vector4d> std_error_mm;
  /// std_error_mm is the method's own and already counts correlated errors (the envelope fit
  /// with an outline): AddUncertainty keeps it instead of the points' scatter and jackknife.
  bool std_error_own = false;
  /// Standard errors of (cx, cy, cz, r), mm, from the rig's calibration uncertainty (sampled
  /// rigs re-triangulating the points; fitting/uncertainty.hpp), when the rig's covariance is known.
  std::optional<Eigen::Vector4d> rig_std_error_mm;
  /// Standard errors of (cx, cy, cz, r), mm, from a disparity offset common to the hedge (the
  /// matcher's bias on real images), for clouds from a stereo capture.
  std::optional<Eigen::Vector4d> matching_std_error_mm;
  std::string message;          ///< empty, or why the fit failed, or a warning
  /// What a method reports beside the sphere, by name and in the order it adds them, written
  /// out as they are (FitFields): the envelope's surface_radius_mm (the mean leaf surface),
  /// leaf_depth_mm and top_bias_mm (`sphere` is the outer envelope); the ellipsoid's and
  /// spheroid's axes_mm (largest first), vertical_axis_mm and horizontal_axis_mm (`sphere` holds
  /// the centre and the axes' geometric mean). A new method adds its own without a new field here.
  std::vector<std::pair<std::string, std::vector<double>>> extras;
  /// Set when the fitted sphere is far wider than the points (ShallowPatchReason): they are a
  /// shallow patch of it, as a lumpy shrub, a wall or a lawn gives, not a ball; says why.
  std::optional<std::string> not_a_ball;
  /// What the checks of the fit's inputs found (pipeline::InputCheck::fields: the capture's rig
  /// against its own images, "rig_check" ...), written out after the method's extras.
  std::vector<std::pair<std::string, pipeline::OptionValue>> checks;
  /// Set when the inputs cannot be trusted (the rig no longer fits the cameras): says why. The
  /// sphere is still reported, for diagnosis, but must not be acted on.
  std::optional<std::string> unusable;

  /// The first value of extra `name`, when the method reported it.
  std::optional<double> Extra(const std::string& name) const;
  /// Sets extra `name` (replacing it when present).
  void SetExtra(const std::string& name, std::vector<double> values);
  /// Whether the sphere can be acted on: the fit converged, its points are a ball's and its
  /// inputs passed their checks (in the spirit of Ceres' Summary::IsSolutionUsable): the one
  /// place that says so.
  bool IsUsable() const { return converged && !not_a_ball && !unusable; }
};

/// Why a point set cannot determine a sphere, or nullopt if it can: fewer than 4
/// points, a NaN/Inf coordinate, all points identical, collinear or coplanar.
/// Coordinates are centred and scaled before the rank test, so the check does not
/// depend on where the cloud is or its units.
std::optional<std::string> DegeneracyReason(const std::vector<Eigen::Vector3d>& points_mm);

/// The same rules from summary statistics: point count, whether all were finite, their
/// mean and covariance (mean of (p - mean)(p - mean)^T).
std::optional<std::string> DegeneracyFromMoments(std::size_t n, bool finite, const Eigen::Vector3d& mean,
                                                 const Eigen::Matrix3d& covariance);

/// The points' span: the distance between their 2nd and 98th percentiles along the direction
/// they spread most across the line of sight from `viewpoint_mm` (the camera: the origin of a
/// capture's cloud), or in 3-D when the viewpoint is among them, mm. A ball's visible cap spans
/// nearly its diameter, whatever the depth noise along the rays.
double PrincipalSpan(const std::vector<Eigen::Vector3d>& points_mm,
                     const Eigen::Vector3d& viewpoint_mm = Eigen::Vector3d::Zero());

/// A ball's sphere is at most this many times as wide as its points' span (PrincipalSpan). A
/// camera sees a cap of a ball up to its limb, a disc 2r sqrt(1 - (r/D)^2) across (0.89 of the
/// diameter for the paper's outdoor hedge, r 920 mm at D 2 m; more for smaller or farther ones),
/// its points spread evenly over the image (their 2-98 % span 0.90 of the disc's diameter); the
/// mask's erosion, a ball half out of the frame and the lowest part hidden by the lawn take some of
/// that but leave its larger extent above half the diameter: at most 2. Both renderers' 36 garden
/// balls give 1.30-1.67. A lumpy shrub's front or a stretch of lawn is fitted by a sphere many
/// times wider than it (7.9-10 on the hard set's four-lobed shrub).
constexpr double kMaxSphereToSpan = 2.5;

/// A ball's points lie on or inside its sphere but for the stereo noise and the leaves the fit
/// puts outside it (a few mm; at 2-3 m a stereo point scatters by 5-10 mm): at most this share
/// of them more than kOutsideRadiusShare of the radius outside it. Both renderers' garden balls
/// have at most 0.6 % so (a touching neighbour's rim); the sphere of one of a shrub's lobes fitted
/// to the whole shrub has 12-42 %.
constexpr double kMaxOutsideShare = 0.05;
constexpr double kOutsideRadiusShare = 0.1;

/// The share of the points more than kOutsideRadiusShare of its radius outside `sphere`.
double OutsideShare(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& sphere);

/// Why `fit` is not the ball these points are on, or nullopt: its sphere is more than
/// kMaxSphereToSpan times as wide as their span (a shallow patch of it), or more than
/// kMaxOutsideShare of them lie more than kOutsideRadiusShare of its radius outside it (they are
/// more than one ball). The second is not asked of a consensus fit (RANSAC: some points its
/// inliers), which may pick a ball out of a scene, unless the points are `one_hedge`'s (a
/// segmented hedge, which should be one ball).
std::optional<std::string> NotABallReason(const std::vector<Eigen::Vector3d>& points_mm, const SphereFitResult& fit,
                                          bool one_hedge = false);

/// RMS of the geometric residuals |p - c| - r, mm.
double RmsResidual(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& sphere);

/// Converts float points (a cloud's storage) to double.
std::vector<Eigen::Vector3d> ToDouble(const std::vector<Eigen::Vector3f>& points_mm);

}  // namespace hedgefit::fitting
