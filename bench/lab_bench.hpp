#pragma once
/// The paper's laboratory test on the simulated rig, end to end, as a library the CLI calls
/// (`hedgefit bench lab`): render boards and spheres, calibrate from the boards (never from
/// the simulator's truth), convert each sphere capture, fit with every method of the table,
/// and score like Table 2.

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "eval/evaluation.hpp"
#include "cloud/cleaning.hpp"
#include "pipeline/option_table.hpp"
#include "stereo/capture.hpp"

namespace hedgefit::bench {

struct LabOptions {
  std::string dir = "build/lab-bench";  ///< where the simulated captures go
  double scale = 1.0;                   ///< image scale of the simulated rig (1 = 1920x1200)
  double alpha;                         ///< rectification scaling; set from CalibrationOptions
  bool reuse = false;                   ///< reuse captures already in `dir`
  bool true_rig = false;                ///< the simulator's exact rig instead of calibrating
  /// Also calibrate from the 12 boards of WideBoards() (board_17..28; rendered when missing),
  /// which reach the image's edges where the paper's lab boards leave the principal point loose.
  bool wide_boards = false;
  /// "hedgefit" (its own simulator) or "povray" (an independent ray tracer, sim/povray.hpp).
  std::string renderer = "hedgefit";
  /// "ideal" (as rendered) or "real": every image through sim::CameraModel's defaults
  /// (gains, white balance, vignetting, Bayer, shot and read noise, independent per camera).
  std::string camera = "ideal";
  /// With camera "real": each sphere is recorded this many times, each time with its own draw of
  /// the cameras' noise (the same render, the same calibration). Draw 1 is the pair in `dir`; the
  /// others go through the camera model in memory from the as-rendered pair (kept in
  /// `dir`/as_rendered, rendered when missing). One draw of seven captures scatters by as much as
  /// the targets, so a setting is judged on several.
  int noise_draws = 1;
  /// With camera "real": these effects of the camera model (sim::WithoutEffect's names) are
  /// left out of the spheres' pairs, to see what each costs; the boards, and so the calibration,
  /// keep them all. Every draw, the first too, is then recorded afresh from the as-rendered pair.
  std::vector<std::string> camera_without;
  stereo::ConvertOptions convert;       ///< the capture path's options
  /// The filter stages (JSON array) run on each capture's cloud before the fits; empty (the
  /// default) fits the matcher's cloud as it is, cloud::DefaultCleaningJson() what `measure` does.
  std::string cleaning;
  LabOptions();
  /// The options a user sets (`hedgefit bench lab`'s flags), declared once.
  static const pipeline::OptionTable<LabOptions>& Table();
};

struct LabRow {
  double z_mm = 0;
  int draw = 1;  ///< the noise draw (1 = the pair on disk)
  fitting::Sphere truth;
  std::vector<fitting::SphereFitResult> fits;  ///< one per method, in table order
  double convert_ms = 0;
  std::size_t points = 0;
};

struct LabResult {
  double rms_stereo_px = 0;  ///< calibration's stereo RMS (0 with the exact rig)
  double baseline_mm = 0;
  bool exact_rig = false;
  std::vector<LabRow> rows;  ///< Z = 2000..2600 mm, draw by draw
  int noise_draws = 1;
  std::vector<std::string> camera_without;  ///< the camera effects left out of the spheres' pairs
  std::map<std::string, eval::MethodSummary> summary;  ///< over every row (all draws)
  /// Per method, the summary of each noise draw's seven captures (empty with one draw).
  std::map<std::string, std::vector<eval::MethodSummary>> per_draw;
  double seconds = 0;
};

/// How well the fits' stated 95 % intervals (fitting::TotalStdError, 1.96 standard errors) hold
/// the truth, over fits x (cx, cy, cz, r), and the stated standard error against the actual
/// error: what `bench lab` and `bench garden` print per method.
struct IntervalCoverage {
  int inside = 0, cases = 0;
  double stated2 = 0, error2 = 0, rig2 = 0, matching2 = 0;  ///< sums of squares, mm^2
  /// Adds a fit's four coordinates; a fit that did not converge or states no error is left out.
  void Add(const fitting::SphereFitResult& fit, const fitting::Sphere& truth);
  double StatedRms() const { return cases ? std::sqrt(stated2 / cases) : 0.0; }
  double ErrorRms() const { return cases ? std::sqrt(error2 / cases) : 0.0; }
  double RigPercent() const { return stated2 > 0 ? 100 * rig2 / stated2 : 0.0; }
  double MatchingPercent() const { return stated2 > 0 ? 100 * matching2 / stated2 : 0.0; }
};

/// A fit's stated uncertainty, for the benches' JSON: fitting::FitFields' std_error_mm,
/// rig_std_error_mm, matching_std_error_mm, total_std_error_mm and ci95_mm, those it has.
std::vector<std::pair<std::string, std::vector<double>>> StatedUncertainty(const fitting::SphereFitResult& fit);

/// Runs the lab test. Throws hedgefit::Error when a capture cannot be converted.
LabResult RunLab(const LabOptions& options);

/// Prints the per-method tables and the summary beside the paper's Table 2.
void PrintLab(const LabResult& result);

/// The result as JSON text.
std::string LabJson(const LabResult& result);

}  // namespace hedgefit::bench
