#pragma once
/// Closed-form algebraic sphere fits. All centre (and scale) the data and accumulate
/// in double, so a sphere 2.3 m or 10 m from the origin fits as precisely as one at it.
///  - Kasa: the paper's least squares on |p - c|^2 - r^2 (METHOD.md step 6). Biased
///    towards small radii on partial caps.
///  - Pratt (1987), Taubin (1991), Hyper (Al-Sharadqah & Chernov 2009): minimise the same
///    algebraic distance under a normalising constraint, as a generalised eigenproblem;
///    Hyper has no essential bias to second order, Pratt and Taubin far less than Kasa.

#include <vector>

#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

enum class AlgebraicMethod { kKasa, kPratt, kTaubin, kHyper };

/// "kasa", "pratt", "taubin", "hyper".
const char* MethodName(AlgebraicMethod method);

struct AlgebraicFitOptions {
  AlgebraicMethod method = AlgebraicMethod::kHyper;  ///< which constraint
};

/// Fits a sphere in closed form. Degenerate input gives converged = false and a message.
SphereFitResult FitSphereAlgebraic(const std::vector<Eigen::Vector3d>& points_mm,
                                   const AlgebraicFitOptions& options = {});

}  // namespace hedgefit::fitting
