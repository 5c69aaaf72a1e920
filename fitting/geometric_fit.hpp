#pragma once
/// Geometric sphere fit: minimises sum rho((|p_i - c| - r)^2), the true orthogonal
/// distance (not r^2 - |p - c|^2, the algebraic residual of Ceres' circle example), with
/// Ceres' Levenberg-Marquardt, started from an algebraic fit. Reports the covariance of
/// (centre, radius) from Ceres, scaled by the residual variance, as standard errors.

#include <string>
#include <vector>

#include "cloud/option_table.hpp"
#include "fitting/algebraic_fit.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

enum class RobustLoss { kNone, kHuber, kCauchy, kTukey };

/// "none", "huber", "cauchy", "tukey"; the parser throws hedgefit::Error if unknown.
const char* LossName(RobustLoss loss);
RobustLoss ParseLoss(const std::string& name);

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
  static const cloud::OptionTable<GeometricFitOptions>& Table();  ///< the options, declared once
};

/// Fits a sphere by orthogonal distance. `initial` (if given) replaces the algebraic start.
SphereFitResult FitSphereGeometric(const std::vector<Eigen::Vector3d>& points_mm,
                                   const GeometricFitOptions& options = {}, const Sphere* initial = nullptr);

}  // namespace hedgefit::fitting
