// The hedge finder's speed beside what a PCL user would run instead, on the same simulated garden
// scan, in one run, one thread each: PCL's ApproximateProgressiveMorphologicalFilter (the ground;
// the exact ProgressiveMorphologicalFilter on a tenth of the cloud, as it is far slower) and
// EuclideanClusterExtraction (the objects, on the points hedgefit finds above the ground), against
// hedgefit's ground model and the whole of `find` (ground, objects, balls and their fits). Threads:
// both cores where each can use them (PCL's approximate PMF through OpenMP, hedgefit's fits'
// jackknife and likelihood); the ground models' other steps and both clusterings run on one.
// Usage: bench_find [--sensor photogrammetry|terrestrial|lidar16|lidar32] [--garden N] [--repeats N]

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/segmentation/approximate_progressive_morphological_filter.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/progressive_morphological_filter.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "bench/bench_util.hpp"
#include "cloud/pcl_adapter.hpp"
#include "fitting/methods.hpp"
#include "scene/finder.hpp"
#include "scene/ground.hpp"
#include "sim/scan.hpp"

int main(int argc, char** argv) {
  using namespace hedgefit;
  std::string sensor = "photogrammetry";
  int garden = 1, repeats = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--sensor" && i + 1 < argc) sensor = argv[++i];
    else if (a == "--garden" && i + 1 < argc) garden = std::atoi(argv[++i]);
    else if (a == "--repeats" && i + 1 < argc) repeats = std::max(1, std::atoi(argv[++i]));
  }
  cloud::QuietPcl();
  fitting::QuietSolverWarnings();
  sim::ScanOptions so;
  so.sensor = sim::ParseSensor(sensor);
  so.seed = std::uint64_t(garden);
  so.noise_mm = so.sensor == sim::Sensor::kTerrestrial ? 3 : (so.sensor == sim::Sensor::kPhotogrammetry ? 5 : 10);
  const sim::ScanScene scene = sim::RandomScanGarden(std::uint64_t(garden));
  const cloud::PointCloud c = sim::ScanGarden(scene, so);
  std::printf("cloud: simulated %s scan of garden %d, %zu points (mm); %u hardware threads, used where a step can\n",
              sensor.c_str(), garden, c.size(), std::thread::hardware_concurrency());

  // hedgefit: the ground alone, and the whole of find.
  const scene::GroundOptions go;
  std::vector<std::uint8_t> is_ground;
  const double ms_ground = bench::MedianMs(repeats, [&] { scene::FitGround(c.points_mm, go, &is_ground); });
  scene::FindResult found;
  const double ms_find = bench::MedianMs(repeats, [&] { found = scene::FindHedges(c); });

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
  std::printf("\n%-64s %10s %10s\n", "step", "ms", "points");
  std::printf("%-64s %10.0f %10zu\n", "hedgefit ground (scene::FitGround)", ms_ground, c.size());
  std::printf("%-64s %10.0f %10zu\n", "PCL ApproximateProgressiveMorphologicalFilter", ms_apmf, c.size());
  std::printf("%-64s %10.0f %10zu\n", "PCL ProgressiveMorphologicalFilter (every 10th point)", ms_pmf_tenth, tenth->size());
  std::printf("%-64s %10.0f %10zu\n", "PCL EuclideanClusterExtraction (above hedgefit's ground, 150 mm)", ms_euclid,
              above->size());
  std::printf("%-64s %10.0f %10zu\n", "hedgefit find: ground, objects, balls and their fits", ms_find, c.size());
  std::printf("\nground points: hedgefit %zu, PCL approximate PMF %zu; objects: PCL's clusters %zu, hedgefit's objects %zu "
              "(%zu balls)\n",
              found.ground_points, pcl_ground.size(), clusters.size(), found.objects.size(), found.Balls());
  std::printf("ratios: PCL approximate PMF / hedgefit ground %.1f; PCL PMF + Euclidean clusters / hedgefit find %.2f\n",
              ms_apmf / ms_ground, (ms_apmf + ms_euclid) / ms_find);
  return 0;
}
