#include "measure/outline_start.hpp"

#include <vector>

#include "fitting/methods.hpp"
#include "pipeline/parallel.hpp"

namespace hedgefit::measure {

namespace {

// The most points the start's envelope is fitted to.
constexpr std::size_t kStartPoints = 2000;

}  // namespace

cloud::HedgeOutlines MeasureCloudOutlines(const cv::Mat& left_rect, const cv::Mat& right_rect, const cv::Mat& labels,
                                          const stereo::StereoRig& rig, const cloud::PointCloud& cloud, std::uint64_t seed,
                                          const std::optional<cv::Vec4d>& ground, std::map<int, stereo::OutlineStats>* stats) {
  const std::vector<cloud::HedgeGroup> groups = cloud::HedgeGroups(cloud);
  // The start: the envelope fitted to the front's points alone, per hedge (in parallel, gathered
  // in id order).
  std::vector<std::optional<Eigen::Vector4d>> spheres(groups.size());
  pipeline::ParallelFor(groups.size(), 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) {
      // Every n-th point up to kStartPoints: the start only places the edge search (+-6 px about
      // its outline), and a few thousand points pin a sphere to a fraction of a pixel.
      std::vector<std::size_t> some;
      const std::size_t every = groups[k].indices.size() / kStartPoints + 1;
      for (std::size_t i = 0; i < groups[k].indices.size(); i += every) some.push_back(groups[k].indices[i]);
      const std::vector<Eigen::Vector3d> pts = cloud::PointsAt(cloud, some);
      const std::vector<double> pixel_mm = cloud::FieldAt(cloud, cloud::kPixelSizeField, some);
      if (pts.size() < 50) continue;
      const fitting::SphereFitResult f = fitting::RunFitMethod("envelope", pts, {}, seed, groups[k].id >= 1, &pixel_mm);
      if (!f.converged) continue;
      const Eigen::Vector3d& c = f.sphere.center_mm;
      spheres[k] = Eigen::Vector4d(c.x(), c.y(), c.z(), f.sphere.radius_mm);
    }
  });
  std::map<int, Eigen::Vector4d> start;
  for (std::size_t k = 0; k < groups.size(); ++k) {
    if (spheres[k]) start[groups[k].id] = *spheres[k];
  }
  return stereo::MeasureOutlines(left_rect, right_rect, labels, rig, start, ground, stats);
}

}  // namespace hedgefit::measure
