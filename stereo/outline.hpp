#pragma once
/// A hedge's outline, measured in both rectified views to a fraction of a pixel, as the rays
/// that graze its envelope: the outermost leaves make the outline, so it sees the envelope where
/// the front's points see the leaves under a matching window.
///
/// About each point of a start sphere's outline in each view (a fit to the front's points, a
/// pixel or two off), along its normal, the image's profile (averaged over 4 px along the
/// outline) is cut into two levels where the squared residual is least: the edge is where the
/// hedge's side ends and the background's begins, whatever either is (sky, lawn, hedge row,
/// shadow), with no threshold on grey levels. A cut counts when its two levels differ by more
/// than three times the profile's own scatter about them. Left out: points at the image's edge,
/// against another hedge, or where the hedge meets the ground (the background just outside is
/// the lawn at its foot, not beyond it).

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstddef>
#include <map>
#include <optional>

#include "cloud/outline_rays.hpp"
#include "cloud/point_cloud.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

struct OutlineStats {
  std::size_t border = 0;     ///< points of the start sphere's outline considered (both views)
  std::size_t left = 0, right = 0;  ///< edges found in each view
  double contrast = 0;        ///< median edge contrast over the profile's scatter (left view)
};

/// `start`: per hedge id, a sphere near its envelope (centre x, y, z and radius, mm, unrectified
/// left frame). `labels` (optional): CV_32S hedge ids in the rectified left image, to leave out
/// the outline where another hedge lies beyond it. `ground` (optional): the ground plane in the
/// unrectified left frame (n.p + d = 0, mm). Rays are in the unrectified left frame.
cloud::HedgeOutlines MeasureOutlines(const cv::Mat& left_rect, const cv::Mat& right_rect, const cv::Mat& labels,
                                     const StereoRig& rig, const std::map<int, Eigen::Vector4d>& start,
                                     const std::optional<cv::Vec4d>& ground = std::nullopt,
                                     std::map<int, OutlineStats>* stats = nullptr);

}  // namespace hedgefit::stereo
