#pragma once
/// What `convert` does around each capture's pipeline: the captures of a directory or manifest,
/// a shard of them for one machine of several, the per-hedge output names, the debug pictures,
/// the one-line summary of a converted capture, and the hints a run's user should act on.

#include <functional>
#include <string>
#include <vector>

#include "pipeline/pipeline.hpp"

namespace hedgefit::stereo {
struct ConvertOptions;
}  // namespace hedgefit::stereo

namespace hedgefit::measure {

struct CaptureFiles {
  std::string name, left, right;
};

/// What became of one capture in ConvertCaptures.
struct CaptureOutcome {
  const CaptureFiles* capture = nullptr;
  std::string output;      ///< the PCD path (with '#' for a hedge's id when there are several)
  std::string summary;     ///< CaptureSummary's line when converted
  std::string hint;        ///< CaptureHint's line, "" when nothing to act on
  std::string error;       ///< why it failed; "" when converted
  bool input_error = false;  ///< the failure is bad input (a damaged image), not processing
  bool unusable = false;     ///< converted, but a check found it unusable (CaptureUnusable)
};

/// Converts each capture with the capture pipeline (CapturePipelineJson: the same that
/// `--print-pipeline` shows) into `output_of(capture)`, `threads` at a time (0 = all cores),
/// also writing the debug pictures when `debug`. `done` is called once per capture as it
/// finishes, one call at a time; a failure is reported there, not thrown.
void ConvertCaptures(const stereo::ConvertOptions& o, const std::vector<CaptureFiles>& captures, const std::string& rig,
                     const std::function<std::string(const CaptureFiles&)>& output_of, bool debug, int threads,
                     const std::function<void(const CaptureOutcome&)>& done);

/// A directory's NAME_left.* / NAME_right.* pairs in name order, or a manifest's
/// 'LEFT RIGHT [NAME]' lines (NAME defaults to LEFT's stem). Throws Error when there are none.
std::vector<CaptureFiles> ListCaptures(const std::string& directory_or_manifest);

/// Every n-th capture starting at i, for `shard` = "i/n" (0 <= i < n); throws Error naming --shard.
std::vector<CaptureFiles> Shard(const std::vector<CaptureFiles>& captures, const std::string& shard);

/// Output names with several hedges: '#' stands for the hedge's id ("row_#.pcd" -> row_1.pcd, ...).
/// PerHedgePath adds "_#" before the extension when `several` and the path has no '#';
/// HedgePath puts `id` in place of the '#'; StemWithoutHedgeMark is the path's stem without it
/// ("row_#.pcd" -> "row").
std::string PerHedgePath(const std::string& path, bool several);
std::string HedgePath(const std::string& path, int id);
std::string StemWithoutHedgeMark(const std::string& path);

/// BASE_rectified.png (the pair side by side), BASE_mask.png and BASE_disparity.png (coloured)
/// from a capture pipeline's context.
void WriteDebugPictures(const std::string& base, pipeline::Context& ctx);

/// One line for a converted capture: points, time, share of the frame matched, the output; then
/// a line per hedge the depth segmentation found (its box, rough size and distance, points, file).
std::string CaptureSummary(const std::string& name, const std::string& output, pipeline::Context& ctx,
                           const pipeline::RunReport& report);

/// What a run saw that its user should act on, in one line ("" when nothing):
/// - The paper's colour mask covers most of a garden (lawn, hedge rows and trees are green too)
///   and a fit may then find one ball of a row, or the lawn. When a run's colour mask covers
///   more than half the frame: use --garden. Half the frame: the paper's largest hedge (r 960
///   mm) from 1 m away covers about a quarter.
/// - What stereo.rig_check said of each hedge: why it is unusable, or that its interval was
///   widened because the rig drifted (one message when every hedge shares it). Without that
///   stage: the rectified rows disagree by more than 0.5 px (stereo.sgbm's estimate over the
///   hedges). The refinement removes the rows' disagreement, SGBM's integer search does not
///   (Middlebury Motorcycle, rows already 0.31 px apart: another 0.25 px raises its bad-0.5 from
///   18.6 to 23.9 %).
std::string CaptureHint(pipeline::Context& ctx);

/// Whether stereo.rig_check found a hedge of this capture unusable (the rig does not fit the
/// cameras): `convert`, `measure` and `stream` then exit with 3.
bool CaptureUnusable(pipeline::Context& ctx);
/// Why stereo.rig_check could not check the rig against this capture (a hedge's "rig_check" is
/// "unchecked": too few textured places across the frame), or empty when it could. `measure
/// --strict` and `stream` (unless --no-strict) refuse such a result with exit 3.
std::string CaptureUnchecked(pipeline::Context& ctx);

}  // namespace hedgefit::measure
