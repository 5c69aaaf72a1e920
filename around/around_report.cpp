#include "around/around_report.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>

#include "around/poses.hpp"

namespace hedgefit::around {

namespace {

using json = nlohmann::ordered_json;

// To `unit` (a power of ten), printed without a binary tail (round(v * 1000) / 1000 is the double
// nearest the decimal; round(v / 0.001) * 0.001 is not), and without a negative zero.
double Round(double v, double unit) {
  if (!std::isfinite(v)) return v;
  const double scale = std::round(1 / unit);
  return std::round(v * scale) / scale + 0.0;
}

json Vec(const Eigen::VectorXd& v, double unit) {
  json a = json::array();
  for (Eigen::Index k = 0; k < v.size(); ++k) a.push_back(std::isfinite(v[k]) ? json(Round(v[k], unit)) : json(nullptr));
  return a;
}

}  // namespace

std::vector<std::string> FuseJsonLines(const FuseResult& r, bool pretty) {
  std::vector<json> lines;
  for (const FusedHedge& h : r.hedges) {
    json names = json::array(), coverage = json::object(), centres = json::object();
    for (std::size_t k = 0; k < h.views.size(); ++k) {
      const std::string& name = r.poses[std::size_t(h.views[k])].name;
      names.push_back(name);
      coverage[name] = Round(h.view_coverage[k], 0.001);
      centres[name] = Vec(h.view_centres_mm[k], 0.01);
    }
    const fitting::SphereFitResult& f = h.fit.fit;
    lines.push_back({{"hedge", h.id},
                     {"method", "envelope"},
                     {"captures", names},
                     {"center_mm", Vec(f.sphere.center_mm, 0.001)},
                     {"radius_mm", Round(f.sphere.radius_mm, 0.001)},
                     {"std_error_mm", Vec(h.std_error_mm, 0.001)},
                     {"likelihood_std_error_mm", Vec(h.likelihood_se_mm, 0.001)},
                     {"jackknife_std_error_mm", Vec(h.jackknife_se_mm, 0.001)},
                     {"registration_std_error_mm", Vec(h.registration_se_mm, 0.001)},
                     {"surface_radius_mm", Round(h.fit.surface_radius_mm, 0.001)},
                     {"leaf_depth_mm", Round(h.fit.leaf_depth_mm, 0.001)},
                     {"clipped_share", Round(h.fit.clipped_share, 0.001)},
                     {"coverage", Round(h.coverage, 0.001)},
                     {"coverage_per_capture", coverage},
                     {"capture_centers_mm", centres},
                     {"points", h.points},
                     {"outline_rays", h.fit.outline_rays}});
    // Not a hedge to act on: said in the line itself, so no reader takes it for one.
    if (!h.unconfirmed.empty()) lines.back()["unconfirmed"] = h.unconfirmed;
  }
  for (const PoseResult& p : r.poses) {
    json j = {{"capture", p.name}, {"used", p.used}};
    if (!p.used) j["left_out"] = p.left_out;
    const Eigen::Isometry3d delta = p.refined * p.given.inverse();
    j["correction_mm"] = Round(p.correction_mm, 0.01);
    j["correction_deg"] = Round(p.correction_deg, 0.001);
    j["correction_translation_mm"] = Vec(p.refined.translation() - p.given.translation(), 0.01);
    j["correction_rotation_deg"] = Vec(Eigen::AngleAxisd(delta.linear()).axis() * RotationDeg(delta), 0.001);
    j["determined_dof"] = p.determined_dof;
    j["sigma_mm"] = Round(p.sigma_mm, 0.01);
    j["sigma_deg"] = Round(p.sigma_deg, 0.001);
    j["centre_residual_mm"] = Round(p.centre_residual_mm, 0.01);
    if (p.gicp_rms_mm > 0) j["gicp_rms_mm"] = Round(p.gicp_rms_mm, 0.01);
    json m = json::array();
    const Eigen::Matrix4d M = p.refined.matrix();
    for (int k = 0; k < 16; ++k) m.push_back(Round(M(k / 4, k % 4), k % 4 == 3 ? 0.001 : 1e-9));
    j["world_from_camera"] = m;
    lines.push_back(j);
  }
  std::vector<std::string> out;
  for (const json& j : lines) out.push_back(pretty ? j.dump(2) : j.dump());
  return out;
}

void PrintFuseTable(std::ostream& out, const FuseResult& r) {
  char line[512];
  std::snprintf(line, sizeof(line), "%-5s %-30s %10s %8s %10s %9s %9s %6s\n", "hedge", "centre (x, y, z) mm", "radius mm",
                "+- mm", "surface mm", "captures", "covered", "points");
  out << line;
  for (const FusedHedge& h : r.hedges) {
    if (!h.unconfirmed.empty()) continue;
    const auto& c = h.fit.fit.sphere.center_mm;
    char centre[96];
    std::snprintf(centre, sizeof(centre), "(%.1f, %.1f, %.1f)", c.x(), c.y(), c.z());
    std::snprintf(line, sizeof(line), "%-5d %-30s %10.2f %8.2f %10.2f %9zu %8.1f%% %6zu\n", h.id, centre,
                  h.fit.fit.sphere.radius_mm, 1.96 * h.std_error_mm[3], h.fit.surface_radius_mm, h.views.size(),
                  100 * h.coverage, h.points);
    out << line;
  }
  for (const FusedHedge& h : r.hedges) {
    if (h.unconfirmed.empty()) continue;
    const auto& c = h.fit.fit.sphere.center_mm;
    std::snprintf(line, sizeof(line), "unconfirmed %d near (%.0f, %.0f, %.0f), r %.0f mm: %s\n", h.id, c.x(), c.y(), c.z(),
                  h.fit.fit.sphere.radius_mm, h.unconfirmed.c_str());
    out << line;
  }
  out << "\n";
  std::snprintf(line, sizeof(line), "%-12s %-5s %12s %12s %8s %10s %10s  %s\n", "capture", "used", "moved mm", "turned deg",
                "pinned", "+- mm", "+- deg", "");
  out << line;
  for (const PoseResult& p : r.poses) {
    std::snprintf(line, sizeof(line), "%-12s %-5s %12.2f %12.3f %6d/6 %10.2f %10.3f  %s\n", p.name.c_str(), p.used ? "yes" : "no",
                  p.correction_mm, p.correction_deg, p.determined_dof, p.sigma_mm, p.sigma_deg, p.left_out.c_str());
    out << line;
  }
}

}  // namespace hedgefit::around
