#pragma once
// Private to cloud/.

namespace hedgefit::cloud::internal {

/// A squared distance summed as nanoflann's L2_Simple_Adaptor and FLANN's L2 sum it: x, y and z
/// in turn, each a product then an add, never fused (this project builds for baseline x86-64,
/// which has no fused multiply-add). The searches that stand in for a k-d tree (PixelGrid, the
/// voxel grid's portable scan, the outlier factor's scan of a few points) use it, so their
/// distances, and so their ties, are the tree's to the bit.
inline float SquaredDistanceAsTrees(float dx, float dy, float dz) {
  float acc = dx * dx;
  acc += dy * dy;
  acc += dz * dz;
  return acc;
}

}  // namespace hedgefit::cloud::internal
