#pragma once
/// Rectification of a capture: Bouguet's R1/P1, R2/P2 applied with cached maps, bilinear for
/// the whole frame and cubic B-splines for the region that is matched.

#include <opencv2/core.hpp>

#include "stereo/rig.hpp"

namespace hedgefit::stereo {

/// Undistorts and rectifies a pair with the rig's R1/P1 and R2/P2 (bilinear; the maps are
/// cached per rig). Throws hedgefit::Error when the rig has no rectification or the images
/// are not the rig's size.
void RectifyPair(const StereoRig& rig, const cv::Mat& left, const cv::Mat& right, cv::Mat* left_rect,
                 cv::Mat* right_rect);

/// Re-renders `roi` of already rectified images with cubic B-spline resampling, whose
/// sub-pixel phase error is far below bilinear's (see bspline.hpp).
void RectifyRegionPrecisely(const StereoRig& rig, const cv::Mat& left, const cv::Mat& right, const cv::Rect& roi,
                            cv::Mat* left_rect, cv::Mat* right_rect);

/// A mask drawn on the unrectified left image, rectified like the left image (nearest
/// neighbour) and thresholded at half: CV_8U 0/255.
cv::Mat RectifyLeftMask(const StereoRig& rig, const cv::Mat& mask);

/// The bounding box, in the rectified left image, of a box drawn on the original left image.
cv::Rect RectifiedBox(const StereoRig& rig, const cv::Rect& box);

/// The inverse: the bounding box, in the original left image, of a box in the rectified one.
cv::Rect OriginalBox(const StereoRig& rig, const cv::Rect& rectified_box);

}  // namespace hedgefit::stereo
