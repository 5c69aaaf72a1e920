#include "eval/evaluation.hpp"
#include "fitting/uncertainty.hpp"

#include "eval/truth_file.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "pipeline/error.hpp"

namespace hedgefit::eval {

Sphere ReadTruthFile(const std::string& path) {
  const eval::SphereTruth t = eval::ReadSphereTruth(path);
  Sphere s;
  s.center_mm = t.center_mm;
  s.radius_mm = t.radius_mm;
  return s;
}

std::vector<Sphere> ReadTruthFiles(const std::string& path) {
  std::vector<Sphere> out;
  for (const eval::SphereTruth& t : eval::ReadSphereTruths(path)) {
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

}  // namespace hedgefit::eval
