#pragma once
/// Does a rig file still fit the cameras? How far apart it leaves a pair's rectified rows, with
/// the policy `hedgefit check-rig` and the Python module apply: the depth range is checked before
/// any matching, and a plane through fewer than kMinRowWindows windows is not a measurement.

#include <opencv2/core.hpp>

#include <string>

#include "stereo/capture.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

/// The textured windows a measurement of the rows needs over the whole frame.
constexpr int kMinRowWindows = 100;

/// Throws Error when [min_z_mm, max_z_mm] is empty or the nearest depth asks for a disparity over
/// a quarter of the half-size views' width; `min_z_name` and `max_z_name` name the two limits as
/// the user gave them ("--min-z", or "min_z" in Python).
void CheckRowSearchRange(const StereoRig& rig, double min_z_mm, double max_z_mm,
                         const std::string& min_z_name = "--min-z", const std::string& max_z_name = "--max-z");

struct RigCheck {
  VerticalDisparity rows;  ///< the rows' disagreement as a plane over the frame
  double max_abs_px = 0;   ///< its largest magnitude over the frame
  bool fits = false;       ///< max_abs_px within the tolerance
};

/// The rows' disagreement of `rig` on this pair. Throws ProcessingError when fewer than
/// kMinRowWindows windows matched (too little texture in the range, or rows more than 2 px
/// apart), Error for bad input; `source` names the pair in messages.
RigCheck CheckRigOnPair(const StereoRig& rig, const cv::Mat& left_bgr, const cv::Mat& right_bgr, double min_z_mm,
                        double max_z_mm, double tolerance_px, const std::string& source);

}  // namespace hedgefit::stereo
