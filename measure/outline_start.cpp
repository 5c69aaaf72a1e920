#include "measure/outline_start.hpp"

#include <vector>

#include "fitting/methods.hpp"
#include "pipeline/parallel.hpp"

namespace hedgefit::measure {

cloud::HedgeOutlines MeasureCloudOutlines(const cv::Mat& left_rect, const cv::Mat& right_rect, const cv::Mat& labels,
                                          const stereo::StereoRig& rig, const cloud::PointCloud& cloud, std::uint64_t seed,
                                          const std::optional<cv::Vec4d>& ground, std::map<int, stereo::OutlineStats>* stats) {
  const std::vector<cloud::HedgeGroup> groups = cloud::HedgeGroups(cloud);
  // The start: the envelope fitted to the front's points alone, per hedge (in parallel, gathered
  // in id order).
  std::vector<std::optional<Eigen::Vector4d>> spheres(groups.size());
  pipeline::ParallelFor(groups.size(), 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) {
      const std::vector<Eigen::Vector3d> pts = cloud::PointsAt(cloud, groups[k].indices);
      const std::vector<double> pixel_mm = cloud::FieldAt(cloud, cloud::kPixelSizeField, groups[k].indices);
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
