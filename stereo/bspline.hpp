#pragma once
/// Cubic B-spline interpolation of images (Unser, Aldroubi & Eden 1991): a recursive
/// prefilter turns samples into spline coefficients, so the interpolant passes through
/// every sample, and its sub-pixel phase error is several times smaller than bilinear or
/// Keys-cubic interpolation's. That phase error is a sub-pixel shift that depends on where
/// a sample falls between pixels: in stereo, the two views fall differently, and the
/// difference is a disparity bias over whole regions.

#include <opencv2/core.hpp>

namespace hedgefit::stereo {

/// Spline coefficients of each row of a CV_32FC1 image (mirror boundaries).
cv::Mat BSplineCoefficientsAlongRows(const cv::Mat& image);

/// Spline coefficients in both directions of a CV_32FC1 image.
cv::Mat BSplineCoefficients2D(const cv::Mat& image);

/// Resamples an 8-bit image (1 or 3 channels) at the CV_32FC2 positions in `map_xy`
/// (the source's x, y per output pixel, as cv::remap's float maps) with cubic B-splines.
/// Positions outside the source give 0.
cv::Mat RemapBSpline(const cv::Mat& source, const cv::Mat& map_xy);

/// RemapBSpline written into `out`, a header of the map's size and the source's type (it may be
/// a region of a larger image): a region rectified again lands in place, with no image between.
void RemapBSplineInto(const cv::Mat& source, const cv::Mat& map_xy, cv::Mat out);

/// Tests only: the portable loops of RemapBSpline and the coefficient functions even where AVX-512
/// is available.
void ForcePortableRemap(bool portable);

/// floor(v) as an int without a library call (std::floor is one on baseline x86-64, and these
/// run per pixel and per sample); the same value for every |v| < 2^31.
inline int FloorInt(double v) {
  const int i = static_cast<int>(v);
  return i - (v < i);
}

/// The cubic B-spline weights at fractional position t of samples k-1, k, k+1, k+2, and
/// the weights of the derivative.
inline void BSplineWeights(double t, double w[4], double dw[4]) {
  const double t2 = t * t, t3 = t2 * t, u = 1 - t;
  constexpr double kSixth = 1.0 / 6;  // a product, not a division: this runs per pixel and sample
  w[0] = u * u * u * kSixth;
  w[1] = (3 * t3 - 6 * t2 + 4) * kSixth;
  w[2] = (-3 * t3 + 3 * t2 + 3 * t + 1) * kSixth;
  w[3] = t3 * kSixth;
  if (dw) {
    dw[0] = -0.5 * u * u;
    dw[1] = 1.5 * t2 - 2 * t;
    dw[2] = -1.5 * t2 + t + 0.5;
    dw[3] = 0.5 * t2;
  }
}

}  // namespace hedgefit::stereo
