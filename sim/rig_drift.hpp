#pragma once
/// Rig files that no longer fit their cameras, the way real rigs drift: for the drifted-rig suite
/// (tests and bench/bench_rig_drift). Each drift changes the rig *file* (the cameras, and so the
/// images, stay as they were) and recomputes its rectification as `calibrate` would.

#include <string>
#include <vector>

#include "stereo/rig.hpp"

namespace hedgefit::sim {

struct RigDrift {
  std::string name;       ///< e.g. "roll 0.1 deg"
  double pitch_deg = 0;   ///< the right camera turned about its x axis
  double roll_deg = 0;    ///< ... about its optical axis
  double yaw_deg = 0;     ///< ... about its y axis (moves no row: unjudgeable by one pair)
  double right_cx_px = 0, right_cy_px = 0;  ///< the right camera's principal point moved
  double right_focal = 0;                   ///< the right camera's focal lengths scaled by 1 + this
  double ty_mm = 0;                         ///< a vertical component added to the baseline
  double baseline_scale = 0;                ///< |T| scaled by 1 + this (moves no row)
  bool no_distortion = false;               ///< both cameras' distortion lost (D = 0)
  double distortion_scale = 1;              ///< both cameras' distortion scaled by this
  bool swapped = false;                     ///< the two cameras' intrinsics exchanged
  bool nominal = false;                     ///< a nominal rig of the right size instead (f, c from K1, |T|)
  /// Whether one pair can reveal the drift: yaw, the horizontal principal point and the
  /// baseline's length move no row (to first order), so no check of one pair's rows can see them.
  bool judgeable = true;
};

/// `rig` drifted by `d`, rectified again (cv::stereoRectify, alpha 0, as `calibrate` does).
stereo::StereoRig DriftRig(const stereo::StereoRig& rig, const RigDrift& d);

/// How far apart `file` leaves the rectified rows of a pair taken by `cameras`, px: the largest
/// |right row - left row| over the frame (a 17 x 11 grid of left pixels) for points 1.5, 2.5 and 5 m
/// away. The calibrated rig stands for the cameras, so its own value is 0.
double RowsApart(const stereo::StereoRig& cameras, const stereo::StereoRig& file);

/// The suite's drifts: pitch, roll, yaw, principal points, vertical baseline, focal lengths
/// (0.5-2 %), distortion lost, cameras swapped and a nominal rig, each at several sizes.
std::vector<RigDrift> DriftSuite();

}  // namespace hedgefit::sim
