#include "eval/compare.hpp"

#include "cloud/outline_io.hpp"

#include "cloud/describe.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <tuple>

#include "cloud/point_cloud.hpp"
#include "fitting/fit_fields.hpp"
#include "fitting/methods.hpp"
#include "fitting/uncertainty.hpp"
#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "pipeline/print.hpp"

namespace hedgefit::eval {

using fitting::Sphere;
using fitting::SphereFitResult;
using nlohmann::json;

namespace {

using pipeline::Print;

// printf into a stream: the table's columns are fixed-width.
std::string Num(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

// The JSON in `path`; Error "PATH: <cannot_open>" or "PATH: invalid JSON; <expected>".
json ReadJsonFile(const std::string& path, const std::string& cannot_open, const std::string& expected) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": " + cannot_open);
  json j;
  try {
    in >> j;
  } catch (const json::exception&) {
    throw Error(path + ": invalid JSON; " + expected);
  }
  return j;
}

json SphereJson(const Sphere& s) {
  return {{"center_mm", {s.center_mm.x(), s.center_mm.y(), s.center_mm.z()}}, {"radius_mm", s.radius_mm}};
}

json FitJson(const SphereFitResult& f, const std::optional<Sphere>& truth) {
  json j = {{"center_mm", nullptr}, {"radius_mm", nullptr}, {"rms_mm", nullptr}, {"std_error_mm", nullptr}};
  for (const auto& [key, value] : fitting::FitFields(f)) j[key] = std::visit([](const auto& v) { return json(v); }, value);
  if (truth && f.converged) {
    const FitError e = Evaluate(f.sphere, *truth);
    j["errors"] = {{"aer_mm", e.aer_mm}, {"rer_percent", e.rer_percent}, {"ld_mm", e.ld_mm}};
  } else {
    j["errors"] = nullptr;
  }
  return j;
}

json SummaryJson(const MethodSummary& s) {
  return {{"mean_abs_aer_mm", s.mean_abs_aer_mm}, {"max_abs_aer_mm", s.max_abs_aer_mm},
          {"mean_rer_percent", s.mean_rer_percent}, {"mean_ld_mm", s.mean_ld_mm},
          {"max_ld_mm", s.max_ld_mm}, {"rmse_radius_mm", s.rmse_radius_mm}};
}

// The cleaning after a reader of `file`, as one pipeline.
json CleaningPipeline(const CompareOptions& o, const json& reader) {
  json stages = json::array({reader});
  for (const auto& s : json::parse(o.cleaning_json)) stages.push_back(s);
  return stages;
}

void WriteTableRows(std::ostream& out, const CloudReport& r) {
  Print(out, "%s: %zu points, %zu after cleaning", r.file.c_str(), r.points, r.points_cleaned);
  if (r.truth) {
    Print(out, "; truth r %.2f mm at [%.2f, %.2f, %.2f]", r.truth->radius_mm, r.truth->center_mm.x(),
          r.truth->center_mm.y(), r.truth->center_mm.z());
  }
  Print(out, "\n  %-17s %10s %10s %10s %9s %7s %8s %8s %8s %7s", "method", "cx mm", "cy mm", "cz mm", "r mm", "rms",
        "inliers", "ms", "95%(c)", "95%(r)");
  if (r.truth) Print(out, " %8s %7s %8s", "AER mm", "RER %", "LD mm");
  out << "\n";
  for (const auto& f : r.fits) {
    if (!f.converged) {
      Print(out, "  %-17s failed: %s\n", f.method.c_str(), f.message.c_str());
      continue;
    }
    // The 95 % interval's half-width: the centre's largest axis, and the radius.
    const auto total = fitting::TotalStdError(f);
    const std::string se_c = total ? "+-" + Num(1.96 * total->head<3>().maxCoeff(), 2) : "-";
    const std::string se_r = total ? "+-" + Num(1.96 * (*total)[3], 2) : "-";
    Print(out, "  %-17s %10.2f %10.2f %10.2f %9.2f %7.2f %8zu %8.2f %8s %7s", f.method.c_str(), f.sphere.center_mm.x(),
          f.sphere.center_mm.y(), f.sphere.center_mm.z(), f.sphere.radius_mm, f.rms_mm, f.inliers, f.wall_ms,
          se_c.c_str(), se_r.c_str());
    if (r.truth) {
      const auto e = Evaluate(f.sphere, *r.truth);
      Print(out, " %8.2f %7.2f %8.2f", e.aer_mm, e.rer_percent, e.ld_mm);
    }
    out << "\n";
    if (f.not_a_ball) Print(out, "  %-17s ^ not a ball: %s\n", "", f.not_a_ball->c_str());
  }
  out << "\n";
}

}  // namespace

std::string ReadCleaningFile(const std::string& path) {
  json j = ReadJsonFile(path, "cannot open the cleaning pipeline; check the path",
                        "give an array of cleaning stages, e.g. [{\"type\": \"filters.voxel_grid\"}]");
  if (j.is_object() && j.contains("pipeline")) j = j["pipeline"];
  if (!j.is_array()) throw Error(path + ": a cleaning pipeline is a JSON array of filter stages");
  for (const auto& s : j) {
    const bool reader_or_writer =
        s.is_string() || (s.is_object() && s.contains("type") && s["type"].is_string() &&
                          (s["type"].get<std::string>().rfind("readers.", 0) == 0 ||
                           s["type"].get<std::string>().rfind("writers.", 0) == 0));
    if (reader_or_writer) throw Error(path + ": give filter stages only; compare reads each cloud itself");
  }
  return j.dump();
}

void CheckCleaning(const CompareOptions& options, const std::string& first_cloud) {
  pipeline::Pipeline::FromJson(CleaningPipeline(options, first_cloud).dump(), options.cleaning_source,
                               pipeline::Registry::Global());
}

std::vector<CloudReport> CompareCloud(const std::string& file, const CompareOptions& o) {
  pipeline::Pipeline p = pipeline::Pipeline::FromJson(
      CleaningPipeline(o, {{"filename", file}, {"scale", o.scale}}).dump(), "cleaning of " + file,
      pipeline::Registry::Global());
  pipeline::Context ctx;
  ctx.seed = o.seed;
  const pipeline::RunReport run_report = p.Run(ctx);
  const std::size_t points_read = std::size_t(std::max<std::int64_t>(0, run_report.stages.front().points_out));
  const cloud::PointCloud& cleaned = ctx.Get<cloud::PointCloud>("cloud");
  // Units: a cloud in metres is refused with the fix, unless --scale says what it is.
  if (o.scale == 1.0) {
    if (const std::string why = cloud::MetresReason(cloud::LargestExtent(cleaned), "read it with --scale 1000");
        !why.empty()) {
      throw InputError(file + ": " + why);
    }
  }
  std::vector<Sphere> truths = o.truth;
  if (truths.empty()) {
    if (auto t = TruthFileFor(file)) truths = ReadTruthFiles(*t);
  }
  // The outline `convert` wrote beside the cloud (cloud/outline_io.hpp), for the envelope, in mm:
  // only for a cloud read at its own scale.
  const std::optional<cloud::HedgeOutlines> outlines =
      o.scale == 1.0 ? cloud::ReadOutlineSidecar(file, points_read) : std::optional<cloud::HedgeOutlines>();
  // A capture with several hedges (hedge_id field): one report per hedge.
  const auto groups = cloud::HedgeGroups(cleaned);
  std::vector<CloudReport> reports;
  for (const auto& g : groups) {
    CloudReport rep;
    rep.file = g.id ? file + " hedge " + std::to_string(g.id) : file;
    rep.hedge_id = g.id;
    const std::vector<Eigen::Vector3d> pts = cloud::PointsAt(cleaned, g.indices);
    rep.points = groups.size() == 1 ? points_read : g.indices.size();
    rep.points_cleaned = pts.size();
    // A cloud shifted on reading (PointCloud::offset) is fitted in its own frame; truths and
    // reported fits are in the file's.
    std::vector<Eigen::Vector3d> in_file = pts;
    for (auto& q : in_file) q += cleaned.offset;
    rep.truth = TruthForPoints(truths, in_file);
    const std::vector<double> pixel_mm = cloud::FieldAt(cleaned, cloud::kPixelSizeField, g.indices);
    for (const auto& m : o.methods) {
      const std::vector<cloud::TangentRay>* outline = nullptr;
      if (outlines) {
        const auto it = outlines->find(g.id);
        if (it != outlines->end()) outline = &it->second;
      }
      rep.fits.push_back(fitting::RunFitMethod(m, pts, o.fit_options, o.seed, g.id >= 1, &pixel_mm, outline));
      rep.fits.back().hedge_id = g.id;
      fitting::AddUncertainty(pts, o.rig, &rep.fits.back(), o.matching);
      rep.fits.back().sphere.center_mm += cleaned.offset;
    }
    reports.push_back(std::move(rep));
  }
  if (reports.empty()) throw Error(file + ": no point belongs to a hedge (hedge_id >= 1)");
  return reports;
}

std::vector<const CloudReport*> Unfitted(const std::vector<CloudReport>& reports) {
  std::vector<const CloudReport*> out;
  for (const auto& r : reports) {
    const bool any = std::any_of(r.fits.begin(), r.fits.end(), [](const auto& f) { return f.converged; });
    if (!r.fits.empty() && !any) out.push_back(&r);
  }
  return out;
}

CompareSummary Summarise(const std::vector<CloudReport>& reports) {
  SummaryBuilder builder;
  CompareSummary s;
  for (const auto& r : reports) {
    if (!r.truth) continue;
    ++s.with_truth;
    for (const auto& f : r.fits) builder.Add(f.method, f, *r.truth);
  }
  s.per_method = builder.Finish();
  return s;
}

std::vector<ErrorSeries> ErrorSeriesByMethod(const std::vector<CloudReport>& reports,
                                             const std::vector<std::string>& methods, std::string* x_title) {
  // Against the true distance when the clouds' truths differ in Z, else by cloud.
  std::vector<double> zs;
  for (const auto& r : reports) {
    if (r.truth) zs.push_back(r.truth->center_mm.z());
  }
  std::sort(zs.begin(), zs.end());
  const bool by_distance = zs.size() >= 2 && std::unique(zs.begin(), zs.end()) - zs.begin() == long(zs.size());
  *x_title = by_distance ? "true distance Z (mm)" : "cloud";
  std::vector<ErrorSeries> series;
  for (const auto& m : methods) {
    ErrorSeries s;
    s.method = m;
    std::vector<std::tuple<double, double, double>> points;
    for (std::size_t i = 0; i < reports.size(); ++i) {
      const auto& r = reports[i];
      if (!r.truth) continue;
      for (const auto& f : r.fits) {
        if (f.method != m || !f.converged) continue;
        const auto e = Evaluate(f.sphere, *r.truth);
        points.emplace_back(by_distance ? r.truth->center_mm.z() : double(i + 1), std::abs(e.aer_mm), e.ld_mm);
      }
    }
    std::sort(points.begin(), points.end());
    for (const auto& [x, aer, ld] : points) {
      s.x.push_back(x);
      s.abs_aer_mm.push_back(aer);
      s.ld_mm.push_back(ld);
    }
    if (!s.x.empty()) series.push_back(s);
  }
  return series;
}

void WriteCompareJson(std::ostream& out, const std::vector<CloudReport>& reports,
                      const std::vector<std::string>& methods, const CompareSummary& summary) {
  json doc;
  doc["clouds"] = json::array();
  for (const auto& r : reports) {
    json c;
    c["file"] = r.file;
    if (r.hedge_id) c["hedge_id"] = r.hedge_id;
    c["points"] = r.points;
    c["points_cleaned"] = r.points_cleaned;
    c["truth"] = r.truth ? SphereJson(*r.truth) : json(nullptr);
    c["fits"] = json::array();
    for (const auto& f : r.fits) c["fits"].push_back(FitJson(f, r.truth));
    doc["clouds"].push_back(c);
  }
  doc["summary"] = json::object();
  for (const auto& m : methods) {
    auto it = summary.per_method.find(m);
    if (it == summary.per_method.end()) continue;
    json s = SummaryJson(it->second);
    s["clouds"] = it->second.clouds;
    s["failures"] = it->second.failures;
    doc["summary"][m] = s;
  }
  doc["paper"] = SummaryJson(PaperTable2());
  doc["paper"]["source"] = kPaperTable2Label;
  out << doc.dump(2) << "\n";
}

void WriteCompareCsv(std::ostream& out, const std::vector<CloudReport>& reports) {
  out << "cloud,method,converged,cx_mm,cy_mm,cz_mm,r_mm,rms_mm,inliers,points_used,iterations,wall_ms,"
         "se_cx_mm,se_cy_mm,se_cz_mm,se_r_mm,rig_se_cx_mm,rig_se_cy_mm,rig_se_cz_mm,rig_se_r_mm,ci95_cx_mm,ci95_cy_mm,"
         "ci95_cz_mm,ci95_r_mm,match_se_cx_mm,match_se_cy_mm,match_se_cz_mm,match_se_r_mm,true_r_mm,aer_mm,"
         "rer_percent,ld_mm,message\n";
  for (const auto& r : reports) {
    for (const auto& f : r.fits) {
      std::string msg = f.message;
      if (f.converged && f.not_a_ball) msg += (msg.empty() ? "" : "; ") + ("not a ball: " + *f.not_a_ball);
      std::replace(msg.begin(), msg.end(), '"', '\'');
      Print(out, "%s,%s,%d,", r.file.c_str(), f.method.c_str(), f.converged ? 1 : 0);
      if (f.converged) {
        Print(out, "%.4f,%.4f,%.4f,%.4f,%.4f,", f.sphere.center_mm.x(), f.sphere.center_mm.y(), f.sphere.center_mm.z(),
              f.sphere.radius_mm, f.rms_mm);
      } else {
        out << ",,,,,";
      }
      Print(out, "%zu,%zu,%d,%.3f,", f.inliers, f.points_used, f.iterations, f.wall_ms);
      const auto total = fitting::TotalStdError(f);
      for (const auto& v : {f.std_error_mm, f.rig_std_error_mm,
                            total ? std::optional<Eigen::Vector4d>(1.96 * *total) : std::nullopt,
                            f.matching_std_error_mm}) {
        if (v) {
          Print(out, "%.4f,%.4f,%.4f,%.4f,", (*v)[0], (*v)[1], (*v)[2], (*v)[3]);
        } else {
          out << ",,,,";
        }
      }
      if (r.truth && f.converged) {
        const auto e = Evaluate(f.sphere, *r.truth);
        Print(out, "%.4f,%.4f,%.4f,%.4f,", r.truth->radius_mm, e.aer_mm, e.rer_percent, e.ld_mm);
      } else {
        out << ",,,,";
      }
      out << "\"" << msg << "\"\n";
    }
  }
}

void WriteCompareTable(std::ostream& out, const std::vector<CloudReport>& reports,
                       const std::vector<std::string>& methods, const CompareSummary& summary) {
  for (const auto& r : reports) WriteTableRows(out, r);
  if (summary.with_truth == 0) return;
  Print(out, "summary over %zu clouds with truth\n  %-17s %11s %11s %10s %9s %9s %9s %6s\n", summary.with_truth,
        "method", "mean|AER|", "max|AER|", "mean RER%", "RMSE", "mean LD", "max LD", "fails");
  for (const auto& m : methods) {
    auto it = summary.per_method.find(m);
    if (it == summary.per_method.end()) continue;
    const auto& s = it->second;
    Print(out, "  %-17s %11.2f %11.2f %10.3f %9.2f %9.2f %9.2f %6zu\n", m.c_str(), s.mean_abs_aer_mm, s.max_abs_aer_mm,
          s.mean_rer_percent, s.rmse_radius_mm, s.mean_ld_mm, s.max_ld_mm, s.failures);
  }
  const MethodSummary p = PaperTable2();
  Print(out, "  %-17s %11.2f %11.2f %10.3f %9.2f %9.2f %9.2f %6s   (%s)\n", "paper", p.mean_abs_aer_mm,
        p.max_abs_aer_mm, p.mean_rer_percent, p.rmse_radius_mm, p.mean_ld_mm, p.max_ld_mm, "-", kPaperTable2Label);
  out << "  (mm; AER = measured - true radius, RER = |AER| / true radius, LD = centre distance)\n";
}

std::vector<FitRecord> ReadCompareFits(const std::string& path, const std::string& cloud_path) {
  const json j = ReadJsonFile(path, "cannot open the fits file; write one with `hedgefit compare CLOUD --format json > FILE`",
                              "expected the output of `hedgefit compare --format json`");
  if (!j.is_object() || !j.contains("clouds") || !j["clouds"].is_array() || j["clouds"].empty()) {
    throw Error(path + ": has no \"clouds\"; expected the output of `hedgefit compare --format json`");
  }
  const json* entry = &j["clouds"][0];
  for (const auto& c : j["clouds"]) {
    if (c.value("file", "") == cloud_path ||
        std::filesystem::path(c.value("file", "")).filename() == std::filesystem::path(cloud_path).filename()) {
      entry = &c;
      break;
    }
  }
  std::vector<FitRecord> out;
  try {
    const json fits = entry->value("fits", json::array());
    for (const auto& f : fits) {
      // A fit that says it did not converge has no sphere to draw; one that does not say is read.
      if (!f.value("converged", true)) continue;
      FitRecord o;
      o.label = f.at("method").get<std::string>();
      o.sphere.center_mm = Eigen::Vector3d(f.at("center_mm")[0], f.at("center_mm")[1], f.at("center_mm")[2]);
      o.sphere.radius_mm = f.at("radius_mm").get<double>();
      if (o.label == "shape" && f.contains("axes_mm") && f["axes_mm"].is_array() && f["axes_mm"].size() == 3) {
        o.axes_mm = Eigen::Vector3d(f["axes_mm"][0], f["axes_mm"][1], f["axes_mm"][2]);
        o.heading_deg = f.value("heading_deg", 0.0);
        if (f.contains("up") && f["up"].is_array() && f["up"].size() == 3) o.up = Eigen::Vector3d(f["up"][0], f["up"][1], f["up"][2]);
        const std::string message = f.value("message", std::string());
        if (message == "cylinder" || message == "cuboid" || message == "cone") o.form = message;
      }
      out.push_back(o);
    }
    if (entry->contains("truth") && !(*entry)["truth"].is_null()) {
      const auto& t = (*entry)["truth"];
      FitRecord o;
      o.label = "truth";
      o.truth = true;
      o.sphere.center_mm = Eigen::Vector3d(t.at("center_mm")[0], t.at("center_mm")[1], t.at("center_mm")[2]);
      o.sphere.radius_mm = t.at("radius_mm").get<double>();
      out.push_back(o);
    }
  } catch (const json::exception&) {
    throw Error(path + ": a fit lacks center_mm or radius_mm; expected the output of `hedgefit compare --format json`");
  }
  // Nothing to draw is not a picture of the fits: say so rather than draw the points alone.
  if (out.empty()) {
    throw Error(path + ": no converged fit and no truth for " + cloud_path + "; expected the output of `hedgefit compare "
                "--format json` for this cloud");
  }
  return out;
}

}  // namespace hedgefit::eval
