#include "fitting/ransac_fit.hpp"

#include <pcl/console/print.h>
#include <pcl/search/kdtree.h>
#include <pcl/sample_consensus/lmeds.h>
#include <pcl/sample_consensus/mlesac.h>
#include <pcl/sample_consensus/msac.h>
#include <pcl/sample_consensus/prosac.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_sphere.h>

#include <chrono>
#include <cmath>
#include <memory>

#include "pipeline/error.hpp"

namespace hedgefit::fitting {

namespace {

// PCL seeds its sampler with a constant (or the clock); this exposes the seed.
class SeededSphereModel : public pcl::SampleConsensusModelSphere<pcl::PointXYZ> {
 public:
  SeededSphereModel(const PointCloudConstPtr& cloud, std::uint64_t seed)
      : pcl::SampleConsensusModelSphere<pcl::PointXYZ>(cloud, false) {
    rng_alg_.seed(static_cast<unsigned>(seed ^ (seed >> 32)));
  }
};

std::unique_ptr<pcl::SampleConsensus<pcl::PointXYZ>> MakeEstimator(
    ConsensusMethod method, const pcl::SampleConsensusModel<pcl::PointXYZ>::Ptr& model, double threshold) {
  switch (method) {
    case ConsensusMethod::kRansac: return std::make_unique<pcl::RandomSampleConsensus<pcl::PointXYZ>>(model, threshold);
    case ConsensusMethod::kMsac: return std::make_unique<pcl::MEstimatorSampleConsensus<pcl::PointXYZ>>(model, threshold);
    case ConsensusMethod::kLmeds: return std::make_unique<pcl::LeastMedianSquares<pcl::PointXYZ>>(model, threshold);
    case ConsensusMethod::kProsac: return std::make_unique<pcl::ProgressiveSampleConsensus<pcl::PointXYZ>>(model, threshold);
    case ConsensusMethod::kMlesac:
      return std::make_unique<pcl::MaximumLikelihoodSampleConsensus<pcl::PointXYZ>>(model, threshold);
  }
  return nullptr;
}

}  // namespace

const std::vector<std::pair<std::string, ConsensusMethod>>& ConsensusNames() {
  static const std::vector<std::pair<std::string, ConsensusMethod>> names{
      {"ransac", ConsensusMethod::kRansac}, {"msac", ConsensusMethod::kMsac}, {"lmeds", ConsensusMethod::kLmeds},
      {"prosac", ConsensusMethod::kProsac}, {"mlesac", ConsensusMethod::kMlesac}};
  return names;
}

const char* ConsensusName(ConsensusMethod method) { return pipeline::EnumName(ConsensusNames(), method); }

const pipeline::OptionTable<RansacFitOptions>& RansacFitOptions::Table() {
  using O = RansacFitOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .AddEnum("method", &O::method, ConsensusNames(), "estimator")
          .Add("distance_threshold", &O::distance_threshold_mm, "inlier band around the sphere", "mm").Min(1e-9)
          .Add("max_iterations", &O::max_iterations, "samples drawn at most", "samples").Range(1, 100000000)
          .Add("probability", &O::probability, "chance of one outlier-free sample").Range(1e-6, 0.999999)
          .Add("min_radius", &O::min_radius_mm, "smallest sphere accepted", "mm").Min(0)
          .Add("max_radius", &O::max_radius_mm, "largest sphere accepted", "mm").Min(0)
          .Add("optimize", &O::optimize, "refine on the inliers")
          .Add("sample_radius", &O::sample_radius_mm, "draw each sample within this distance (0 = anywhere)", "mm")
          .Min(0);
  return table;
}

void RansacFitOptions::Check() const {
  Table().Validate(*this);
  if (!(max_radius_mm > min_radius_mm)) {
    throw Error("option 'min_radius'/'max_radius': need min_radius < max_radius (mm)");
  }
}

SphereFitResult FitSphereRansac(const std::vector<Eigen::Vector3d>& points_mm, const RansacFitOptions& options,
                                std::vector<std::size_t>* inlier_indices) {
  options.Check();
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(); };
  SphereFitResult r;
  r.method = ConsensusName(options.method);
  r.points_used = points_mm.size();
  if (auto reason = DegeneracyReason(points_mm)) {
    r.message = *reason;
    r.wall_ms = elapsed();
    return r;
  }
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  // PCL computes in float: hand it centred coordinates so a sphere 10 m away keeps its digits.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_mm) mean += p;
  mean /= double(points_mm.size());
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->resize(points_mm.size());
  for (std::size_t i = 0; i < points_mm.size(); ++i) {
    const Eigen::Vector3f q = (points_mm[i] - mean).cast<float>();
    (*cloud)[i] = pcl::PointXYZ(q.x(), q.y(), q.z());
  }
  auto model = std::make_shared<SeededSphereModel>(cloud, options.seed);
  model->setRadiusLimits(options.min_radius_mm, options.max_radius_mm);
  if (options.sample_radius_mm > 0) {
    auto search = std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
    search->setInputCloud(cloud);
    model->setSamplesMaxDist(options.sample_radius_mm, search);
  }
  auto sac = MakeEstimator(options.method, model, options.distance_threshold_mm);
  sac->setMaxIterations(options.max_iterations);
  sac->setProbability(options.probability);
  if (!sac->computeModel()) {
    r.message = "no sphere within the radius limits found support in " + std::to_string(options.max_iterations) +
                " samples; widen distance_threshold or the radius limits";
    r.wall_ms = elapsed();
    return r;
  }
  // PCL 1.13 does not expose how many samples it drew; iterations stays 0.
  pcl::Indices inliers;
  sac->getInliers(inliers);
  Eigen::VectorXf coeffs;
  sac->getModelCoefficients(coeffs);
  if (options.optimize) {
    // PCL refines once, on the consensus set of the best sample. When that sample is off
    // by more than the band, its set is truncated on one side and the refit inherits the
    // bias; so refit and reselect until the set stops changing (a few rounds at most).
    for (int round = 0; round < 6 && inliers.size() >= 4; ++round) {
      Eigen::VectorXf refined;
      model->optimizeModelCoefficients(inliers, coeffs, refined);
      if (refined.size() != 4 || !refined.allFinite()) break;
      coeffs = refined;
      pcl::Indices again;
      model->selectWithinDistance(coeffs, options.distance_threshold_mm, again);
      // Stable: the same set, or one that changed by less than 0.1 % (points on the band's edge).
      const auto change = static_cast<std::size_t>(
          std::abs(static_cast<long long>(again.size()) - static_cast<long long>(inliers.size())));
      const bool stable = again == inliers || change * 1000 < inliers.size();
      inliers.swap(again);
      if (stable) break;
    }
  }
  r.sphere.center_mm = coeffs.head<3>().cast<double>() + mean;
  r.sphere.radius_mm = static_cast<double>(coeffs[3]);
  std::vector<Eigen::Vector3d> in;
  in.reserve(inliers.size());
  for (int i : inliers) in.push_back(points_mm[static_cast<std::size_t>(i)]);
  if (inlier_indices) inlier_indices->assign(inliers.begin(), inliers.end());
  r.inliers = in.size();
  r.rms_mm = RmsResidual(in, r.sphere);
  r.converged = in.size() >= 4;
  // PCL's refinement does not enforce the radius limits: check them here.
  if (r.sphere.radius_mm < options.min_radius_mm || r.sphere.radius_mm > options.max_radius_mm) {
    r.converged = false;
    r.message = "refined radius " + std::to_string(r.sphere.radius_mm) + " mm is outside the limits [" +
                std::to_string(options.min_radius_mm) + ", " + std::to_string(options.max_radius_mm) + "] mm";
  }
  r.wall_ms = elapsed();
  return r;
}

}  // namespace hedgefit::fitting
