#pragma once
// Neighbours on the image grid of a stereo capture's cloud: each point's pixel (the pixel_u and
// pixel_v fields stereo.reproject writes) is known, so its nearest points in 3-D are found among
// the points of the pixels about it, without a 3-D search. Private to cloud/.

#include <cstdint>
#include <optional>
#include <vector>

#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud::internal {

class PixelGrid {
 public:
  /// The grid of `cloud`'s finite points, or none when the cloud has no pixel fields (and
  /// pixel_mm, each point's footprint), holds
  /// several captures (a "capture" field: their pixels overlap), or two points share a pixel.
  static std::optional<PixelGrid> Of(const PointCloud& cloud);

  /// Half the window's side for k neighbours, in grid steps (a thinned capture's points lie every
  /// stride-th pixel): the smallest whose (2 h + 1)^2 - 1 others are twice k, so that the window
  /// reaches past the k-th nearest of a facing surface (h = 3, 48 others, for k = 20; h = 4 for 30).
  static int HalfFor(std::size_t k);

  /// The `k` nearest (3-D) points to point `i` among the finite points within HalfFor(k) grid steps of
  /// its pixel, itself excluded: cloud indices and squared distances, in no particular order but the
  /// k-th nearest last. Returns how many were found; fewer than `k` at a hole's or the hedge's edge.
  /// `*exact` says whether they are the k nearest of the whole cloud: every point outside the
  /// window lies on a ray at least (h + 1) grid steps away, so at least
  /// (h + 1) stride pixel_mm cos(angle off the optical axis) from point i (a pinhole's rays spread
  /// by cos^2 / f per pixel, and point i is Z / cos from the camera; 5 % off for lens distortion); when the k-th lies within
  /// that, none outside is nearer. On a surface that faces the camera this holds; on a slanted one
  /// (a limb, where 3-D neighbours lie further along the surface than the window reaches) it does
  /// not: the window is widened once (twice the half-width), then the caller searches in 3-D.
  /// `scratch` is reused between calls.
  std::size_t Nearest(std::size_t i, std::size_t k, std::uint32_t* indices, float* sq_distances,
                      std::vector<std::uint64_t>* scratch, bool* exact) const;

 private:
  PixelGrid(const PointCloud& cloud) : cloud_(&cloud) {}
  const PointCloud* cloud_;
  int u0_ = 0, v0_ = 0, stride_ = 1, cols_ = 0, rows_ = 0;
  std::vector<std::int32_t> cell_;  // cols_ x rows_: the point at each grid pixel, -1 none
  std::vector<std::int32_t> u_, v_;  // each point's grid column and row (-1: not finite)
  const std::vector<float>* pixel_mm_ = nullptr;
};

}  // namespace hedgefit::cloud::internal
