#include "fitting/fit_fields.hpp"

#include "fitting/uncertainty.hpp"

namespace hedgefit::fitting {

std::vector<std::pair<std::string, pipeline::OptionValue>> FitFields(const SphereFitResult& f) {
  std::vector<std::pair<std::string, pipeline::OptionValue>> out = {
      {"method", f.method},
      {"converged", f.converged},
      {"points_used", static_cast<std::int64_t>(f.points_used)},
      {"inliers", static_cast<std::int64_t>(f.inliers)},
      {"iterations", static_cast<std::int64_t>(f.iterations)},
      {"wall_ms", f.wall_ms},
      {"message", f.message}};
  if (f.hedge_id != 0) out.emplace_back("hedge_id", static_cast<std::int64_t>(f.hedge_id));
  if (f.converged) {
    out.emplace_back("center_mm", std::vector<double>{f.sphere.center_mm.x(), f.sphere.center_mm.y(), f.sphere.center_mm.z()});
    out.emplace_back("radius_mm", f.sphere.radius_mm);
    out.emplace_back("rms_mm", f.rms_mm);
  }
  if (f.std_error_mm) {
    const auto& e = *f.std_error_mm;
    out.emplace_back("std_error_mm", std::vector<double>{e[0], e[1], e[2], e[3]});
  }
  if (f.rig_std_error_mm) {
    const auto& e = *f.rig_std_error_mm;
    out.emplace_back("rig_std_error_mm", std::vector<double>{e[0], e[1], e[2], e[3]});
  }
  if (f.matching_std_error_mm) {
    const auto& e = *f.matching_std_error_mm;
    out.emplace_back("matching_std_error_mm", std::vector<double>{e[0], e[1], e[2], e[3]});
  }
  if (const auto t = TotalStdError(f); t && f.converged) {
    out.emplace_back("total_std_error_mm", std::vector<double>{(*t)[0], (*t)[1], (*t)[2], (*t)[3]});
    out.emplace_back("ci95_mm", std::vector<double>{1.96 * (*t)[0], 1.96 * (*t)[1], 1.96 * (*t)[2], 1.96 * (*t)[3]});
  }
  if (f.converged) {
    for (const auto& [name, values] : f.extras) {
      if (values.size() == 1) {
        out.emplace_back(name, values.front());
      } else {
        out.emplace_back(name, values);
      }
    }
  }
  if (f.converged && f.not_a_ball) out.emplace_back("not_a_ball", *f.not_a_ball);
  for (const auto& field : f.checks) out.push_back(field);
  if (f.unusable) out.emplace_back("unusable", *f.unusable);
  return out;
}

}  // namespace hedgefit::fitting
