#pragma once
/// stereo.* pipeline stages and readers.stereo: thin adapters from declared options to the
/// capture functions (capture.hpp). Artifacts: "left_image", "right_image" (cv::Mat BGR;
/// rectified after stereo.rectify), "raw_left_image", "raw_right_image" (as captured), "rig"
/// (StereoRig), "rectified" (bool), "mask" (CV_8U), "disparity" (CV_32F px), "filled" (CV_8U,
/// 255 where filled rather than measured), "disparity_sigma" (CV_32F px), "matched_region"
/// (cv::Rect), and "cloud".

#include <opencv2/core.hpp>

#include <string>

#include "cloud/registry.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::stereo {

/// Adds readers.stereo, stereo.rectify, stereo.segment, stereo.mask, stereo.segment_depth,
/// stereo.sgbm and stereo.reproject to `registry`.
void RegisterStereoStages(cloud::Registry& registry);

/// One image of a capture, as readers.stereo reads it: 8-bit BGR (or grey with
/// cv::IMREAD_GRAYSCALE); only PNG, JPEG, TIFF, BMP and PNM are decoded. Throws hedgefit::Error
/// naming the file when it cannot be read (another format, damaged, absurd size).
cv::Mat ReadCaptureImage(const std::string& path, int flags = 1 /* cv::IMREAD_COLOR */);

/// Writes `image` to `path` in the format its extension names (.png, .jpg, ...), atomically:
/// encoded in memory, written to a hidden temporary file beside it and renamed, so a failed
/// or killed run never leaves a half-written image under the final name. Throws
/// hedgefit::Error naming the file.
void WriteImageAtomic(const std::string& path, const cv::Mat& image);

/// Puts a capture already in memory into `ctx` as readers.stereo would.
void PutCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig, cloud::Context* ctx);

}  // namespace hedgefit::stereo
