#pragma once
/// Geometric sphere fit: minimises sum rho((|p_i - c| - r)^2), the true orthogonal
/// distance (not r^2 - |p - c|^2, the algebraic residual of Ceres' circle example), with
/// Ceres' Levenberg-Marquardt, started from an algebraic fit. Reports the covariance of
/// (centre, radius) from Ceres, scaled by the residual variance, as standard errors.

#include <optional>
#include <string>
#include <vector>

#include "pipeline/option_table.hpp"
#include "fitting/algebraic_fit.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

enum class RobustLoss { kNone, kHuber, kCauchy, kTukey };

/// "none", "huber", "cauchy", "tukey"; the parser throws hedgefit::Error if unknown.
/// The losses by name, the one list the option table and LossName() read.
const std::vector<std::pair<std::string, RobustLoss>>& LossNames();
const char* LossName(RobustLoss loss);

struct GeometricFitOptions {
  AlgebraicMethod initial = AlgebraicMethod::kHyper;  ///< starting fit, when none is given
  RobustLoss loss = RobustLoss::kNone;                ///< robust loss on the residuals
  double loss_scale_mm = 5.0;          ///< residual size where the loss starts to down-weight, mm
  bool analytic_derivatives = true;    ///< false: Ceres' automatic differentiation
  int max_iterations = 100;            ///< Levenberg-Marquardt iterations at most
  bool compute_covariance = true;      ///< standard errors of (cx, cy, cz, r)
  int num_threads = 0;                 ///< 0 = all cores
  /// Throws hedgefit::Error naming the bad option.
  void Check() const;
  static const pipeline::OptionTable<GeometricFitOptions>& Table();  ///< the options, declared once
};

/// Fits a sphere by orthogonal distance. `initial` (if given) replaces the algebraic start.
SphereFitResult FitSphereGeometric(const std::vector<Eigen::Vector3d>& points_mm,
                                   const GeometricFitOptions& options = {}, const Sphere* initial = nullptr);

/// The same least squares (no loss, no covariance) by plain Gauss-Newton from `start`, which must
/// already be close: the refit that the uncertainty's jackknife and perturbations repeat dozens of
/// times per fit, on the same points less a patch or moved by a millimetre. Single-threaded.
/// nullopt for fewer than 4 points, a singular system or no settling within `max_iterations`.
std::optional<Sphere> RefitSphereGeometric(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& start,
                                           int max_iterations = 20);

/// The same with Ceres' HuberLoss(`huber_mm`) (FitSphereGeometric with RobustLoss::kHuber and that
/// scale, no covariance), by reweighted Levenberg-Marquardt in closed form: the robust refit a
/// search repeats hundreds of times per cloud (`find`'s ball hypotheses), without Ceres' set-up
/// for each. nullopt for fewer than 4 points, no loss scale, or no step under `tolerance_mm`
/// within `max_iterations` (a cap too small to pin a sphere, as Ceres' would not converge).
std::optional<Sphere> RefitSphereHuber(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& start, double huber_mm,
                                       int max_iterations = 50, double tolerance_mm = 1e-6);

}  // namespace hedgefit::fitting
