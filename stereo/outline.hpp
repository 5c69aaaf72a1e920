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
#include <vector>

#include "cloud/outline_rays.hpp"
#include "cloud/point_cloud.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

struct OutlineStats {
  std::size_t border = 0;     ///< points of the start sphere's outline considered (both views)
  std::size_t left = 0, right = 0;  ///< edges found in each view
  double contrast = 0;        ///< median edge contrast over the profile's scatter (left view)
};

/// One point of a sphere's outline as a camera sees it: the tangent point `q` (rectified frame,
/// mm), its outward direction `u` from the ring's centre, its pixel `p` and the outline's outward
/// normal `n` there (unit, px).
struct SilhouettePoint {
  cv::Vec3d u, q;
  cv::Point2d p, n;
};

/// The outline of the sphere (`centre`, `radius`; rectified frame, mm) seen from `origin` through a
/// rectified camera (focal `f`, principal point `cx`, `cy`, px): about one point per pixel of it and
/// at least 64, in order round it. Empty when the camera is within 1.05 radii of the centre or the
/// sphere is not wholly in front of it.
std::vector<SilhouettePoint> SphereSilhouette(const cv::Vec3d& centre, double radius, const cv::Vec3d& origin, double f,
                                              double cx, double cy);

/// `start`: per hedge id, a sphere near its envelope (centre x, y, z and radius, mm, unrectified
/// left frame). `labels` (optional): CV_32S hedge ids in the rectified left image, to leave out
/// the outline where another hedge lies beyond it. `ground` (optional): the ground plane in the
/// unrectified left frame (n.p + d = 0, mm). Rays are in the unrectified left frame.
cloud::HedgeOutlines MeasureOutlines(const cv::Mat& left_rect, const cv::Mat& right_rect, const cv::Mat& labels,
                                     const StereoRig& rig, const std::map<int, Eigen::Vector4d>& start,
                                     const std::optional<cv::Vec4d>& ground = std::nullopt,
                                     std::map<int, OutlineStats>* stats = nullptr);

}  // namespace hedgefit::stereo
