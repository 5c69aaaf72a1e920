#pragma once
/// log(erfc(z)) where erfc underflows: the leaf layer's likelihood (envelope_fit.cpp,
/// shape_fit.cpp) takes it of arguments up to hundreds.

#include <cmath>

namespace hedgefit::fitting {

/// log(erfc(z)) and its derivative; for z > 5 the asymptotic series (erfc(5) = 1.5e-12).
inline double LogErfc(double z, double* derivative = nullptr) {
  if (z > 5) {
    const double z2 = z * z, a = 1 - 0.5 / z2 + 0.75 / (z2 * z2), da = 1 / (z2 * z) - 3 / (z2 * z2 * z);
    if (derivative != nullptr) *derivative = -2 * z - 1 / z + da / a;
    return -z2 - std::log(z * std::sqrt(M_PI)) + std::log(a);
  }
  const double e = std::erfc(z);
  if (derivative != nullptr) *derivative = -2 / std::sqrt(M_PI) * std::exp(-z * z) / e;
  return std::log(e);
}

}  // namespace hedgefit::fitting
