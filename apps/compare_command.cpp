// hedgefit compare CLOUD...: clean each cloud, run every fitter, and print one row per
// method; with ground truth, the paper's AER / RER / LD columns and a summary per method.

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "apps/capture_flags.hpp"
#include "apps/commands.hpp"
#include "apps/stage_flags.hpp"
#include "cloud/cloud_io.hpp"
#include "cloud/pipeline.hpp"
#include "fitting/evaluation.hpp"
#include "fitting/methods.hpp"
#include "fitting/uncertainty.hpp"
#include "stereo/rig.hpp"
#include "stereo/rig_uncertainty.hpp"
#include "render/plot.hpp"

namespace hedgefit::apps {

namespace {

using fitting::Sphere;
using fitting::SphereFitResult;
using nlohmann::json;


struct CompareArgs {
  std::vector<std::string> clouds;
  std::string truth;
  std::string pipeline;
  std::string methods = "all";
  std::string format = "table";
  double scale = 1.0;
  std::uint64_t seed = 42;
  StageFlags fit_flags;  // the robust methods' options, from the method table
  std::string plot;
  std::string rig;
};

struct CloudReport {
  std::string file;  ///< with " hedge N" for one hedge of a capture
  int hedge_id = 0;
  std::size_t points = 0;
  std::size_t points_cleaned = 0;
  std::optional<Sphere> truth;
  std::vector<SphereFitResult> fits;
};

// The cleaning stages as JSON: the user's pipeline file, or cloud::DefaultCleaningJson().
json CleaningStages(const CompareArgs& a) {
  if (a.pipeline.empty()) {
    return DefaultCleaning();
  }
  std::ifstream in(a.pipeline);
  if (!in) throw Error(a.pipeline + ": cannot open the cleaning pipeline; check the path");
  json j;
  try {
    in >> j;
  } catch (const json::exception&) {
    throw Error(a.pipeline + ": invalid JSON; give an array of cleaning stages, e.g. [{\"type\": \"filters.voxel_grid\"}]");
  }
  if (j.is_object() && j.contains("pipeline")) j = j["pipeline"];
  if (!j.is_array()) throw Error(a.pipeline + ": a cleaning pipeline is a JSON array of filter stages");
  for (const auto& s : j) {
    const bool reader_or_writer =
        s.is_string() || (s.is_object() && s.contains("type") && s["type"].is_string() &&
                          (s["type"].get<std::string>().rfind("readers.", 0) == 0 ||
                           s["type"].get<std::string>().rfind("writers.", 0) == 0));
    if (reader_or_writer) {
      throw Error(a.pipeline + ": give filter stages only; compare reads each cloud itself");
    }
  }
  return j;
}

json FitJson(const SphereFitResult& f, const std::optional<Sphere>& truth) {
  json j = {{"center_mm", nullptr}, {"radius_mm", nullptr}, {"rms_mm", nullptr}, {"std_error_mm", nullptr}};
  for (const auto& [key, value] : fitting::FitFields(f)) j[key] = std::visit([](const auto& v) { return json(v); }, value);
  if (truth && f.converged) {
    const fitting::FitError e = fitting::Evaluate(f.sphere, *truth);
    j["errors"] = {{"aer_mm", e.aer_mm}, {"rer_percent", e.rer_percent}, {"ld_mm", e.ld_mm}};
  } else {
    j["errors"] = nullptr;
  }
  return j;
}

std::string Num(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

}  // namespace

void AddCompareCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("compare", "Clean clouds, fit spheres with every method, compare (with truth: AER, RER, LD)");
  cmd->footer(
      "Examples:\n"
      "  hedgefit compare sample_clouds/*.pcd\n"
      "  hedgefit compare scan.pcd --truth scan.truth.json --methods hyper,ransac_geometric --format json\n"
      "  hedgefit compare ../shared/data/sphere_scans/example2/L1_S1.xyz --scale 1000 --min-radius 250 --max-radius 350\n"
      "  hedgefit compare build/garden/row_*.pcd --truth build/garden/garden_row.truth.json --methods ransac,envelope\n"
      "Truth: --truth FILE, or CLOUD.truth.json beside each cloud: {\"center_mm\": [x, y, z], \"radius_mm\": r}, or\n"
      "{\"hedges\": [...]} for several; each hedge (a cloud's hedge_id field) is matched to the nearest one.\n"
      "A fit whose sphere is far wider than its points, or with over 5 % of them a tenth of its radius outside it,\n"
      "is marked not a ball (not_a_ball in JSON, a '^ not a ball' line in the table): a shrub, lawn, or two lobes.\n");
  auto a = std::make_shared<CompareArgs>();
  cmd->add_option("CLOUD", a->clouds, "cloud files (" + cloud::CloudExtensionList() + ")")->required();
  cmd->add_option("--truth", a->truth, "ground-truth JSON for every cloud (default: CLOUD.truth.json if present)");
  cmd->add_option("--pipeline", a->pipeline, "JSON array of cleaning stages replacing the default (nonfinite + hedge_outlier)");
  std::string method_list;
  for (const auto& m : fitting::FitMethodNames()) method_list += m + ",";
  cmd->add_option("--methods", a->methods,
                  "comma-separated: " + method_list + " or all (every sphere fit; all,ellipsoid adds the ellipsoid)")
      ->capture_default_str();
  cmd->add_option("--format", a->format, "table, json or csv")->check(CLI::IsMember({"table", "json", "csv"}))->capture_default_str();
  cmd->add_option("--scale", a->scale, "multiply coordinates on read (1000 for metre files)")->capture_default_str();
  // RANSAC's options, as declared in its table; each applies to every method that has it.
  std::vector<cloud::OptionSpec> robust;
  for (const auto& spec : fitting::FindFitMethod("ransac", "compare").options) {
    if (spec.name != "seed") robust.push_back(spec);
  }
  a->fit_flags.Add(cmd, robust);
  cmd->add_option("--seed", a->seed, "RANSAC sampler seed")->capture_default_str();
  cmd->add_option("--rig", a->rig,
                  "the rig the clouds were measured with (hedgefit calibrate's YAML): each fit's uncertainty then "
                  "includes the rig's calibration");
  cmd->add_option("--plot", a->plot, "also draw |AER| and LD per method (against distance when several clouds have truth) to this PNG");
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      if (!a->plot.empty()) CheckImageOutput("--plot", a->plot, {".png"}, a->clouds);
      const std::vector<std::string> methods = fitting::ParseMethodList(a->methods, "--methods");
      const auto fit_options = a->fit_flags.Given();
      const json cleaning = CleaningStages(*a);
      std::vector<Sphere> common_truth;
      if (!a->truth.empty()) common_truth = fitting::ReadTruthFiles(a->truth);
      cloud::PointPerturbation rig_perturbation, matching_perturbation;
      if (!a->rig.empty()) {
        const stereo::StereoRig rig = stereo::ReadRig(a->rig);
        if (rig.covariance.empty()) {
          throw Error("--rig " + a->rig + ": the rig carries no calibration covariance; recalibrate it with `hedgefit calibrate`");
        }
        rig_perturbation = stereo::RigPerturbation(rig);
        matching_perturbation = stereo::DisparityOffsetPerturbation(rig);
      }
      // Validate the cleaning pipeline once, before any cloud is read.
      {
        json probe = json::array({a->clouds.front()});
        for (const auto& s : cleaning) probe.push_back(s);
        cloud::Pipeline::FromJson(probe.dump(), a->pipeline.empty() ? "default cleaning" : a->pipeline,
                                  cloud::Registry::Global());
      }
      std::vector<CloudReport> reports;
      int failed = 0;
      for (const std::string& file : a->clouds) {
        try {
          json stages = json::array();
          stages.push_back({{"filename", file}, {"scale", a->scale}});
          for (const auto& s : cleaning) stages.push_back(s);
          cloud::Pipeline p = cloud::Pipeline::FromJson(stages.dump(), "cleaning of " + file, cloud::Registry::Global());
          cloud::Context ctx;
          ctx.seed = a->seed;
          const cloud::RunReport run_report = p.Run(ctx);
          const std::size_t points_read = std::size_t(std::max<std::int64_t>(0, run_report.stages.front().points_out));
          const cloud::PointCloud& cleaned = ctx.Get<cloud::PointCloud>("cloud");
          std::vector<Sphere> truths = common_truth;
          if (truths.empty()) {
            if (auto t = fitting::TruthFileFor(file)) truths = fitting::ReadTruthFiles(*t);
          }
          // A capture with several hedges (hedge_id field): one report per hedge.
          const auto groups = cloud::HedgeGroups(cleaned);
          std::vector<CloudReport> mine;
          for (const auto& g : groups) {
            CloudReport rep;
            rep.file = g.id ? file + " hedge " + std::to_string(g.id) : file;
            rep.hedge_id = g.id;
            std::vector<Eigen::Vector3d> pts;
            for (std::size_t i : g.indices) pts.push_back(cleaned.points_mm[i].cast<double>());
            rep.points = groups.size() == 1 ? points_read : g.indices.size();
            rep.points_cleaned = pts.size();
            rep.truth = fitting::TruthForPoints(truths, pts);
            const std::vector<double> pixel_mm = cloud::FieldAt(cleaned, cloud::kPixelSizeField, g.indices);
            for (const auto& m : methods) {
              rep.fits.push_back(fitting::RunFitMethod(m, pts, fit_options, a->seed, g.id >= 1, &pixel_mm));
              rep.fits.back().hedge_id = g.id;
              fitting::AddUncertainty(pts, a->rig.empty() ? nullptr : &rig_perturbation, &rep.fits.back(),
                                      a->rig.empty() ? nullptr : &matching_perturbation);
            }
            mine.push_back(std::move(rep));
          }
          if (mine.empty()) throw Error(file + ": no point belongs to a hedge (hedge_id >= 1)");
          for (auto& r : mine) reports.push_back(std::move(r));
        } catch (const Error& e) {
          std::cerr << "hedgefit: " << e.what() << "; skipped\n";
          ++failed;
        }
      }

      // A cloud (or hedge) that no method could fit is a failure of the run, not only a table
      // row: a script must not read "every fit failed" as success.
      int unfitted = 0;
      for (const auto& r : reports) {
        if (r.fits.empty() || std::any_of(r.fits.begin(), r.fits.end(), [](const auto& f) { return f.converged; })) {
          continue;
        }
        std::cerr << "hedgefit: " << r.file << ": no method fitted a sphere (" << r.fits.front().message
                  << "); give the points of one hedge's surface\n";
        ++unfitted;
      }

      fitting::SummaryBuilder summary;
      std::size_t with_truth = 0;
      for (const auto& r : reports) {
        if (!r.truth) continue;
        ++with_truth;
        for (const auto& f : r.fits) summary.Add(f.method, f, *r.truth);
      }
      const auto stats = summary.Finish();

      if (!a->plot.empty()) {
        // Against the true distance when the clouds' truths differ in Z, else by cloud.
        std::vector<double> zs;
        for (const auto& r : reports) {
          if (r.truth) zs.push_back(r.truth->center_mm.z());
        }
        std::sort(zs.begin(), zs.end());
        const bool by_distance = zs.size() >= 2 && std::unique(zs.begin(), zs.end()) - zs.begin() == long(zs.size());
        std::vector<render::ErrorSeries> series;
        for (const auto& m : methods) {
          render::ErrorSeries s;
          s.method = m;
          std::vector<std::tuple<double, double, double>> points;
          for (std::size_t i = 0; i < reports.size(); ++i) {
            const auto& r = reports[i];
            if (!r.truth) continue;
            for (const auto& f : r.fits) {
              if (f.method != m || !f.converged) continue;
              const auto e = fitting::Evaluate(f.sphere, *r.truth);
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
        render::PlotErrors(series, by_distance ? "true distance Z (mm)" : "cloud", 1200, 500, a->plot);
      }
      if (a->format == "json") {
        json out;
        out["clouds"] = json::array();
        for (const auto& r : reports) {
          json c;
          c["file"] = r.file;
          if (r.hedge_id) c["hedge_id"] = r.hedge_id;
          c["points"] = r.points;
          c["points_cleaned"] = r.points_cleaned;
          c["truth"] = r.truth ? json{{"center_mm", {r.truth->center_mm.x(), r.truth->center_mm.y(), r.truth->center_mm.z()}},
                                      {"radius_mm", r.truth->radius_mm}}
                               : json(nullptr);
          c["fits"] = json::array();
          for (const auto& f : r.fits) c["fits"].push_back(FitJson(f, r.truth));
          out["clouds"].push_back(c);
        }
        out["summary"] = json::object();
        for (const auto& m : methods) {
          auto it = stats.find(m);
          if (it == stats.end()) continue;
          const auto& s = it->second;
          out["summary"][m] = {{"clouds", s.clouds}, {"failures", s.failures}, {"mean_abs_aer_mm", s.mean_abs_aer_mm},
                               {"max_abs_aer_mm", s.max_abs_aer_mm}, {"mean_rer_percent", s.mean_rer_percent},
                               {"mean_ld_mm", s.mean_ld_mm}, {"max_ld_mm", s.max_ld_mm},
                               {"rmse_radius_mm", s.rmse_radius_mm}};
        }
        const fitting::MethodSummary paper = fitting::PaperTable2();
        out["paper"] = {{"mean_abs_aer_mm", paper.mean_abs_aer_mm}, {"max_abs_aer_mm", paper.max_abs_aer_mm},
                        {"mean_rer_percent", paper.mean_rer_percent}, {"mean_ld_mm", paper.mean_ld_mm},
                        {"max_ld_mm", paper.max_ld_mm}, {"rmse_radius_mm", paper.rmse_radius_mm},
                        {"source", fitting::kPaperTable2Label}};
        std::cout << out.dump(2) << "\n";
      } else if (a->format == "csv") {
        std::printf("cloud,method,converged,cx_mm,cy_mm,cz_mm,r_mm,rms_mm,inliers,points_used,iterations,wall_ms,"
                    "se_cx_mm,se_cy_mm,se_cz_mm,se_r_mm,rig_se_cx_mm,rig_se_cy_mm,rig_se_cz_mm,rig_se_r_mm,ci95_cx_mm,ci95_cy_mm,"
                    "ci95_cz_mm,ci95_r_mm,match_se_cx_mm,match_se_cy_mm,match_se_cz_mm,match_se_r_mm,true_r_mm,aer_mm,rer_percent,ld_mm,message\n");
        for (const auto& r : reports) {
          for (const auto& f : r.fits) {
            std::string msg = f.message;
            if (f.converged && f.not_a_ball) msg += (msg.empty() ? "" : "; ") + ("not a ball: " + *f.not_a_ball);
            std::replace(msg.begin(), msg.end(), '"', '\'');
            std::printf("%s,%s,%d,", r.file.c_str(), f.method.c_str(), f.converged ? 1 : 0);
            if (f.converged) {
              std::printf("%.4f,%.4f,%.4f,%.4f,%.4f,", f.sphere.center_mm.x(), f.sphere.center_mm.y(),
                          f.sphere.center_mm.z(), f.sphere.radius_mm, f.rms_mm);
            } else {
              std::printf(",,,,,");
            }
            std::printf("%zu,%zu,%d,%.3f,", f.inliers, f.points_used, f.iterations, f.wall_ms);
            const auto total = fitting::TotalStdError(f);
            for (const auto& v : {f.std_error_mm, f.rig_std_error_mm,
                                  total ? std::optional<Eigen::Vector4d>(1.96 * *total) : std::nullopt,
                                  f.matching_std_error_mm}) {
              if (v) {
                std::printf("%.4f,%.4f,%.4f,%.4f,", (*v)[0], (*v)[1], (*v)[2], (*v)[3]);
              } else {
                std::printf(",,,,");
              }
            }
            if (r.truth && f.converged) {
              const auto e = fitting::Evaluate(f.sphere, *r.truth);
              std::printf("%.4f,%.4f,%.4f,%.4f,", r.truth->radius_mm, e.aer_mm, e.rer_percent, e.ld_mm);
            } else {
              std::printf(",,,,");
            }
            std::printf("\"%s\"\n", msg.c_str());
          }
        }
      } else {
        for (const auto& r : reports) {
          std::printf("%s: %zu points, %zu after cleaning", r.file.c_str(), r.points, r.points_cleaned);
          if (r.truth) {
            std::printf("; truth r %.2f mm at [%.2f, %.2f, %.2f]", r.truth->radius_mm, r.truth->center_mm.x(),
                        r.truth->center_mm.y(), r.truth->center_mm.z());
          }
          std::printf("\n  %-17s %10s %10s %10s %9s %7s %8s %8s %8s %7s", "method", "cx mm", "cy mm", "cz mm", "r mm",
                      "rms", "inliers", "ms", "95%(c)", "95%(r)");
          if (r.truth) std::printf(" %8s %7s %8s", "AER mm", "RER %", "LD mm");
          std::printf("\n");
          for (const auto& f : r.fits) {
            if (!f.converged) {
              std::printf("  %-17s failed: %s\n", f.method.c_str(), f.message.c_str());
              continue;
            }
            // The 95 % interval's half-width: the centre's largest axis, and the radius.
            const auto total = fitting::TotalStdError(f);
            const std::string se_c = total ? "+-" + Num(1.96 * total->head<3>().maxCoeff(), 2) : "-";
            const std::string se_r = total ? "+-" + Num(1.96 * (*total)[3], 2) : "-";
            std::printf("  %-17s %10.2f %10.2f %10.2f %9.2f %7.2f %8zu %8.2f %8s %7s", f.method.c_str(),
                        f.sphere.center_mm.x(), f.sphere.center_mm.y(), f.sphere.center_mm.z(), f.sphere.radius_mm,
                        f.rms_mm, f.inliers, f.wall_ms, se_c.c_str(), se_r.c_str());
            if (r.truth) {
              const auto e = fitting::Evaluate(f.sphere, *r.truth);
              std::printf(" %8.2f %7.2f %8.2f", e.aer_mm, e.rer_percent, e.ld_mm);
            }
            std::printf("\n");
            if (f.not_a_ball) std::printf("  %-17s ^ not a ball: %s\n", "", f.not_a_ball->c_str());
          }
          std::printf("\n");
        }
        if (with_truth > 0) {
          std::printf("summary over %zu clouds with truth\n  %-17s %11s %11s %10s %9s %9s %9s %6s\n", with_truth,
                      "method", "mean|AER|", "max|AER|", "mean RER%", "RMSE", "mean LD", "max LD", "fails");
          for (const auto& m : methods) {
            auto it = stats.find(m);
            if (it == stats.end()) continue;
            const auto& s = it->second;
            std::printf("  %-17s %11.2f %11.2f %10.3f %9.2f %9.2f %9.2f %6zu\n", m.c_str(), s.mean_abs_aer_mm,
                        s.max_abs_aer_mm, s.mean_rer_percent, s.rmse_radius_mm, s.mean_ld_mm, s.max_ld_mm, s.failures);
          }
          const fitting::MethodSummary p = fitting::PaperTable2();
          std::printf("  %-17s %11.2f %11.2f %10.3f %9.2f %9.2f %9.2f %6s   (%s)\n", "paper", p.mean_abs_aer_mm,
                      p.max_abs_aer_mm, p.mean_rer_percent, p.rmse_radius_mm, p.mean_ld_mm, p.max_ld_mm, "-",
                      fitting::kPaperTable2Label);
          std::printf("  (mm; AER = measured - true radius, RER = |AER| / true radius, LD = centre distance)\n");
        }
      }
      return failed > 0 ? kExitBadInput : unfitted > 0 ? kExitProcessing : kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
