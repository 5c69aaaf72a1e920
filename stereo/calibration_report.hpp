#pragma once
/// `hedgefit calibrate` as a library: the pairs from globs or a list file, the calibration, and
/// what a user should know of it: the distortion model's evidence (the same corners with the
/// terms it adds dropped), the corners' coverage of the image, loose principal points, and the
/// report as text or JSON.

#include <opencv2/core.hpp>

#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "stereo/calibration.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

/// The principal point's standard deviation above which a calibration warns (px): 0.2 px moves a
/// hedge about 0.5 mm sideways at 2.3 m on the paper's rig.
constexpr double kPrincipalPointWarnPx = 0.2;
/// The share of an 8 x 8 grid over the image the corners must reach in each camera.
constexpr double kMinCornerCoverage = 0.6;

/// Files matching `pattern`, sorted; throws Error naming `option` when none does.
std::vector<std::string> GlobFiles(const std::string& pattern, const std::string& option);

/// Pairs from two globs matched by sorted order; throws Error when the counts differ.
std::vector<std::pair<std::string, std::string>> PairsFromGlobs(const std::string& left, const std::string& right);

/// Pairs from a file of 'LEFT RIGHT' lines (blank lines and # comments skipped).
std::vector<std::pair<std::string, std::string>> ReadPairList(const std::string& path);

/// A stereo rig for hedges is this wide, mm (hand-held pairs from 20 mm, a robot's up to 2 m):
/// outside it, --square was given in another unit, and calibrate warns.
constexpr double kMinPlausibleBaselineMm = 20, kMaxPlausibleBaselineMm = 2000;

struct CalibrationReport {
  StereoRig rig;
  std::vector<double> std_devs;      ///< RigStdDevs(rig)
  std::optional<StereoRig> simpler;  ///< the same corners without the terms the model adds
  std::string dropped_terms;         ///< "k3", or "k4..k6" for the rational model
  double dropped_in_std = 0;         ///< the largest dropped term, in its standard deviations
  std::pair<double, double> corner_coverage{0, 0};  ///< left, right: share of an 8 x 8 grid
  cv::Mat coverage_picture;          ///< CoveragePicture
  double rotation_deg = 0;           ///< between the cameras
  int pairs_used = 0;
  std::vector<std::string> warnings;  ///< what the poses leave loose, and how to fix it
};

/// Detects the board in `pairs`, calibrates, and judges the result. `progress` (may be null)
/// gets one line per pair as DetectBoards gives it.
CalibrationReport CalibrateWithReport(const std::vector<std::pair<std::string, std::string>>& pairs,
                                      const CalibrationOptions& options, std::ostream* progress);

/// The report as `calibrate --json` prints it.
std::string CalibrationReportJson(const CalibrationReport& report, const std::string& rig_file);

/// The report as `calibrate` prints it; `coverage_file` empty adds how to draw the coverage.
void PrintCalibrationReport(std::ostream& out, const CalibrationReport& report, const std::string& coverage_file);

}  // namespace hedgefit::stereo
