// The hedge finder's speed beside what a PCL user would run instead, on the same simulated garden
// scan, in one run, one thread each: PCL's ApproximateProgressiveMorphologicalFilter (the ground;
// the exact ProgressiveMorphologicalFilter on a tenth of the cloud, as it is far slower) and
// EuclideanClusterExtraction (the objects, on the points hedgefit finds above the ground), against
// hedgefit's ground model and the whole of `find` (ground, objects, balls and their fits). Threads:
// both cores where each can use them (PCL's approximate PMF through OpenMP, hedgefit's fits'
// jackknife and likelihood); the ground models' other steps and both clusterings run on one.
// For topiary, a PCL user would then fit a sphere to each cluster by sample consensus
// (SACSegmentation, SACMODEL_SPHERE, with find's radius limits): timed too.
// Usage: bench_find [--sensor photogrammetry|terrestrial|lidar16|lidar32|aerial] [--garden N] [--repeats N]
//        bench_find --sensor lidar16 --station K [--garden N]   (the LiDAR parked at its K-th station
//        only, and find told where: the see-through check on each ball runs, and its time is shown)
//        bench_find --cloud FILE [--copies N] [--repeats N]   (a real cloud; units guessed as find guesses
//        them; --copies: the cloud N times side by side along x, every other copy turned half a turn
//        about the vertical, a stand-in for a larger garden of the same kind)

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/segmentation/approximate_progressive_morphological_filter.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/progressive_morphological_filter.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "bench/bench_util.hpp"
#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"
#include "cloud/pcl_adapter.hpp"
#include "fitting/methods.hpp"
#include "pipeline/print.hpp"
#include "scene/finder.hpp"
#include "scene/ground.hpp"
#include "sim/scan.hpp"

namespace {

// The cloud the bench runs on: a file (units guessed), or a simulated scan.
hedgefit::cloud::PointCloud BenchCloud(const std::string& file, int copies, const std::string& sensor, int garden,
                                       int station, std::vector<Eigen::Vector3d>* viewpoints) {
  using namespace hedgefit;
  if (!file.empty()) {
    cloud::PointCloud c = cloud::ReadCloud(file);
    const double scale = cloud::GuessScale(c);
    for (auto& p : c.points_mm) p *= float(scale);
    const std::size_t n = c.size();
    if (copies > 1) {
      // Up is z here (a map's cloud); each copy a metre beyond the last's far edge.
      Eigen::Vector3f lo = c.points_mm.front(), hi = lo;
      for (const auto& p : c.points_mm) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
      const Eigen::Vector3f mid = 0.5f * (lo + hi);
      const float step = hi.x() - lo.x() + 1000.f;
      c.points_mm.reserve(n * std::size_t(copies));
      for (int k = 1; k < copies; ++k) {
        for (std::size_t i = 0; i < n; ++i) {
          Eigen::Vector3f p = c.points_mm[i] - mid;
          if (k % 2 == 1) p.head<2>() = -p.head<2>();
          c.points_mm.push_back(p + mid + Eigen::Vector3f(step * float(k), 0, 0));
        }
      }
      c.colors.clear(), c.fields.clear();
      c.Flatten();
    }
    std::printf("cloud: %s%s, %zu points (scale %g, guessed); %u hardware threads, used where a step can\n", file.c_str(),
                copies > 1 ? pipeline::Format(" %d times side by side", copies).c_str() : "", c.size(), scale,
                std::thread::hardware_concurrency());
    return c;
  }
  sim::ScanOptions so;
  so.sensor = sim::ParseSensor(sensor);
  so.seed = std::uint64_t(garden);
  so.noise_mm = so.sensor == sim::Sensor::kTerrestrial ? 3 : (so.sensor == sim::Sensor::kLidar16 || so.sensor == sim::Sensor::kLidar32 ? 10 : 5);
  const sim::ScanScene scene = so.sensor == sim::Sensor::kAerial ? sim::RandomTopiaryBed(std::uint64_t(garden))
                                                                 : sim::RandomScanGarden(std::uint64_t(garden));
  std::string parked;
  if (station >= 0) {
    const std::vector<Eigen::Vector3d> stations = sim::ScanStations(scene, so);
    so.station = std::min(station, int(stations.size()) - 1);
    viewpoints->push_back(stations[std::size_t(so.station)]);
    parked = pipeline::Format(" from station %d of %zu only (find told where)", so.station, stations.size());
  }
  cloud::PointCloud c = sim::ScanGarden(scene, so);
  std::printf("cloud: simulated %s scan of %s %d%s, %zu points (mm); %u hardware threads, used where a step can\n",
              sensor.c_str(), so.sensor == sim::Sensor::kAerial ? "topiary bed" : "garden", garden, parked.c_str(),
              c.size(), std::thread::hardware_concurrency());
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hedgefit;
  std::string sensor = "photogrammetry", file;
  int garden = 1, repeats = 3, copies = 1, station = -1;
  const int done = bench::ParseOptionPairs(
      argc, argv, "bench_find", "[--cloud FILE [--copies N]] [--sensor S] [--garden N] [--station K] [--repeats N]",
      [&](const std::string& a, const char* v) {
        if (a == "--sensor") sensor = v;
        else if (a == "--cloud") file = v;
        else if (a == "--copies") copies = std::max(1, std::atoi(v));
        else if (a == "--garden") garden = std::atoi(v);
        else if (a == "--station") station = std::max(0, std::atoi(v));
        else if (a == "--repeats") repeats = std::max(1, std::atoi(v));
        else return false;
        return true;
      });
  if (done >= 0) return done;
  cloud::QuietPcl();
  fitting::QuietSolverWarnings();
  scene::FindOptions told;
  const cloud::PointCloud c = BenchCloud(file, copies, sensor, garden, station, &told.viewpoints_mm);

  // hedgefit: the ground alone, and the whole of find.
  const scene::GroundOptions go;
  std::vector<std::uint8_t> is_ground;
  const double ms_ground = bench::MedianMs(repeats, [&] { scene::FitGround(c.points_mm, go, &is_ground); });
  scene::FindResult found;
  const double ms_find = bench::MedianMs(repeats, [&] { found = scene::FindHedges(c, told); });

  // PCL: the approximate PMF with the same cell, window, slope and step.
  auto pcl_cloud = cloud::ToPclXyz(c).makeShared();
  pcl::Indices pcl_ground;
  const double ms_apmf = bench::MedianMs(repeats, [&] {
    pcl::ApproximateProgressiveMorphologicalFilter<pcl::PointXYZ> pmf;
    pmf.setInputCloud(pcl_cloud);
    pmf.setCellSize(float(go.cell_mm));
    pmf.setMaxWindowSize(int(go.max_window_mm / go.cell_mm));
    pmf.setSlope(float(go.slope));
    pmf.setInitialDistance(float(go.step_mm));
    pmf.setMaxDistance(3000.f);
    pmf.setNumberOfThreads(std::thread::hardware_concurrency());
    pmf.extract(pcl_ground);
  });
  // The exact PMF on every tenth point (its cost grows with points times window).
  auto tenth = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (std::size_t i = 0; i < pcl_cloud->size(); i += 10) tenth->push_back((*pcl_cloud)[i]);
  pcl::Indices pmf_ground;
  const double ms_pmf_tenth = bench::MedianMs(1, [&] {
    pcl::ProgressiveMorphologicalFilter<pcl::PointXYZ> pmf;
    pmf.setInputCloud(tenth);
    pmf.setMaxWindowSize(int(go.max_window_mm / go.cell_mm));
    pmf.setSlope(float(go.slope));
    pmf.setInitialDistance(float(go.step_mm));
    pmf.setMaxDistance(3000.f);
    pmf.setCellSize(float(go.cell_mm));
    pmf.extract(pmf_ground);
  });
  // PCL's Euclidean clustering of the points hedgefit puts above the ground, at find's gap.
  auto above = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (!is_ground[i]) above->push_back((*pcl_cloud)[i]);
  }
  std::vector<pcl::PointIndices> clusters;
  const double ms_euclid = bench::MedianMs(repeats, [&] {
    auto tree = pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
    tree->setInputCloud(above);
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
    ec.setClusterTolerance(150.0);
    ec.setMinClusterSize(30);
    ec.setSearchMethod(tree);
    ec.setInputCloud(above);
    clusters.clear();
    ec.extract(clusters);
  });
  // PCL: a sphere by sample consensus in each cluster, within find's radius limits.
  const scene::FindOptions fo;
  std::size_t spheres = 0;
  const double ms_sac = bench::MedianMs(repeats, [&] {
    spheres = 0;
    for (const auto& cluster : clusters) {
      auto part = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>(*above, cluster.indices);
      pcl::SACSegmentation<pcl::PointXYZ> sac;
      sac.setModelType(pcl::SACMODEL_SPHERE);
      sac.setMethodType(pcl::SAC_RANSAC);
      sac.setDistanceThreshold(30.0);
      sac.setRadiusLimits(fo.min_radius_mm, fo.max_radius_mm);
      sac.setMaxIterations(1000);
      sac.setInputCloud(part);
      pcl::PointIndices inliers;
      pcl::ModelCoefficients model;
      sac.segment(inliers, model);
      spheres += inliers.indices.empty() ? 0 : 1;
    }
  });
  std::printf("\n%-64s %10s %10s\n", "step", "ms", "points");
  std::printf("%-64s %10.0f %10zu\n", "hedgefit ground (scene::FitGround)", ms_ground, c.size());
  std::printf("%-64s %10.0f %10zu\n", "PCL ApproximateProgressiveMorphologicalFilter", ms_apmf, c.size());
  std::printf("%-64s %10.0f %10zu\n", "PCL ProgressiveMorphologicalFilter (every 10th point)", ms_pmf_tenth, tenth->size());
  std::printf("%-64s %10.0f %10zu\n", "PCL EuclideanClusterExtraction (above hedgefit's ground, 150 mm)", ms_euclid,
              above->size());
  std::printf("%-64s %10.0f %10zu\n", "PCL SACSegmentation sphere in each of those clusters", ms_sac, above->size());
  std::printf("%-64s %10.0f %10zu\n", "hedgefit find: ground, objects, balls, topiary and their fits", ms_find, c.size());
  std::printf("\nground points: hedgefit %zu, PCL approximate PMF %zu; objects: PCL's clusters %zu (a sphere in %zu), "
              "hedgefit's objects %zu (%zu balls, %zu clipped shapes in all)\n",
              found.ground_points, pcl_ground.size(), clusters.size(), spheres, found.objects.size(), found.Balls(),
              found.Topiary());
  std::printf("ratios: PCL approximate PMF / hedgefit ground %.1f; PCL PMF + Euclidean clusters + spheres / hedgefit find %.2f\n",
              ms_apmf / ms_ground, (ms_apmf + ms_euclid + ms_sac) / ms_find);
  // Where find's time went, step by step (its last run; FindResult::timings_ms).
  std::printf("hedgefit find's steps (last run, ms):");
  for (const auto& [step, ms] : found.timings_ms) std::printf(" %s %.0f;", step.c_str(), ms);
  std::printf("\n");
  return 0;
}
