#pragma once
/// Sphere fit along the sensor's rays. A stereo camera measures each point's range along the
/// ray of its (exact) pixel, and its noise lies along that ray; a LiDAR's likewise. The
/// orthogonal distance |p - c| - r then carries the noise into its regressors (the direction
/// from the centre to the noisy point), and on a cap seen from one side that errors-in-variables
/// bias reads the sphere small and near: with the lab's real-camera noise (6-8 mm along the rays
/// at 2-2.6 m) the geometric fit of points with unbiased Gaussian range noise is 0.8-1.3 mm small.
/// Here each point's residual is its range less the range at which its ray first meets the
/// sphere, t - t0(c, r): the ray is exact and the noise is in t alone, so the least squares are
/// unbiased to first order whatever the noise. Rays that pass the centre farther out than
/// sqrt(1 - min_chord^2) r (the last few per cent before the outline, where t0 stops depending
/// smoothly on the sphere) keep the orthogonal distance, divided by min_chord (the cosine of
/// incidence at the band's edge) so the two forms meet for points near the sphere. Which form a
/// point takes is decided where the sphere is and kept while Gauss-Newton settles, then decided
/// again, until no point changes (a point far off the sphere switching mid-search made the steps
/// cycle on a LiDAR scan); a ray the sphere moves off keeps a smooth residual (the half-chord
/// continues along its tangent). Gauss-Newton from a start close to the
/// answer (RANSAC's sphere, the geometric fit), standard errors from the residual variance.

#include <Eigen/Core>

#include <vector>

#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

struct RayFitOptions {
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();  ///< where the rays start: the sensor, in the cloud's frame
  /// Rays whose half-chord through the sphere is below min_chord * r use the orthogonal distance.
  double min_chord = 0.2;
  int max_iterations = 50;
};

/// Fits a sphere to `points_mm` by their ranges along the rays from `options.origin_mm`, from
/// `start`. Not converged (with a message) for fewer than 4 points, an origin inside or behind
/// the sphere, a singular system or no settling within max_iterations.
SphereFitResult FitSphereAlongRays(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& start,
                                   const RayFitOptions& options = {});

}  // namespace hedgefit::fitting
