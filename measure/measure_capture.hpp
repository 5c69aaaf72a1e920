#pragma once
/// One stereo capture measured, as a typed call: what `hedgefit measure`, `hedgefit stream` and
/// Python's `hedgefit.measure` run and read. The request says how (fit methods, cleaning, the
/// capture path's options, an overlay to write); the result holds the fits, the JSON lines the
/// commands print (one per hedge and fit, `compare --format json`'s fields with the hedge's image
/// box), and what the capture's own checks said. The pipeline underneath is measure's recipe
/// (recipes.hpp; `--print-pipeline` prints it), run through the stages' registry, so a plugin
/// matcher or fitter joins it; its context's string keys are read here and nowhere above.

#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <vector>

#include "fitting/sphere_fit.hpp"
#include "pipeline/pipeline.hpp"
#include "stereo/capture.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::measure {

/// How to measure a capture.
struct MeasureRequest {
  std::vector<std::string> methods{"ransac_ray"};  ///< fit methods (fitting/methods.hpp), in order
  bool clean = true;                                ///< the default cleaning before the fits (filters.hedge_outlier)
  stereo::ConvertOptions capture;                   ///< the capture path's options (`measure`'s capture flags)
  /// Options set in every capture stage (stereo.*) that declares them, by name, as a `measure`
  /// flag sets them; a name no capture stage declares is an InputError.
  std::map<std::string, pipeline::OptionValue> capture_options;
  std::string overlay;  ///< also write the left image with each fitted hedge drawn on it ("" none)
};

/// What a capture's measurement says.
struct MeasureResult {
  std::vector<fitting::SphereFitResult> fits;  ///< one per hedge and method, in the pipeline's order
  std::vector<nlohmann::ordered_json> lines;   ///< the same as `measure` prints them (keys in order: hedge first)
  int converged = 0;                           ///< fits that converged
  std::string first_failure;                   ///< "hedge N, METHOD: why" of the first that did not, "" none
  std::vector<std::string> not_balls;          ///< "hedge N, METHOD: not a ball: why" of each such fit
  std::string hint;       ///< what the capture's checks ask a user to act on (a drifted rig, a colour mask over the lawn), "" none
  bool unusable = false;  ///< a check found a result unusable (its line's "unusable" says why): not to act on
  std::string unchecked;  ///< why the rig could not be checked against the capture, "" when it was
  std::map<std::string, double> stage_ms;  ///< wall time per stage type
  double total_ms = 0;
  /// An output (the overlay) that could not be written after the fits: the rest holds.
  std::string output_error;
};

/// The pipeline `request` runs (JSON stages), reading the files given or, with none, taking the
/// images and the rig from its caller.
std::string MeasureRecipe(const MeasureRequest& request, const pipeline::Registry& registry, const std::string& left = "",
                          const std::string& right = "", const std::string& rig = "");

/// Measures the capture in image files with a rig file. An unreadable image or rig is an
/// InputError naming the file; a failure of the path a ProcessingError naming the left image.
MeasureResult MeasureCapture(const std::string& left, const std::string& right, const std::string& rig,
                             const MeasureRequest& request, const pipeline::Registry& registry);

/// Measures a capture already in memory (BGR images) with its rig.
MeasureResult MeasureCapture(const cv::Mat& left, const cv::Mat& right, const stereo::StereoRig& rig,
                             const MeasureRequest& request, const pipeline::Registry& registry);

/// Reads a measure recipe's run (a runner that ran it itself: `stream`'s overlapped frames).
MeasureResult ReadMeasureResult(pipeline::Context& ctx, const pipeline::RunReport& report);

/// Millimetres and milliseconds to the micrometre / microsecond (more digits are noise).
nlohmann::ordered_json Rounded(const nlohmann::ordered_json& value);

}  // namespace hedgefit::measure
