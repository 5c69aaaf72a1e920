#pragma once
/// `hedgefit compare` as a library: clean each cloud, fit every method to each of its hedges, add
/// the fits' uncertainty, match each hedge to its truth; then the per-method summary, the plot's
/// series and the three report formats (table, JSON, CSV).

#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "cloud/point_perturbation.hpp"
#include "eval/evaluation.hpp"
#include "fitting/sphere_fit.hpp"
#include "pipeline/stage.hpp"

namespace hedgefit::eval {

struct CompareOptions {
  std::vector<std::string> methods;                          ///< fitting method names, in report order
  std::map<std::string, pipeline::OptionValue> fit_options;  ///< each applies to every method that has it
  std::string cleaning_json;   ///< JSON array of filter stages; cloud::DefaultCleaningJson() by default
  std::string cleaning_source = "default cleaning";  ///< names the cleaning in errors
  double scale = 1.0;          ///< coordinates are multiplied by it on read (1000 for metres)
  std::uint64_t seed = 42;     ///< the cleaning's and RANSAC's seed
  std::vector<fitting::Sphere> truth;  ///< for every cloud; empty: CLOUD.truth.json beside each, if any
  const cloud::PointPerturbation* rig = nullptr;       ///< the rig's calibration, or none
  const cloud::PointPerturbation* matching = nullptr;  ///< the matcher's common offset, or none
};

/// One hedge of one cloud (the whole cloud when it has no hedge_id field) and its fits.
struct CloudReport {
  std::string file;  ///< with " hedge N" for one hedge of a capture
  int hedge_id = 0;
  std::size_t points = 0;
  std::size_t points_cleaned = 0;
  std::optional<fitting::Sphere> truth;
  std::vector<fitting::SphereFitResult> fits;
};

/// A user's cleaning pipeline file as a JSON array of filter stages (a {"pipeline": [...]} object
/// is unwrapped); throws Error naming `path` when it is unreadable, not JSON, or holds a reader or
/// writer.
std::string ReadCleaningFile(const std::string& path);

/// Throws Error when `options.cleaning_json` cannot run after a reader of `first_cloud`: checked
/// once, before any cloud is read.
void CheckCleaning(const CompareOptions& options, const std::string& first_cloud);

/// Reads, cleans and fits `file`: one report per hedge. Throws Error for a file that cannot be read
/// or holds no hedge's point.
std::vector<CloudReport> CompareCloud(const std::string& file, const CompareOptions& options);

/// The reports (hedges) that no method fitted: a failure of the run, not only a table row.
std::vector<const CloudReport*> Unfitted(const std::vector<CloudReport>& reports);

struct CompareSummary {
  std::size_t with_truth = 0;                       ///< reports that have a truth
  std::map<std::string, MethodSummary> per_method;  ///< over those
};
CompareSummary Summarise(const std::vector<CloudReport>& reports);

/// One method's errors against truth, one entry per report with truth.
struct ErrorSeries {
  std::string method;
  std::vector<double> x;           ///< true distance Z (mm), or the report's index
  std::vector<double> abs_aer_mm;  ///< |measured - true radius|
  std::vector<double> ld_mm;       ///< centre deviation
};

/// |AER| and LD per method, against the true distance when the truths differ in Z (then
/// `*x_title` says so), else against the report's number.
std::vector<ErrorSeries> ErrorSeriesByMethod(const std::vector<CloudReport>& reports,
                                             const std::vector<std::string>& methods, std::string* x_title);

/// The reports as `compare --format table|json|csv` prints them.
void WriteCompareTable(std::ostream& out, const std::vector<CloudReport>& reports,
                       const std::vector<std::string>& methods, const CompareSummary& summary);
void WriteCompareJson(std::ostream& out, const std::vector<CloudReport>& reports,
                      const std::vector<std::string>& methods, const CompareSummary& summary);
void WriteCompareCsv(std::ostream& out, const std::vector<CloudReport>& reports);

/// A sphere from a fits file: a converged fit (its method) or the truth.
struct FitRecord {
  std::string label;  ///< the method, or "truth"
  fitting::Sphere sphere;
  bool truth = false;
  /// A clipped shape's (the `shape` method's): semi-axes along the heading, across it and along
  /// `up`, mm (zero for a sphere), and the heading about `up` from the x axis laid flat.
  Eigen::Vector3d axes_mm = Eigen::Vector3d::Zero();
  double heading_deg = 0;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::string form = "";  ///< "cylinder", "cuboid" or "cone" for a shape standing on the ground (the fit's message), else ""
};

/// The converged fits and the truth `compare --format json` wrote for `cloud_path` (matched by
/// path, then by file name; the first cloud otherwise). Throws Error naming `path`.
std::vector<FitRecord> ReadCompareFits(const std::string& path, const std::string& cloud_path);

}  // namespace hedgefit::eval
