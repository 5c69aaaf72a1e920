#pragma once
/// A leafy hedge is a shell, not a surface: stereo sees the outermost leaves and, through the
/// gaps, leaves deeper along the line of sight. A sphere fitted to all of them has the radius
/// of the mean leaf and a centre pushed away from the camera. This fit models each point's
/// distance from the centre s_i as the envelope radius R minus a depth below it seen along the
/// view ray, plus Gaussian measurement noise (sigma, also along the ray, as stereo's depth error
/// is), both seen radially scaled by cos(theta_i), theta_i the angle between the ray and the
/// sphere's normal there. The depth is a mixture: a share w of the leaves lies on the envelope
/// itself (a clipped hedge: the shears cut the outer leaves flush with it), the rest deeper,
/// exponentially (mean mu: the gaps one sees into); a small uniform share of outliers is
/// allowed. Maximum likelihood (Ceres LBFGS) gives
///  - the outer envelope radius R: where the leaves end, what a tape measure and a trimmer see;
///  - the mean leaf-surface radius R - (1 - w) mu: where the average visible leaf is;
///  - one centre for both, not pulled by the depth of the leaf layer.
/// On a bare sphere (w -> 1 or mu -> 0) it reduces to the geometric fit. Without the share on
/// the envelope, a clipped hedge's cut leaves were read as noise about a start a little deeper,
/// and the envelope came out inside (see the tests and README's "The envelope").

#include <Eigen/Core>

#include <limits>
#include <optional>
#include <vector>

#include "cloud/outline_rays.hpp"
#include "pipeline/option_table.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

struct EnvelopeFitOptions {
  Eigen::Vector3d viewpoint_mm = Eigen::Vector3d::Zero();  ///< the camera, mm (the cloud's origin for hedgefit's clouds)
  double outlier_share = 0.02;  ///< prior share of points from neither leaves nor noise (uniform)
  int max_iterations = 200;     ///< LBFGS iterations at most
  /// The likelihood is summed over about this many points (a share of them chosen by where each
  /// lies: cloud::StableSample): six parameters are settled to ~0.1 mm by 10000 points, and
  /// the cost grows with every point. 0 = all.
  int max_points = 10000;
  /// With an outline, about this many of the front's points per outline ray (chosen as for
  /// max_points), so that the front's leaves and the outline have a comparable say in where the
  /// envelope lies; 0 = off (max_points alone). 1 was chosen on the tuning gardens of both
  /// renderers, where it put the paper's hedge size's centres nearer (LD 2.73 -> 1.93 mm on
  /// POV-Ray's, 2.14 -> 1.65 on hedgefit's) and held the smaller balls' (CHANGELOG's Record "The
  /// front's points against the outline's rays").
  double points_per_ray = 1;
  /// A matching window about one of the outermost leaves also sees the deeper leaves around it,
  /// so stereo reads the outermost leaves too deep, by about half a pixel's footprint there
  /// (Z / f): against each renderer's per-pixel truth, 0.45-0.47 footprints on hedgefit's three
  /// garden sets and 0.47-0.58 on POV-Ray's (bench garden, "the matcher against the renderer's
  /// own leaves"), 0.5-2 mm at 1.3-3 m. The envelope adds this many footprints back, point by
  /// point, where the cloud says what a pixel spans (its "pixel_mm" field); 0 = off. Footprints
  /// over 4 mm (beyond those it was measured at) count as 4 mm. With an outline it is fitted
  /// per hedge, this value the centre of its prior (1 px wide).
  double top_bias_px = 0.5;
  /// A prior on the envelope's radius (mm; NaN = none) and its standard deviation: the radius
  /// known from elsewhere (several captures of the hedge fused), so one capture's cap, whose
  /// radius trades against its centre's depth, gives its centre alone.
  double radius_prior_mm = std::numeric_limits<double>::quiet_NaN();
  double radius_prior_sd_mm = 1;
  /// The leaves' and the outline's parameters (EnvelopeFit::shape of another fit) to hold this fit
  /// to; empty = free.
  std::vector<double> shape_prior;
  void Check() const;
  static const pipeline::OptionTable<EnvelopeFitOptions>& Table();  ///< the options, declared once
};

struct EnvelopeFit {
  SphereFitResult fit;            ///< sphere = centre and outer envelope radius (method "envelope")
  double surface_radius_mm = 0;   ///< mean leaf-surface radius, R - top bias - (1 - w) mu
  double leaf_depth_mm = 0;       ///< (1 - w) mu: mean depth of the visible leaves below the envelope, face-on
  double noise_mm = 0;            ///< sigma: measurement noise along the view ray
  double clipped_share = 0;       ///< w: share of the points on the envelope itself (leaves cut flush)
  double top_bias_mm = 0;         ///< the matcher's mean reading of the outermost leaves below them, added back
  double top_bias_px = 0;         ///< the same in pixel footprints: top_bias_px, or fitted where there is an outline
  std::size_t outline_rays = 0;   ///< outline rays the fit used (both views)
  double outline_noise_px = 0;    ///< the outline's edge noise (px)
  double outline_ragged_px = 0;   ///< the outline's mean depth inside the envelope's tangent (px): its raggedness
  /// The fit's mean negative log-likelihood per point (nats; with any priors): a density of the
  /// points' distances from the centre, so two fits of the same points under different view
  /// models (one viewpoint, or one per point) compare by it.
  double mean_nll = std::numeric_limits<double>::quiet_NaN();
  /// With an outline: standard errors of (cx, cy, cz, R), mm, from the likelihood itself (a
  /// cluster sandwich over patches of the sphere and sectors of the outline, so correlated
  /// errors count once), with the top bias' and the leaves' parameters free.
  std::optional<Eigen::Vector4d> std_error_mm;
  /// The fitted leaves' and outline's parameters as the search holds them (for
  /// EnvelopeFitOptions::shape_prior).
  std::vector<double> shape;
};

/// Fits the envelope, starting from `initial` (e.g. a geometric fit) or a Hyper fit.
/// `pixel_mm` (optional, one per point): the lateral size of one pixel at each point (Z / f, a
/// capture cloud's "pixel_mm" field), for options.top_bias_px; without it (null or empty) no bias
/// is added.
/// `outline` (optional): the hedge's outline as tangent rays (stereo::MeasureOutlines, both views):
/// the envelope is fitted to touch them too, and the top bias is fitted (about top_bias_px).
/// `viewpoints` (optional, one per point): where each point was seen from, for points fused from
/// several captures (options.viewpoint_mm is then unused); the outline's rays carry their own.
EnvelopeFit FitEnvelope(const std::vector<Eigen::Vector3d>& points_mm, const EnvelopeFitOptions& options = {},
                        const Sphere* initial = nullptr, const std::vector<double>* pixel_mm = nullptr,
                        const std::vector<cloud::TangentRay>* outline = nullptr,
                        const std::vector<Eigen::Vector3d>* viewpoints = nullptr);


namespace detail {
/// The shell model's mean negative log-likelihood over `points` at the 10 parameters p (centre x,
/// y, z, R, log of the exponential's mean, log of the noise, logit of the share on the envelope;
/// both scales above a 0.01 mm floor; the top bias in footprints; the outline's noise as a logit
/// between 0.02 and 0.52 px and the log of its raggedness in px) and, when `gradient` is given, its gradient: what FitEnvelope minimises, exposed so a test
/// can hold the hand-written gradient to differences. `footprint_mm` (one per point, or null): the
/// top bias' unit; `rays` with `px_per_mm` (one per ray, or null): the outline.
double ShellCost(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& viewpoint_mm, double outlier_share,
                 double outlier_width_mm, const double* p, double* gradient,
                 const std::vector<double>* footprint_mm = nullptr, const std::vector<cloud::TangentRay>* rays = nullptr,
                 const std::vector<double>* px_per_mm = nullptr, double top_bias_px = 0.5);
}  // namespace detail

}  // namespace hedgefit::fitting
