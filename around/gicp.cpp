// PCL's generalized ICP, alone in this file: GCC 12 reports a false -Warray-bounds inside
// Eigen's SSE loads as PCL's GICP instantiates them, and the flag that silences it (CMakeLists)
// should cover nothing else.
#include "around/gicp.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>

#include <cmath>

#include "around/poses.hpp"

namespace hedgefit::around {

namespace {

// Each capture's hedge points in the world through `pose`.
std::vector<Eigen::Vector3d> WorldPoints(const View& view, const Eigen::Isometry3d& pose) {
  std::vector<Eigen::Vector3d> out;
  for (const ViewHedge& h : view.hedges) {
    for (const auto& p : h.points_mm) out.push_back(pose * p);
  }
  return out;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const std::vector<Eigen::Vector3d>& pts, std::size_t step) {
  auto c = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (std::size_t i = 0; i < pts.size(); i += std::max<std::size_t>(1, step)) {
    c->push_back(pcl::PointXYZ(float(pts[i].x()), float(pts[i].y()), float(pts[i].z())));
  }
  return c;
}

// Generalized ICP of each capture's hedges against all the others', from the current poses;
// a capture's correction is kept when GICP converged and it is within the limits.
}  // namespace

void RefineByGicp(const std::vector<View>& views, const std::vector<bool>& used, int anchor, const FuseOptions& o,
                  std::vector<Eigen::Isometry3d>* poses, std::vector<double>* rms) {
  for (int v = 0; v < int(views.size()); ++v) {
    if (!used[std::size_t(v)] || v == anchor) continue;
    std::vector<Eigen::Vector3d> target;
    for (int w = 0; w < int(views.size()); ++w) {
      if (w == v || !used[std::size_t(w)]) continue;
      const auto pts = WorldPoints(views[std::size_t(w)], (*poses)[std::size_t(w)]);
      target.insert(target.end(), pts.begin(), pts.end());
    }
    const auto source_pts = WorldPoints(views[std::size_t(v)], (*poses)[std::size_t(v)]);
    if (source_pts.size() < 100 || target.size() < 100) continue;
    pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
    gicp.setInputSource(ToPcl(source_pts, source_pts.size() / 8000 + 1));
    gicp.setInputTarget(ToPcl(target, target.size() / 30000 + 1));
    gicp.setMaxCorrespondenceDistance(o.gicp_max_distance_mm);
    gicp.setMaximumIterations(50);
    gicp.setTransformationEpsilon(1e-8);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    gicp.align(aligned);
    if (!gicp.hasConverged()) continue;
    Eigen::Isometry3d delta(gicp.getFinalTransformation().cast<double>());
    if (RotationDeg(delta) > 2 || delta.translation().norm() > 50) continue;  // a jump, not a refinement
    (*poses)[std::size_t(v)] = delta * (*poses)[std::size_t(v)];
    (*rms)[std::size_t(v)] = std::sqrt(gicp.getFitnessScore(o.gicp_max_distance_mm * o.gicp_max_distance_mm));
  }
}


}  // namespace hedgefit::around
