#pragma once
/// Bilinear resampling through fixed-point maps, as cv::remap does it, only sooner where the CPU
/// allows: the whole-frame rectification of every capture (stereo.rectify).

#include <opencv2/core.hpp>

namespace hedgefit::stereo {

/// cv::remap(source, *out, map1, map2, cv::INTER_LINEAR), border constant 0, to the bit, for
/// fixed-point maps (`map1` CV_16SC2, `map2` CV_16UC1, as cv::convertMaps makes them). 8-bit colour
/// is resampled 16 pixels at a time where the CPU has AVX-512 (F, BW and VBMI), in OpenCV's integer
/// arithmetic (its 32 x 32 table of 15-bit weights, its rounding); anything else is cv::remap's.
void RemapLinearFixed(const cv::Mat& source, const cv::Mat& map1, const cv::Mat& map2, cv::Mat* out);

/// Tests only: cv::remap itself even where the AVX-512 path would run.
void ForcePortableLinearRemap(bool portable);

}  // namespace hedgefit::stereo
