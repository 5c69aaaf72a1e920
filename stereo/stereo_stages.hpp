#pragma once
/// stereo.* pipeline stages and readers.stereo: thin adapters from declared options to the
/// capture functions (capture.hpp). Artifacts: "left_image", "right_image" (cv::Mat BGR;
/// rectified after stereo.rectify), "raw_left_image", "raw_right_image" (as captured), "rig"
/// (StereoRig), "rectified" (bool), "mask" (CV_8U), "disparity" (CV_32F px), "filled" (CV_8U,
/// 255 where filled rather than measured), "disparity_sigma" (CV_32F px), "matched_region"
/// (cv::Rect), and "cloud".

#include <opencv2/core.hpp>

#include <string>

#include "pipeline/registry.hpp"
#include "stereo/image_io.hpp"  // WriteImageAtomic
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

/// Adds readers.stereo, stereo.rectify, stereo.segment, stereo.mask, stereo.segment_depth,
/// stereo.sgbm and stereo.reproject to `registry`.
void RegisterStereoStages(pipeline::Registry& registry);

/// One image of a capture, as readers.stereo reads it: 8-bit BGR (or grey with
/// cv::IMREAD_GRAYSCALE); only PNG, JPEG, TIFF, BMP and PNM are decoded. Throws hedgefit::Error
/// naming the file when it cannot be read (another format, damaged, absurd size).
cv::Mat ReadCaptureImage(const std::string& path, int flags = 1 /* cv::IMREAD_COLOR */);

/// The capture formats ReadCaptureImage decodes: throws hedgefit::Error naming `path` for
/// `format` (from SniffImageFormat) when it is none of them.
void RequireCaptureFormat(const std::string& path, const std::string& format);

/// Puts a capture already in memory into `ctx` as readers.stereo would.
void PutCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig, pipeline::Context* ctx);

/// Checks the images of one capture before any work: each exists and is a format a capture can
/// be read from (a missing or unreadable image is bad input, exit 1).
void CheckCaptureImages(const std::string& left, const std::string& right);

}  // namespace hedgefit::stereo
