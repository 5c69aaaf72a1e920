#pragma once
/// Scoring fits against ground truth with the paper's statistics (Table 2/3):
/// AER = measured - true radius (mm), RER = |AER| / true radius (%), LD = distance
/// between measured and true centres (mm), and per method the means and the RMSE.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/stage.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::eval {

using fitting::Sphere;
using fitting::SphereFitResult;

/// Reads a truth JSON {"center_mm": [x, y, z], "radius_mm": r}; throws hedgefit::Error naming the file.
Sphere ReadTruthFile(const std::string& path);

/// Every sphere of a truth file (one, or a capture's several hedges, eval/truth_file.hpp).
std::vector<Sphere> ReadTruthFiles(const std::string& path);

/// The truth a hedge's points belong to: the sphere whose centre is nearest their centroid, if
/// the centroid lies within that sphere (a hedge's visible points lie on its near side, inside
/// its radius of the centre); nullopt otherwise.
std::optional<Sphere> TruthForPoints(const std::vector<Sphere>& truths, const std::vector<Eigen::Vector3d>& points_mm);

/// CLOUD.truth.json beside CLOUD.ext, if it exists.
std::optional<std::string> TruthFileFor(const std::string& cloud_path);

struct FitError {
  double aer_mm = 0;       ///< absolute error of radius, signed: measured - true (mm)
  double rer_percent = 0;  ///< relative error of radius, |AER| / true radius * 100
  double ld_mm = 0;        ///< location deviation: |measured centre - true centre| (mm)
};

FitError Evaluate(const Sphere& fit, const Sphere& truth);

struct MethodSummary {
  std::size_t clouds = 0;       ///< clouds with truth where the method converged
  std::size_t failures = 0;     ///< clouds with truth where it did not
  double mean_abs_aer_mm = 0;   ///< mean |AER|
  double max_abs_aer_mm = 0;    ///< max |AER|
  double mean_rer_percent = 0;  ///< mean RER
  double mean_ld_mm = 0;        ///< mean LD
  double max_ld_mm = 0;         ///< max LD
  double rmse_radius_mm = 0;    ///< sqrt(mean AER^2)
};

/// The paper's published lab summary (Table 2: seven positions, 2.0-2.6 m), the one copy of
/// the figures every report sets beside its own.
MethodSummary PaperTable2();
inline constexpr const char* kPaperTable2Label = "Table 2, lab, 2.0-2.6 m";

/// Accumulates per-method statistics over clouds.
class SummaryBuilder {
 public:
  void Add(const std::string& method, const SphereFitResult& fit, const Sphere& truth);
  std::map<std::string, MethodSummary> Finish() const;

 private:
  std::map<std::string, std::vector<FitError>> errors_;
  std::map<std::string, std::size_t> failures_;
};

}  // namespace hedgefit::eval
