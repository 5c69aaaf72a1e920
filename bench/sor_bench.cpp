// Statistical outlier removal: hedgefit vs PCL, side by side in one run.
// Usage: bench_statistical_outlier [CLOUD] [--repeats N] [--mean-k K] [--stddev-mul S]
// Prints the median wall time of each over N runs, their ratio, and whether the
// kept sets agree (PCL is run both as loaded, organised -> OrganizedNeighbor,
// and flattened -> FLANN k-d tree).

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "cloud/cloud_io.hpp"
#include "cloud/filters.hpp"
#include "cloud/pcl_adapter.hpp"

namespace {

template <class Fn>
double MedianMs(int repeats, Fn fn) {
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hedgefit::cloud;
  const char* data = std::getenv("HEDGEFIT_DATA_DIR");
  std::string path = std::string(data ? data : HEDGEFIT_DEFAULT_DATA_DIR) + "/pcl_test/table_scene_mug_stereo_textured.pcd";
  int repeats = 5, mean_k = 50;
  double stddev_mul = 1.0;
  bool only_hedgefit = false;  // for profiling hedgefit alone
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeats" && i + 1 < argc) repeats = std::atoi(argv[++i]);
    else if (a == "--mean-k" && i + 1 < argc) mean_k = std::atoi(argv[++i]);
    else if (a == "--stddev-mul" && i + 1 < argc) stddev_mul = std::atof(argv[++i]);
    else if (a == "--only-hedgefit") only_hedgefit = true;
    else path = a;
  }
  PointCloud cloud;
  try {
    cloud = ReadCloud(path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_statistical_outlier: %s\n", e.what());
    return 1;
  }
  QuietPcl();
  auto pcl_organised = ToPclXyz(cloud).makeShared();
  auto pcl_flat = ToPclXyz(cloud).makeShared();
  pcl_flat->width = static_cast<std::uint32_t>(pcl_flat->size());
  pcl_flat->height = 1;

  auto run_pcl = [&](const pcl::PointCloud<pcl::PointXYZ>::Ptr& in) {
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
    sor.setInputCloud(in);
    sor.setMeanK(mean_k);
    sor.setStddevMulThresh(stddev_mul);
    pcl::Indices kept;
    sor.filter(kept);
    return kept;
  };
  StatisticalOutlierOptions opt;
  opt.mean_k = mean_k;
  opt.stddev_mul = stddev_mul;

  pcl::Indices kept_org, kept_flat;
  std::vector<bool> ours;
  if (only_hedgefit) {
    opt.num_threads = 1;
    const double ms = MedianMs(repeats, [&] { ours = StatisticalInliers(cloud, opt); });
    std::printf("hedgefit StatisticalInliers (1 thread): %.1f ms\n", ms);
    return 0;
  }
  const double pcl_org_ms = MedianMs(repeats, [&] { kept_org = run_pcl(pcl_organised); });
  const double pcl_flat_ms = MedianMs(repeats, [&] { kept_flat = run_pcl(pcl_flat); });
  const double ours_ms = MedianMs(repeats, [&] { ours = StatisticalInliers(cloud, opt); });
  opt.num_threads = 1;
  const double ours_1t_ms = MedianMs(repeats, [&] { ours = StatisticalInliers(cloud, opt); });

  // PCL keeps non-finite points (their mean distance is set to 0); compare finite points only.
  auto differences = [&](const pcl::Indices& kept) {
    std::vector<bool> pcl_keep(cloud.size(), false);
    for (int i : kept) pcl_keep[static_cast<std::size_t>(i)] = true;
    std::size_t diff = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (IsFinite(cloud.points_mm[i]) && pcl_keep[i] != ours[i]) ++diff;
    }
    return diff;
  };
  std::size_t finite = cloud.size() - CountNonFinite(cloud);
  std::size_t kept = static_cast<std::size_t>(std::count(ours.begin(), ours.end(), true));
  std::printf("cloud: %s (%zu points, %zu finite), mean_k %d, stddev_mul %.2f, %d repeats, %u hardware threads\n",
              path.c_str(), cloud.size(), finite, mean_k, stddev_mul, repeats, std::thread::hardware_concurrency());
  std::printf("%-44s %10s %10s %14s\n", "implementation", "median ms", "speed-up", "kept-set diff");
  std::printf("%-44s %10.1f %10s %14zu\n", "PCL StatisticalOutlierRemoval (organised)", pcl_org_ms, "1.0x",
              differences(kept_org));
  std::printf("%-44s %10.1f %9.1fx %14zu\n", "PCL StatisticalOutlierRemoval (flat, FLANN)", pcl_flat_ms,
              pcl_org_ms / pcl_flat_ms, differences(kept_flat));
  std::printf("%-44s %10.1f %9.1fx %14s\n", "hedgefit StatisticalInliers (1 thread)", ours_1t_ms,
              pcl_org_ms / ours_1t_ms, "-");
  std::printf("%-44s %10.1f %9.1fx %14s\n", "hedgefit StatisticalInliers (all threads)", ours_ms,
              pcl_org_ms / ours_ms, "-");
  std::printf("kept %zu of %zu finite points\n", kept, finite);
  return 0;
}
