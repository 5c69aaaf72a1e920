#include "stereo/calibration_report.hpp"

#include <glob.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "pipeline/error.hpp"
#include "pipeline/print.hpp"

namespace hedgefit::stereo {

namespace {

using pipeline::Print;

double StdDev(const CalibrationReport& r, const std::string& name) {
  return r.std_devs.empty() ? 0.0 : r.std_devs[std::size_t(RigParameterIndex(name))];
}

// The distortion model by evidence: the same corners with the terms the model adds dropped (k3,
// or k4..k6 for the rational model), and those terms' size against their standard deviations.
void CheckModel(const std::vector<PairCorners>& corners, cv::Size size, const CalibrationOptions& o,
                CalibrationReport* r) {
  if (o.model == DistortionModel::kK1K2P1P2) return;
  const bool rational = o.model == DistortionModel::kRational;
  CalibrationOptions simpler = o;
  simpler.model = rational ? DistortionModel::kK1K2P1P2K3 : DistortionModel::kK1K2P1P2;
  r->simpler = CalibrateFromCorners(corners, size, simpler);
  r->dropped_terms = rational ? "k4..k6" : "k3";
  const std::vector<std::string> terms = rational ? std::vector<std::string>{"k4", "k5", "k6"} : std::vector<std::string>{"k3"};
  const auto theta = RigParameters(r->rig);
  for (const char* camera : {"left.", "right."}) {
    for (const auto& term : terms) {
      const std::string name = camera + term;
      const double sd = StdDev(*r, name);
      if (sd > 0) r->dropped_in_std = std::max(r->dropped_in_std, std::abs(theta[RigParameterIndex(name)]) / sd);
    }
  }
}

// The principal point is what moves a hedge sideways: say when the poses leave it loose.
std::vector<std::string> Warnings(const CalibrationReport& r) {
  std::vector<std::string> warnings;
  // hedgefit reads the rig in mm: a baseline outside what a stereo rig for hedges can be is
  // --square given in another unit (metres: 0.03 for 30 mm gives a 0.14 "mm" baseline).
  if (!(r.rig.baseline_mm >= kMinPlausibleBaselineMm && r.rig.baseline_mm <= kMaxPlausibleBaselineMm)) {
    char buf[320];
    std::snprintf(buf, sizeof(buf),
                  "the baseline is %.4g in --square's unit, which a rig file holds as mm: a stereo rig for hedges is "
                  "%.0f-%.0f mm wide; give --square in mm (30 for a 30 mm square), or every depth will be off by "
                  "that factor",
                  r.rig.baseline_mm, kMinPlausibleBaselineMm, kMaxPlausibleBaselineMm);
    warnings.emplace_back(buf);
  }
  if (r.std_devs.empty()) return warnings;
  if (std::min(r.corner_coverage.first, r.corner_coverage.second) < kMinCornerCoverage) {
    warnings.emplace_back("the corners cover under 60 % of the image: show the board near the corners and edges, "
                          "where distortion is largest");
  }
  const char* axis_hint[2] = {"tilt the board about the vertical axis and show it near the left and right edges",
                              "tilt the board about the horizontal axis and show it near the top and bottom edges"};
  for (const char* camera : {"left", "right"}) {
    for (int k = 0; k < 2; ++k) {
      const double s_pp = StdDev(r, std::string(camera) + (k ? ".cy" : ".cx"));
      if (s_pp > kPrincipalPointWarnPx) {
        char buf[256];
        std::snprintf(buf, sizeof(buf), "%s camera's %s is loose (+-%.2f px > %.1f px): %s", camera, k ? "cy" : "cx",
                      s_pp, kPrincipalPointWarnPx, axis_hint[k]);
        warnings.emplace_back(buf);
      }
    }
  }
  return warnings;
}

std::vector<double> Values(const cv::Mat& m) {
  std::vector<double> v;
  for (int i = 0; i < static_cast<int>(m.total()); ++i) v.push_back(m.at<double>(i));
  return v;
}

void PrintCamera(std::ostream& out, const CalibrationReport& r, const char* name, const cv::Mat& K, const cv::Mat& D) {
  auto pm = [&](const char* p) { return StdDev(r, std::string(name) + "." + p); };
  Print(out, "  %-5s fx %.2f+-%.2f fy %.2f+-%.2f cx %.2f+-%.2f cy %.2f+-%.2f\n        dist", name, K.at<double>(0, 0),
        pm("fx"), K.at<double>(1, 1), pm("fy"), K.at<double>(0, 2), pm("cx"), K.at<double>(1, 2), pm("cy"));
  const char* terms[8] = {"k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
  for (int i = 0; i < std::min(8, static_cast<int>(D.total())); ++i) Print(out, " %.4f+-%.4f", D.at<double>(i), pm(terms[i]));
  out << "\n";
}

}  // namespace

std::vector<std::string> GlobFiles(const std::string& pattern, const std::string& option) {
  glob_t g{};
  std::vector<std::string> out;
  if (glob(pattern.c_str(), 0, nullptr, &g) == 0) {
    for (std::size_t i = 0; i < g.gl_pathc; ++i) out.emplace_back(g.gl_pathv[i]);
  }
  globfree(&g);
  if (out.empty()) throw Error(option + " '" + pattern + "': no file matches; check the pattern (quote it)");
  return out;  // glob() sorts
}

std::vector<std::pair<std::string, std::string>> PairsFromGlobs(const std::string& left, const std::string& right) {
  const auto l = GlobFiles(left, "--left"), r = GlobFiles(right, "--right");
  if (l.size() != r.size()) {
    throw Error("--left matches " + std::to_string(l.size()) + " files but --right matches " +
                std::to_string(r.size()) + "; pairs are matched by sorted order");
  }
  std::vector<std::pair<std::string, std::string>> pairs;
  for (std::size_t i = 0; i < l.size(); ++i) pairs.emplace_back(l[i], r[i]);
  return pairs;
}

std::vector<std::pair<std::string, std::string>> ReadPairList(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open the pair list");
  std::vector<std::pair<std::string, std::string>> pairs;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    std::istringstream ss(line);
    std::string l, r;
    if (!(ss >> l) || l[0] == '#') continue;
    if (!(ss >> r)) throw Error(path + ":" + std::to_string(n) + ": expected 'LEFT RIGHT'");
    pairs.emplace_back(l, r);
  }
  return pairs;
}

CalibrationReport CalibrateWithReport(const std::vector<std::pair<std::string, std::string>>& pairs,
                                      const CalibrationOptions& o, std::ostream* progress) {
  cv::Size size;
  const auto corners = DetectBoards(pairs, o.board, &size, progress);
  CalibrationReport r;
  r.rig = CalibrateFromCorners(corners, size, o);
  r.std_devs = RigStdDevs(r.rig);
  CheckModel(corners, size, o, &r);
  r.coverage_picture = CoveragePicture(corners, r.rig.pairs, size, &r.corner_coverage);
  cv::Mat rvec;
  cv::Rodrigues(r.rig.R, rvec);
  r.rotation_deg = cv::norm(rvec) * 180.0 / CV_PI;
  for (const auto& p : r.rig.pairs) r.pairs_used += p.used;
  r.warnings = Warnings(r);
  return r;
}

std::string CalibrationReportJson(const CalibrationReport& r, const std::string& rig_file) {
  const StereoRig& rig = r.rig;
  nlohmann::json j;
  j["rig_file"] = rig_file;
  j["image_size"] = {rig.image_size.width, rig.image_size.height};
  j["pairs_used"] = r.pairs_used;
  j["pairs_total"] = rig.pairs.size();
  j["rms_left_px"] = rig.rms_left_px;
  j["rms_right_px"] = rig.rms_right_px;
  j["rms_stereo_px"] = rig.rms_stereo_px;
  j["baseline"] = rig.baseline_mm;
  j["baseline_std"] = BaselineStdDev(rig);
  j["rotation_deg"] = r.rotation_deg;
  j["K1"] = Values(rig.K1);
  j["D1"] = Values(rig.D1);
  j["K2"] = Values(rig.K2);
  j["D2"] = Values(rig.D2);
  j["R"] = Values(rig.R);
  j["T"] = Values(rig.T);
  for (std::size_t k = 0; k < r.std_devs.size(); ++k) j["std"][RigParameterNames()[k]] = r.std_devs[k];
  if (r.simpler) {
    j["model_check"] = {{"without", r.dropped_terms},
                        {"rms_stereo_px_without", r.simpler->rms_stereo_px},
                        {"largest_dropped_term_in_std", r.dropped_in_std}};
  }
  j["warnings"] = r.warnings;
  j["corner_coverage"] = {r.corner_coverage.first, r.corner_coverage.second};
  for (const auto& p : rig.pairs) {
    j["pairs"].push_back({{"left", p.left}, {"right", p.right}, {"used", p.used}, {"status", p.status},
                          {"rms_left_px", p.rms_left_px}, {"rms_right_px", p.rms_right_px},
                          {"rms_stereo_px", p.rms_stereo_px}});
  }
  return j.dump(2);
}

void PrintCalibrationReport(std::ostream& out, const CalibrationReport& r, const std::string& coverage_file) {
  const StereoRig& rig = r.rig;
  Print(out, "calibrated from %d of %zu pairs (%dx%d images)\n", r.pairs_used, rig.pairs.size(), rig.image_size.width,
        rig.image_size.height);
  Print(out, "  RMS reprojection: left %.3f px, right %.3f px, stereo %.3f px\n", rig.rms_left_px, rig.rms_right_px,
        rig.rms_stereo_px);
  Print(out, "  baseline %.4f +- %.4f (units of --square), rotation between cameras %.3f deg\n", rig.baseline_mm,
        BaselineStdDev(rig), r.rotation_deg);
  PrintCamera(out, r, "left", rig.K1, rig.D1);
  PrintCamera(out, r, "right", rig.K2, rig.D2);
  Print(out, "  T [%.4f, %.4f, %.4f] +- [%.4f, %.4f, %.4f]\n", rig.T.at<double>(0), rig.T.at<double>(1),
        rig.T.at<double>(2), StdDev(r, "rig.tx"), StdDev(r, "rig.ty"), StdDev(r, "rig.tz"));
  out << "  (+- one standard deviation, from the calibration's Jacobian and its residuals)\n";
  if (r.simpler) {
    Print(out,
          "  model: without %s the stereo RMS is %.4f px (with: %.4f px); the largest %s is %.1f standard "
          "deviations from 0, %s\n",
          r.dropped_terms.c_str(), r.simpler->rms_stereo_px, rig.rms_stereo_px, r.dropped_terms.c_str(),
          r.dropped_in_std,
          r.dropped_in_std < 2 ? "so the data do not support it: consider the simpler --model" : "so the data support it");
  }
  Print(out, "  corners fell in %.0f %% (left) and %.0f %% (right) of an 8 x 8 grid over the image%s\n",
        100 * r.corner_coverage.first, 100 * r.corner_coverage.second,
        coverage_file.empty() ? " (--coverage FILE.png draws it)" : "");
  out << "pairs:\n";
  for (const auto& p : rig.pairs) {
    if (p.used || p.rms_stereo_px > 0) {
      Print(out, "  %-40s %-40s L %.3f R %.3f px  %s\n", p.left.c_str(), p.right.c_str(), p.rms_left_px,
            p.rms_right_px, p.status.c_str());
    } else {
      Print(out, "  %-40s %-40s %s\n", p.left.c_str(), p.right.c_str(), p.status.c_str());
    }
  }
  for (const auto& w : r.warnings) out << "warning: " << w << "\n";
}

}  // namespace hedgefit::stereo
