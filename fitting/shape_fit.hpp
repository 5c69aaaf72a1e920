#pragma once
/// The shapes box and yew are clipped to, with a vertical axis: a ball (4 parameters), a spheroid
/// (5: horizontal and vertical semi-axes) and an ellipsoid (7: three semi-axes and the heading),
/// each fitted by robust Levenberg-Marquardt (Huber weights, scale from the residuals' own
/// spread) on the radial distance to the surface, with a sandwich covariance. The class is the one
/// with the lowest Bayesian information criterion on the residuals clipped at 2.5 robust
/// deviations, when its axes also differ by more than 5 % (below that a gardener clips the simpler
/// shape, and thousands of points make any difference "significant"); a caller may limit the
/// choice to the families whose points lie within a robust spread (`max_spread_mm`). A ball or spheroid whose
/// centre lies below 0.8 of its vertical semi-axis above the ground is cut by it: a dome.
///
/// Topiary is also clipped to drums and boxes: a cylinder (4: centre, radius, top) and a cuboid
/// (6: centre, half-sides, top, heading) standing on the ground, fitted on their exact signed
/// distance. Either is chosen only when its criterion is lower and its points lie clearly closer
/// to it (a robust spread at most 0.6 of the chosen quadric's): on a rough real top, residuals that
/// are not independent make a box's extra parameters look significant. It is tried on 300 of the
/// points first, and only where the ellipsoid leaves more than the noise over 0.6 unexplained.
///
/// Measured (`envelope`), the axes are the envelope's: where the outer leaves end, what the shears
/// cut and a tape measure reads. The points of a leafy shape lie in a layer below it (and a
/// reconstruction's in a thicker one), so the surface fitted through them is smaller. Along each
/// point's normal, its residual from that surface is modelled as the envelope's offset, less a
/// leaf's depth below the envelope (none for a share w, the shears' cut; exponential for the rest),
/// plus the sensor's Gaussian noise (`noise_mm`): envelope_fit.hpp's model, in one dimension. Its
/// maximum likelihood gives the offset. A quadric's centre height and vertical semi-axis are then
/// fitted again on the exact distance along its normal (the nearest point of the surface), its
/// footprint held, with its points the offset inside it: the envelope itself. Seen from above, a
/// squat shape's vertical semi-axis is pinned only by the curvature of its rim, where the radial
/// distance is biased by noise (a flat spheroid read 3-20 % tall under 6-12 mm); a prism's sides
/// and top move out by the offset.
///
/// Up is +z: the caller turns its points (scene::FindHedges does; fitters.shape by its `up`).

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace hedgefit::fitting {

/// A clipped shape with a vertical axis, in the frame its points are given in (up +z).
struct ClippedShape {
  bool converged = false;
  std::string shape;             ///< "ball", "dome", "spheroid", "ellipsoid", "cylinder", "cuboid" or "cone"
  /// the family fitted: "ball" (4 parameters), "spheroid" (5), "ellipsoid" (7), or a prism standing
  /// on the ground, "cylinder" (4: centre, radius, top), "cuboid" (6: centre, half-sides, top, heading) or
  /// "cone" (4: centre, base radius, apex; axes_mm is then the base's radius twice and half the height)
  std::string family;
  std::string form;              ///< "oblate" or "prolate" for a spheroid or ellipsoid (vertical against horizontal), else ""
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axes_mm = Eigen::Vector3d::Zero();   ///< semi-axes: along the heading, across it, vertical
  double heading_deg = 0;        ///< of the first horizontal semi-axis from the scene's x, counter-clockwise, [0, 180)
  Eigen::Vector3d center_ci95_mm = Eigen::Vector3d::Zero();  ///< 95 % half-widths (sandwich; block jackknife when larger and asked for)
  Eigen::Vector3d axes_ci95_mm = Eigen::Vector3d::Zero();
  double roughness_mm = 0;       ///< robust spread (1.4826 MAD) of the radial residuals, mm
  double bic_ball = 0, bic_spheroid = 0, bic_ellipsoid = 0;  ///< the criterion per family (lower is better)
  double bic_cylinder = 0, bic_cuboid = 0;                    ///< the prisms' (0: not fitted)
  /// The share of each prism's walls that holds points half-way up (16 sectors about its axis; a
  /// prism is chosen only from 0.5); 0 when not fitted.
  double walls_cylinder = 0, walls_cuboid = 0;
  double bic_cone = 0, walls_cone = 0;                        ///< the same for a cone (apex up, standing on the ground)
  std::size_t points = 0;
  bool jackknifed = false;       ///< the intervals include the block jackknife
  /// The footprint on the ground: the horizontal semi-axes where the shape meets the ground
  /// (the full ones when its centre is above it).
  Eigen::Vector2d footprint_mm = Eigen::Vector2d::Zero();
  double top_mm = 0;             ///< the shape's top, height above the ground under its centre
  /// How far the envelope lies outside the surface fitted through the points (mm, >= 0; already
  /// in the axes, footprint and top); 0 unless asked for.
  double envelope_offset_mm = 0;
};

/// Fits the three families to `points` (up +z, mm) standing on ground of height `ground_mm` and
/// chooses one. `noise_mm` is the sensor's (the robust scale never goes below half of it);
/// `widest_mm` bounds the horizontal semi-axes (0: 1.3 times the points' 98th-percentile reach
/// from their centre in the top view). At most `max_points`, evenly through the list, are fitted;
/// the intervals are scaled to all of them. converged = false on fewer than 20 points.
/// `jackknife`: the intervals are also taken from a block jackknife over 16 patches of the surface
/// (the larger of the two is reported): residuals that move together (a leaf layer, a lower half
/// nobody saw) make the sandwich interval far too narrow; with `envelope`, each refit estimates its
/// own envelope offset, so the axes' intervals hold the leaf layer's uncertainty. `envelope`: the axes are the envelope's
/// (above), from the leaf layer's model with the noise `noise_mm` (at least 1 mm; 0: estimated
/// with the layer from the residuals), of the chosen
/// family fitted again without the points beyond 2.5 robust deviations of its median residual.
/// `max_spread_mm` (0: none): when one of the quadrics' points lie within this robust spread of it,
/// the class is chosen among those that do (a caller that refuses a rougher shape asks whether
/// any of the families is smooth enough, not only the one the criterion prefers). `round`: only
/// the families whose footprint is a circle are candidates (ball, spheroid, cylinder, cone).
/// `viewpoints` (the points' frame, mm): where the sensor stood; the envelope's leaf layer then
/// reads its noise and its leaves' depth along each point's rays (with none, the noise is held
/// about the vertical).
ClippedShape FitClippedShape(const std::vector<Eigen::Vector3d>& points, double ground_mm, double noise_mm,
                             double widest_mm = 0, std::size_t max_points = 800, bool jackknife = false,
                             bool envelope = false, double max_spread_mm = 0, bool round = false,
                             const std::vector<Eigen::Vector3d>& viewpoints = {});

/// How far `p` lies outside the shape `s` (mm; negative inside), along the shape's normal: the
/// exact distance to the nearest point of a quadric's surface (a prism's: the signed distance
/// its fit uses). Both in the frame `s` was fitted in (up +z).
double DistanceOutside(const ClippedShape& s, const Eigen::Vector3d& p);

/// A shape's axes in its cloud's frame, as columns: along its heading, across it, along `up`.
/// The heading turns counter-clockwise about `up` from the cloud's x axis laid flat (its y axis
/// when x is `up`). trim's target, render's overlay and fitters.shape read the shape so.
Eigen::Matrix3d ShapeAxes(const Eigen::Vector3d& up, double heading_deg);

}  // namespace hedgefit::fitting
