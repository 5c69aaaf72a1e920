#include "fitting/evaluation.hpp"
#include "fitting/uncertainty.hpp"

#include "cloud/truth_file.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cloud/error.hpp"

namespace hedgefit::fitting {

Sphere ReadTruthFile(const std::string& path) {
  const cloud::SphereTruth t = cloud::ReadSphereTruth(path);
  Sphere s;
  s.center_mm = t.center_mm;
  s.radius_mm = t.radius_mm;
  return s;
}

std::vector<Sphere> ReadTruthFiles(const std::string& path) {
  std::vector<Sphere> out;
  for (const cloud::SphereTruth& t : cloud::ReadSphereTruths(path)) {
    Sphere s;
    s.center_mm = t.center_mm;
    s.radius_mm = t.radius_mm;
    out.push_back(s);
  }
  return out;
}

std::optional<Sphere> TruthForPoints(const std::vector<Sphere>& truths, const std::vector<Eigen::Vector3d>& points) {
  if (truths.empty() || points.empty()) return std::nullopt;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= double(points.size());
  const Sphere* best = nullptr;
  double best_d = 0;
  for (const Sphere& t : truths) {
    const double d = (t.center_mm - centroid).norm();
    if (best == nullptr || d < best_d) best = &t, best_d = d;
  }
  if (best_d > best->radius_mm) return std::nullopt;
  return *best;
}

std::optional<std::string> TruthFileFor(const std::string& cloud_path) {
  std::filesystem::path p(cloud_path);
  p.replace_extension(".truth.json");
  std::error_code ec;
  if (std::filesystem::is_regular_file(p, ec)) return p.string();
  return std::nullopt;
}

FitError Evaluate(const Sphere& fit, const Sphere& truth) {
  FitError e;
  e.aer_mm = fit.radius_mm - truth.radius_mm;
  e.rer_percent = std::abs(e.aer_mm) / truth.radius_mm * 100.0;
  e.ld_mm = (fit.center_mm - truth.center_mm).norm();
  return e;
}

void SummaryBuilder::Add(const std::string& method, const SphereFitResult& fit, const Sphere& truth) {
  if (!fit.converged) {
    ++failures_[method];
    errors_[method];  // keep the method listed
    return;
  }
  errors_[method].push_back(Evaluate(fit.sphere, truth));
}

std::map<std::string, MethodSummary> SummaryBuilder::Finish() const {
  std::map<std::string, MethodSummary> out;
  for (const auto& [method, errors] : errors_) {
    MethodSummary s;
    s.clouds = errors.size();
    auto f = failures_.find(method);
    s.failures = f == failures_.end() ? 0 : f->second;
    double ss = 0;
    for (const auto& e : errors) {
      s.mean_abs_aer_mm += std::abs(e.aer_mm);
      s.max_abs_aer_mm = std::max(s.max_abs_aer_mm, std::abs(e.aer_mm));
      s.mean_rer_percent += e.rer_percent;
      s.mean_ld_mm += e.ld_mm;
      s.max_ld_mm = std::max(s.max_ld_mm, e.ld_mm);
      ss += e.aer_mm * e.aer_mm;
    }
    if (!errors.empty()) {
      const double n = double(errors.size());
      s.mean_abs_aer_mm /= n;
      s.mean_rer_percent /= n;
      s.mean_ld_mm /= n;
      s.rmse_radius_mm = std::sqrt(ss / n);
    }
    out[method] = s;
  }
  return out;
}

MethodSummary PaperTable2() {
  MethodSummary s;
  s.clouds = 7;
  s.mean_abs_aer_mm = 1.58;
  s.max_abs_aer_mm = 3.00;
  s.mean_rer_percent = 0.52;
  s.rmse_radius_mm = 1.59;
  s.mean_ld_mm = 15.92;
  s.max_ld_mm = 19.12;
  return s;
}

std::vector<std::pair<std::string, cloud::OptionValue>> FitFields(const SphereFitResult& f) {
  std::vector<std::pair<std::string, cloud::OptionValue>> out = {
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
