#pragma once
/// The outline-then-envelope step of the measuring layer: each hedge's envelope fitted to the
/// front's points alone (fitting's "envelope" method) is the start sphere about which
/// stereo::MeasureOutlines measures its outline in both rectified views. stereo/ measures an
/// outline about any start it is given; which fit gives the start is decided here.

#include <opencv2/core.hpp>

#include <cstdint>
#include <map>
#include <optional>

#include "cloud/outline_rays.hpp"
#include "cloud/point_cloud.hpp"
#include "stereo/outline.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::measure {

/// stereo::MeasureOutlines about each hedge's envelope fitted to `cloud`'s points alone (per
/// hedge_id group; fitting's "envelope" method with `seed`): what stage stereo.outline does.
cloud::HedgeOutlines MeasureCloudOutlines(const cv::Mat& left_rect, const cv::Mat& right_rect, const cv::Mat& labels,
                                          const stereo::StereoRig& rig, const cloud::PointCloud& cloud, std::uint64_t seed,
                                          const std::optional<cv::Vec4d>& ground = std::nullopt,
                                          std::map<int, stereo::OutlineStats>* stats = nullptr);

}  // namespace hedgefit::measure
