#pragma once
/// The operator's picture: the (rectified) left image with the hedge's mask outline and each
/// fitted sphere's projected outline, centre, label and radius, so a glance says whether the
/// fit sits on the hedge.

#include <opencv2/core.hpp>

#include <vector>

#include "fitting/sphere_fit.hpp"
#include "render/render.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::render {

/// The silhouette of `sphere` (in the unrectified left camera frame, mm) in the rectified left
/// image: the circle where the left camera's rays graze the sphere, projected with R1 and P1,
/// `n` points (px). Empty when the camera is inside the sphere or the sphere is behind it.
std::vector<cv::Point2d> SphereOutline(const stereo::StereoRig& rig, const fitting::Sphere& sphere, int n = 180);

/// Draws on a copy of `left_rect` (BGR or grey): the outline of `mask` (CV_8U, same size; may be
/// empty) in magenta, and for each sphere its outline and centre in the overlay colour of its
/// index (OverlayColor; the truth in black), with a legend line "id label r R mm c (x, y, z) mm".
/// `crop`: only the spheres and a quarter of their size around them.
cv::Mat DrawOverlay(const cv::Mat& left_rect, const stereo::StereoRig& rig, const cv::Mat& mask,
                    const std::vector<SphereOverlay>& spheres, int line_px = 2, bool crop = false);

}  // namespace hedgefit::render
