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
  if (f.converged && f.surface_radius_mm) out.emplace_back("surface_radius_mm", *f.surface_radius_mm);
  if (f.converged && f.leaf_depth_mm) out.emplace_back("leaf_depth_mm", *f.leaf_depth_mm);
  if (f.converged && f.top_bias_mm) out.emplace_back("top_bias_mm", *f.top_bias_mm);
  if (f.converged && f.axes_mm) {
    out.emplace_back("axes_mm", std::vector<double>{(*f.axes_mm)[0], (*f.axes_mm)[1], (*f.axes_mm)[2]});
  }
  if (f.converged && f.vertical_axis_mm) out.emplace_back("vertical_axis_mm", *f.vertical_axis_mm);
  if (f.converged && f.horizontal_axis_mm) out.emplace_back("horizontal_axis_mm", *f.horizontal_axis_mm);
  if (f.converged && f.not_a_ball) out.emplace_back("not_a_ball", *f.not_a_ball);
  return out;
}

}  // namespace hedgefit::fitting
