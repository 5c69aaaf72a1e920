#pragma once
/// How far a sphere fit can be trusted: standard errors from the points' scatter (any method)
/// and from a systematic error source such as the rig's calibration (by refitting perturbed
/// copies of the points), combined into a 95 % interval per coordinate.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "cloud/point_perturbation.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

/// The points a converged fit rests on: of those within max(50 mm, r / 10) of the surface, the
/// ones within 3 robust standard deviations (1.4826 MAD) of their median residual |p - c| - r.
/// For robust methods these are about its inliers, however much of the cloud is something else.
std::vector<Eigen::Vector3d> SupportingPoints(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& sphere);

/// Standard errors of (cx, cy, cz, r) from the scatter of `support` about `sphere`: the inverse
/// normal matrix of the geometric residuals times their variance, inflated by sqrt(correlation_area)
/// because neighbouring stereo points share matching windows and are not independent.
std::optional<Eigen::Vector4d> ScatterStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                               double correlation_area = 1.0);

/// Standard errors of (cx, cy, cz, r) by a delete-a-group jackknife over 16 patches of the
/// surface (polar angle from the camera's axis above and below its median, times 8 azimuth
/// sectors), refitting by geometric least squares from `sphere` without each patch in turn.
/// Unlike ScatterStdError it counts errors that neighbouring points share, and errors that
/// differ between the rim and the middle of the seen cap. On up to `max_points` (evenly taken).
std::optional<Eigen::Vector4d> BlockJackknifeStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                      std::size_t max_points = 3000);

/// Standard errors of (cx, cy, cz, r) by a delete-a-group jackknife over `bands` horizontal
/// slices of `support` (equal counts along `up`), refitting by geometric least squares from
/// `sphere`. A scanner lays its points in rings, one laser each, and a laser's own range offset
/// moves its whole ring: on a ball at a distance from a level scanner a ring is a horizontal
/// slice, which the patches above cut across and so count as independent errors. On up to
/// `max_points` (evenly taken); nullopt with fewer than 64 points.
std::optional<Eigen::Vector4d> BandJackknifeStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                     const Eigen::Vector3d& up, int bands = 8,
                                                     std::size_t max_points = 3000);

/// Standard errors of (cx, cy, cz, r) by a delete-a-ring jackknife: `support` grouped by the
/// rings a spinning scanner at `scanner` laid it in (its elevation about `spin_axis`: a laser
/// sweeps a cone, so a ring's points share one elevation to a few hundredths of a degree, and
/// rings lie tenths of a degree to degrees apart), refitting by geometric least squares from
/// `sphere` without each ring in turn. A laser's own range and angle offsets move its whole ring,
/// so a ball's error is its rings', a handful, not its hundreds of points'. With so few groups the
/// jackknife's variance has (rings - 1) degrees of freedom: the errors returned are scaled so that
/// 1.96 of them is Student's 95 % interval (x 1.25 with 7 rings). nullopt when the elevations do
/// not fall in rings (a gap-parted group wider than 0.3 degrees: not a spinning scanner's, or
/// not about this axis), with fewer than 4 rings, or fewer than 64 points. On up to `max_points`.
std::optional<Eigen::Vector4d> RingJackknifeStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                     const Eigen::Vector3d& scanner, const Eigen::Vector3d& spin_axis,
                                                     std::size_t max_points = 3000);

/// Student's t distribution's two-sided 95 % quantile for `dof` degrees of freedom (12.71 at 1,
/// 2.45 at 6, 1.96 as dof grows).
double StudentT95(int dof);

/// Standard deviations of (cx, cy, cz, r) over the perturbation's draws: each draw moves (up to
/// `max_points` of, evenly taken) `support`, and a geometric least-squares fit from `sphere`
/// is refitted. nullopt with fewer than 2 draws or points.
std::optional<Eigen::Vector4d> PerturbationStdError(const std::vector<Eigen::Vector3d>& support, const Sphere& sphere,
                                                    const cloud::PointPerturbation& perturbation,
                                                    std::size_t max_points = 3000);

/// Fills a converged fit's uncertainty: std_error_mm, the larger of the method's own (or the
/// scatter's, where it gave none) and the block jackknife's, rig_std_error_mm from the rig's perturbation and matching_std_error_mm from the
/// disparity offset's, each when given with draws.
void AddUncertainty(const std::vector<Eigen::Vector3d>& points_mm, const cloud::PointPerturbation* rig,
                    SphereFitResult* fit, const cloud::PointPerturbation* matching = nullptr);

/// Standard error of (cx, cy, cz, r) from every source the fit has (root sum of squares), and
/// the half-width of its 95 % interval (1.96 standard errors); nullopt without any.
std::optional<Eigen::Vector4d> TotalStdError(const SphereFitResult& fit);

}  // namespace hedgefit::fitting
