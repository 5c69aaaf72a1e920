#include "bench/rig_drift.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <unistd.h>

#include "eval/truth_file.hpp"
#include "fitting/methods.hpp"
#include "fitting/uncertainty.hpp"
#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "stereo/capture.hpp"
#include "measure/recipes.hpp"
#include "measure/modules.hpp"

namespace hedgefit::bench {

namespace {

namespace fs = std::filesystem;

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.rfind(from);
  if (at == std::string::npos) throw Error(s + ": expected a NAME" + from + " file");
  return s.replace(at, from.size(), to);
}

const pipeline::OptionValue* Check(const fitting::SphereFitResult& f, const std::string& key) {
  for (const auto& [k, v] : f.checks) {
    if (k == key) return &v;
  }
  return nullptr;
}

// One capture under one drift: a row per true hedge (refused: one row for the capture).
void MeasureOne(const std::string& left, const std::string& rig_path, const std::string& stage,
                const sim::RigDrift& drift, double rows_apart, std::vector<DriftRow>* out) {
  const std::string right = Replace(left, "_left.", "_right.");
  const std::vector<eval::SphereTruth> truths = eval::ReadSphereTruths(Replace(left, "_left.png", ".truth.json"));
  const std::string json =
      measure::MeasurePipelineJson(stereo::ConvertOptions(), {stage}, true, left, right, rig_path, "");
  pipeline::Pipeline p = pipeline::Pipeline::FromJson(json, "rig drift", pipeline::Registry::Global());
  pipeline::Context ctx;
  ctx.quiet = true;
  DriftRow base;
  base.capture = fs::path(left).filename().string();
  base.drift = drift.name;
  base.judgeable = drift.judgeable;
  base.rows_px = rows_apart;
  try {
    p.Run(ctx);
  } catch (const Error& e) {
    base.verdict = "refused";
    base.message = e.what();
    base.said = true;
    out->push_back(base);
    return;
  }
  static const std::vector<fitting::SphereFitResult> none;
  const auto* found = ctx.Find<std::vector<fitting::SphereFitResult>>("fits");
  const std::vector<fitting::SphereFitResult>& fits = found ? *found : none;
  for (const eval::SphereTruth& t : truths) {
    DriftRow r = base;
    const fitting::SphereFitResult* best = nullptr;
    double best_d = 1e18;
    for (const auto& f : fits) {
      if (!f.converged) continue;
      const double d = (f.sphere.center_mm - t.center_mm).norm();
      if (d < best_d) best_d = d, best = &f;
    }
    // A drifted rig can put a hedge a radius off (the nominal rig: 300 mm): matched within two.
    if (!best || best_d > 2 * t.radius_mm) {
      r.verdict = "not found";
      r.said = true;
      out->push_back(r);
      continue;
    }
    r.hedge = best->hedge_id;
    const Eigen::Vector3d dc = best->sphere.center_mm - t.center_mm;
    r.centre_error_mm = dc.norm();
    r.radius_error_mm = best->sphere.radius_mm - t.radius_mm;
    const auto se = fitting::TotalStdError(*best);
    if (se) {
      // The interval along the error's direction: the per-axis half-widths weighted by it.
      const Eigen::Vector3d ci = 1.96 * se->head<3>();
      const Eigen::Vector3d u = r.centre_error_mm > 0 ? Eigen::Vector3d(dc / r.centre_error_mm) : Eigen::Vector3d(0, 0, 1);
      r.ci_centre_mm = std::sqrt((ci.array() * u.array()).square().sum());
      r.ci_radius_mm = 1.96 * (*se)[3];
    }
    r.inside = r.centre_error_mm <= r.ci_centre_mm && std::abs(r.radius_error_mm) <= r.ci_radius_mm;
    if (const auto* v = Check(*best, "rig_check")) r.verdict = std::get<std::string>(*v);
    if (const auto* v = Check(*best, "rig_rows_px")) r.check_rows_px = std::get<double>(*v);
    if (best->unusable) r.message = *best->unusable, r.verdict = "unusable";
    r.said = r.verdict == "widened" || r.verdict == "unusable";
    out->push_back(r);
  }
}

}  // namespace

std::vector<DriftRow> RunRigDrift(const DriftOptions& o) {
  pipeline::Registry& registry = pipeline::Registry::Global();
  measure::AddStageModules(registry);
  const std::string stage = fitting::FindFitMethod(o.method, "--method").stage;
  const stereo::StereoRig rig = stereo::ReadRig(o.rig);
  const std::string tmp = (fs::temp_directory_path() / ("hedgefit_drift_" + std::to_string(getpid()) + ".yaml")).string();
  std::vector<DriftRow> rows;
  for (const sim::RigDrift& d : o.drifts) {
    const stereo::StereoRig drifted = sim::DriftRig(rig, d);
    const double apart = sim::RowsApart(rig, drifted);
    stereo::WriteRig(tmp, drifted);
    for (const std::string& left : o.lefts) MeasureOne(left, tmp, stage, d, apart, &rows);
  }
  fs::remove(tmp);
  return rows;
}

void PrintRigDrift(const std::vector<DriftRow>& rows) {
  std::printf("%-26s %-24s %5s %6s %6s %9s %9s %9s %9s  %-10s %s\n", "capture", "drift", "hedge", "rows", "check",
              "centre mm", "95% c", "radius mm", "95% r", "verdict", "inside");
  int judged = 0, silent = 0, calibrated_said = 0, calibrated = 0, unjudgeable = 0, unjudgeable_outside = 0;
  int fit_bias = 0;
  // A hedge the calibrated rig already measures outside its interval (a fit's own bias, not the
  // rig's) is no drift's miss.
  std::map<std::pair<std::string, int>, bool> calibrated_inside;
  for (const DriftRow& r : rows) {
    if (r.drift == "calibrated") calibrated_inside[{r.capture, r.hedge}] = r.inside;
  }
  for (const DriftRow& r : rows) {
    if (r.verdict == "refused" || r.verdict == "not found") {
      std::printf("%-26s %-24s %5s %6.2f %6s %9s %9s %9s %9s  %-10s %s\n", r.capture.c_str(), r.drift.c_str(), "-",
                  r.rows_px, "-", "-", "-", "-", "-", r.verdict.c_str(), r.message.substr(0, 50).c_str());
    } else {
      std::printf("%-26s %-24s %5d %6.2f %6.2f %9.2f %9.2f %+9.2f %9.2f  %-10s %s\n", r.capture.c_str(),
                  r.drift.c_str(), r.hedge, r.rows_px, r.check_rows_px, r.centre_error_mm, r.ci_centre_mm,
                  r.radius_error_mm, r.ci_radius_mm, r.verdict.c_str(), r.inside ? "yes" : (r.said ? "no, said" : r.judgeable ? "NO: SILENT" : "no (unjudgeable)"));
    }
    if (r.drift == "calibrated") {
      ++calibrated;
      calibrated_said += r.said;
      continue;
    }
    if (!r.judgeable || (r.rows_px <= 0.5 && r.verdict != "refused")) {
      ++unjudgeable;
      unjudgeable_outside += !r.inside && !r.said;
      continue;
    }
    ++judged;
    if (!r.inside && !r.said) {
      const auto c = calibrated_inside.find({r.capture, r.hedge});
      if (c != calibrated_inside.end() && !c->second) ++fit_bias;
      else ++silent;
    }
  }
  std::printf("\n%d judged results (rows more than 0.5 px apart, or refused): %d silent misses (and %d outside their "
              "interval unsaid on a hedge the calibrated rig already misses: the fit's own bias); the calibrated rig: "
              "%d of %d results warned or refused; %d not judgeable by one pair (yaw, horizontal principal point, "
              "baseline length, or rows within 0.5 px), %d of them outside their interval unsaid\n",
              judged, silent, fit_bias, calibrated_said, calibrated, unjudgeable, unjudgeable_outside);
}

}  // namespace hedgefit::bench
