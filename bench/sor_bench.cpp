// Statistical outlier removal: hedgefit vs PCL, side by side in one run; then the filters of
// hedgefit's default cleaning (local outlier factor, spacing ratio) on the same cloud, timed
// against PCL's statistical filter, which is what a user would clean with instead.
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
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "bench/bench_util.hpp"
#include "cloud/cloud_io.hpp"
#include "cloud/filters.hpp"
#include "cloud/pcl_adapter.hpp"
#include "cloud/voxel_neighbours.hpp"

namespace {

// The default cleaning's filters for a stereo capture (filters.hedge_outlier on a cloud with a
// pixel_mm field and no hedge_id), timed against PCL's statistical filter (`pcl_ms`): their own
// decisions, so the removed count instead of agreement with PCL. This cloud has no footprints; a
// pixel's is Z / f, and the spacing ratio divides by its median, so Z stands for it.
void PrintCleaningFilters(const hedgefit::cloud::PointCloud& cloud, int repeats, double pcl_org_ms) {
  using namespace hedgefit::cloud;
  PointCloud stereo = cloud;
  std::vector<float> footprint(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) footprint[i] = cloud.points_mm[i].z();
  stereo.fields[kPixelSizeField] = footprint;
  std::printf("\n%-46s %10s %9s %15s\n", "default cleaning's filters", "median ms", "vs PCL", "removed");
  auto timed = [&](const std::string& name, const std::function<FilterResult()>& run) {
    FilterResult r;
    const double ms = hedgefit::bench::MedianMs(repeats, [&] { r = run(); });
    std::printf("%-46s %10.1f %8.2fx %15zu\n", name.c_str(), ms, pcl_org_ms / ms, r.removed);
  };
  for (int threads : {1, 0}) {
    LocalOutlierOptions lo;
    lo.num_threads = threads;
    SpacingOutlierOptions so;
    so.num_threads = threads;
    HedgeOutlierOptions ho;
    ho.num_threads = threads;
    const std::string suffix = threads == 1 ? " (1 thread)" : " (all threads)";
    timed("local outlier factor, k 20" + suffix, [&] { return LocalOutlierRemoval(stereo, lo); });
    timed("spacing ratio, mean_k 30" + suffix, [&] { return SpacingOutlierRemoval(stereo, so); });
    timed("hedge_outlier, both" + suffix, [&] { return HedgeOutlierRemoval(stereo, ho); });
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hedgefit::cloud;
  using namespace hedgefit::pipeline;
  const char* data = std::getenv("HEDGEFIT_DATA_DIR");
  std::string path = std::string(data ? data : HEDGEFIT_DEFAULT_DATA_DIR) + "/pcl_test/table_scene_mug_stereo_textured.pcd";
  int repeats = 5, mean_k = 50;
  double stddev_mul = 1.0;
  bool only_hedgefit = false;  // for profiling hedgefit alone
  const int done = hedgefit::bench::ParseOptions(
      argc, argv, "bench_statistical_outlier", "[CLOUD] [--repeats N] [--mean-k K] [--stddev-mul S] [--only-hedgefit]",
      [&](const std::string& a, const char* v) {
        if (a == "--repeats") repeats = std::max(1, std::atoi(v));
        else if (a == "--mean-k") mean_k = std::atoi(v);
        else if (a == "--stddev-mul") stddev_mul = std::atof(v);
        else return false;
        return true;
      },
      [&](const std::string& a) {
        if (a == "--only-hedgefit") only_hedgefit = true;
        else if (!a.empty() && a[0] != '-') path = a;
        else return false;
        return true;
      });
  if (done >= 0) return done;
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
  std::vector<bool> ours, ours_1t, ours_portable;
  if (only_hedgefit) {
    opt.num_threads = 1;
    const double ms = hedgefit::bench::MedianMs(repeats, [&] { ours = StatisticalInliers(cloud, opt); });
    std::printf("hedgefit StatisticalInliers (1 thread): %.1f ms\n", ms);
    return 0;
  }
  const double pcl_org_ms = hedgefit::bench::MedianMs(repeats, [&] { kept_org = run_pcl(pcl_organised); });
  const double pcl_flat_ms = hedgefit::bench::MedianMs(repeats, [&] { kept_flat = run_pcl(pcl_flat); });
  const double ours_ms = hedgefit::bench::MedianMs(repeats, [&] { ours = StatisticalInliers(cloud, opt); });
  opt.num_threads = 1;
  const double ours_1t_ms = hedgefit::bench::MedianMs(repeats, [&] { ours_1t = StatisticalInliers(cloud, opt); });
  opt.num_threads = 0;
  hedgefit::cloud::internal::ForcePortableKnn(true);  // what a CPU without AVX-512 runs
  const double portable_ms = hedgefit::bench::MedianMs(repeats, [&] { ours_portable = StatisticalInliers(cloud, opt); });
  hedgefit::cloud::internal::ForcePortableKnn(false);

  // Decisions that differ from PCL's (organised run), on finite points: PCL keeps
  // non-finite points (their mean distance is set to 0), hedgefit drops them.
  std::vector<bool> reference(cloud.size(), false);
  for (int i : kept_org) reference[static_cast<std::size_t>(i)] = true;
  auto differences = [&](const std::vector<bool>& flags) {
    std::size_t diff = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) diff += IsFinite(cloud.points_mm[i]) && flags[i] != reference[i];
    return diff;
  };
  std::vector<bool> flat(cloud.size(), false);
  for (int i : kept_flat) flat[static_cast<std::size_t>(i)] = true;
  const std::size_t finite = cloud.size() - CountNonFinite(cloud);
  const auto kept = static_cast<std::size_t>(std::count(ours.begin(), ours.end(), true));
  std::printf("cloud: %s (%zu points, %zu finite), mean_k %d, stddev_mul %.2f, median of %d runs, %u hardware threads\n",
              path.c_str(), cloud.size(), finite, mean_k, stddev_mul, repeats, std::thread::hardware_concurrency());
  std::printf("%-46s %10s %9s %15s\n", "implementation", "median ms", "vs PCL", "differs from PCL");
  auto row = [&](const char* name, double ms, std::size_t diff) {
    std::printf("%-46s %10.1f %8.1fx %15zu\n", name, ms, pcl_org_ms / ms, diff);
  };
  row("PCL StatisticalOutlierRemoval (organised)", pcl_org_ms, 0);
  row("PCL StatisticalOutlierRemoval (flat, FLANN)", pcl_flat_ms, differences(flat));
  row("hedgefit statistical filter (1 thread)", ours_1t_ms, differences(ours_1t));
  row("hedgefit statistical filter (all threads)", ours_ms, differences(ours));
  row("hedgefit, portable kernels (all threads)", portable_ms, differences(ours_portable));
  std::printf("kept %zu of %zu finite points\n", kept, finite);

  PrintCleaningFilters(cloud, repeats, pcl_org_ms);
  return 0;
}
