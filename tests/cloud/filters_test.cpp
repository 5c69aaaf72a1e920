// Cleaning filters checked against PCL (same kept set) and brute force, on synthetic
// clouds with known structure and on PCL's real stereo test cloud.

#include "cloud/filters.hpp"

#include <gtest/gtest.h>
#include <pcl/filters/radius_outlier_removal.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>

#include <random>

#include "cloud/cloud_io.hpp"
#include "cloud/error.hpp"
#include "cloud/pcl_adapter.hpp"
#include "cloud/voxel_neighbours.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::cloud {
namespace {

// A noisy sphere cap (dense), a plane, sparse outliers, exact duplicates (ties in
// neighbour distances) and NaNs: every case the kNN has to get right.
PointCloud MixedCloud(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> noise(0.f, 2.f);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const float kind = u(rng);
    if (kind < 0.2f) {  // plane
      c.points_mm.emplace_back(800 * u(rng), 300.f + noise(rng), 2300 + 800 * u(rng));
    } else if (kind < 0.95f) {  // sphere cap of 300 mm at 2300 mm
      Eigen::Vector3f d(u(rng), u(rng), -std::abs(u(rng)) - 0.3f);
      c.points_mm.push_back(Eigen::Vector3f(0, 0, 2300) + d.normalized() * (300.f + noise(rng)));
    } else {  // outliers
      c.points_mm.emplace_back(1500 * u(rng), 1500 * u(rng), 2300 + 1500 * u(rng));
    }
  }
  for (std::size_t i = 0; i < n / 50; ++i) c.points_mm[i + n / 2] = c.points_mm[i];  // duplicates
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < n; i += 97) c.points_mm[i] = Eigen::Vector3f(nan, 0, 0);
  c.Flatten();
  return c;
}

// PCL's decision as a per-point flag. PCL keeps NaN points (their mean distance is
// set to 0); hedgefit drops them, so only finite points are compared.
std::vector<bool> PclSor(const PointCloud& cloud, int k, double mul, bool organised) {
  auto pc = ToPclXyz(cloud).makeShared();
  if (!organised) {
    pc->width = static_cast<std::uint32_t>(pc->size());
    pc->height = 1;
  }
  pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
  sor.setInputCloud(pc);
  sor.setMeanK(k);
  sor.setStddevMulThresh(mul);
  pcl::Indices kept;
  sor.filter(kept);
  std::vector<bool> flags(cloud.size(), false);
  for (int i : kept) flags[static_cast<std::size_t>(i)] = true;
  return flags;
}

std::size_t FiniteDifferences(const PointCloud& cloud, const std::vector<bool>& a, const std::vector<bool>& b) {
  std::size_t diff = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) diff += IsFinite(cloud.points_mm[i]) && a[i] != b[i];
  return diff;
}

struct SorCase {
  int mean_k;
  double stddev_mul;
  int threads;
};

void PrintTo(const SorCase& c, std::ostream* os) {
  *os << "k" << c.mean_k << "_mul" << c.stddev_mul << "_threads" << c.threads;
}

class StatisticalVsPcl : public ::testing::TestWithParam<SorCase> {};

TEST_P(StatisticalVsPcl, SameKeptSetOnSyntheticCloud) {
  QuietPcl();
  const SorCase c = GetParam();
  const PointCloud cloud = MixedCloud(20000, 99);
  StatisticalOutlierOptions o;
  o.mean_k = c.mean_k;
  o.stddev_mul = c.stddev_mul;
  o.num_threads = c.threads;
  const std::vector<bool> ours = StatisticalInliers(cloud, o);
  const std::vector<bool> pcl = PclSor(cloud, c.mean_k, c.stddev_mul, false);
  EXPECT_EQ(FiniteDifferences(cloud, ours, pcl), 0u);
  // The filter must actually remove something for the comparison to mean anything.
  const auto kept = static_cast<std::size_t>(std::count(ours.begin(), ours.end(), true));
  EXPECT_LT(kept, cloud.size() - CountNonFinite(cloud));
  EXPECT_GT(kept, cloud.size() / 2);
}

INSTANTIATE_TEST_SUITE_P(Parameters, StatisticalVsPcl,
                         ::testing::Values(SorCase{1, 1.0, 1}, SorCase{8, 0.5, 2}, SorCase{50, 1.0, 0},
                                           SorCase{50, 2.0, 1}, SorCase{200, 1.0, 2}));

// The portable inner loops (used where the CPU lacks AVX-512) decide the same as PCL too.
TEST(Statistical, PortableKernelsMatchPcl) {
  QuietPcl();
  const PointCloud cloud = MixedCloud(20000, 17);
  StatisticalOutlierOptions o;
  o.mean_k = 30;
  internal::ForcePortableKnn(true);
  const std::vector<bool> portable = StatisticalInliers(cloud, o);
  internal::ForcePortableKnn(false);
  EXPECT_EQ(FiniteDifferences(cloud, portable, PclSor(cloud, 30, 1.0, false)), 0u);
  EXPECT_EQ(FiniteDifferences(cloud, portable, StatisticalInliers(cloud, o)), 0u);
}

TEST(Statistical, CloudSmallerThanKMatchesPcl) {
  QuietPcl();
  PointCloud cloud = MixedCloud(40, 3);
  StatisticalOutlierOptions o;
  o.mean_k = 60;  // more neighbours than points: PCL still divides by mean_k
  EXPECT_EQ(FiniteDifferences(cloud, StatisticalInliers(cloud, o), PclSor(cloud, 60, 1.0, false)), 0u);
}

TEST(Statistical, RemovesInjectedOutliersAndKeepsOrganisation) {
  // A 100 x 100 organised grid plane at 2 m with 1 mm spacing, plus 20 points
  // lifted 200 mm off it: those 20 are exactly the outliers.
  PointCloud c;
  c.width = 100;
  c.height = 100;
  for (int r = 0; r < 100; ++r)
    for (int q = 0; q < 100; ++q) c.points_mm.emplace_back(float(q), float(r), 2000.f);
  for (int i = 0; i < 20; ++i) c.points_mm[static_cast<std::size_t>(i * 487)].z() = 1800.f + float(i);
  StatisticalOutlierOptions o;
  o.mean_k = 8;
  o.keep_organized = true;
  const FilterResult r = StatisticalOutlierRemoval(c, o);
  EXPECT_EQ(r.removed, 20u);
  EXPECT_EQ(r.kept, 10000u - 20u);
  EXPECT_EQ(r.cloud.width, 100u);
  EXPECT_EQ(r.cloud.height, 100u);
  for (int i = 0; i < 20; ++i) EXPECT_FALSE(IsFinite(r.cloud.points_mm[static_cast<std::size_t>(i * 487)]));
  o.keep_organized = false;
  EXPECT_EQ(StatisticalOutlierRemoval(c, o).cloud.size(), 10000u - 20u);
}

TEST(Statistical, RealStereoCloudSameKeptSetAsPcl) {
  HEDGEFIT_REQUIRE_DATA("pcl_test/table_scene_mug_stereo_textured.pcd");
  QuietPcl();
  const PointCloud cloud = ReadCloud(testing::DataPath("pcl_test/table_scene_mug_stereo_textured.pcd"));
  StatisticalOutlierOptions o;  // mean_k 50, stddev_mul 1: PCL's tutorial settings
  const std::vector<bool> ours = StatisticalInliers(cloud, o);
  // As loaded (organised: PCL uses OrganizedNeighbor) and flattened (PCL uses FLANN).
  EXPECT_EQ(FiniteDifferences(cloud, ours, PclSor(cloud, 50, 1.0, true)), 0u);
  EXPECT_EQ(FiniteDifferences(cloud, ours, PclSor(cloud, 50, 1.0, false)), 0u);
  const auto kept = static_cast<std::size_t>(std::count(ours.begin(), ours.end(), true));
  EXPECT_GT(kept, 150000u);
  EXPECT_LT(kept, 200000u);
}

TEST(Radius, SameKeptSetAsPcl) {
  QuietPcl();
  const PointCloud cloud = MixedCloud(15000, 5);
  for (auto [radius, min_n] : {std::pair{10.0, 3}, std::pair{25.0, 12}, std::pair{4.0, 1}}) {
    RadiusOutlierOptions o;
    o.radius_mm = radius;
    o.min_neighbours = min_n;
    const FilterResult ours = RadiusOutlierRemoval(cloud, o);
    // Debian's PCL asserts on NaN queries in radiusSearch: give it the finite points only.
    auto pc = ToPclXyz(RemoveNonFinite(cloud).cloud).makeShared();
    pcl::RadiusOutlierRemoval<pcl::PointXYZ> ror;
    ror.setInputCloud(pc);
    ror.setRadiusSearch(radius);
    ror.setMinNeighborsInRadius(min_n);
    pcl::Indices kept;
    ror.filter(kept);
    EXPECT_EQ(ours.kept, kept.size()) << "radius " << radius;
    EXPECT_GT(ours.removed, 0u) << "radius " << radius;
    EXPECT_EQ(ours.kept + ours.removed + ours.nonfinite, cloud.size());
  }
}

TEST(VoxelGrid, CentroidsMatchPcl) {
  QuietPcl();
  PointCloud cloud = MixedCloud(20000, 8);
  cloud = RemoveNonFinite(cloud).cloud;
  VoxelGridOptions o;
  o.leaf_mm = 20.0;
  const FilterResult ours = VoxelGrid(cloud, o);
  auto pc = ToPclXyz(cloud).makeShared();
  pcl::VoxelGrid<pcl::PointXYZ> vg;
  vg.setInputCloud(pc);
  vg.setLeafSize(20.f, 20.f, 20.f);
  pcl::PointCloud<pcl::PointXYZ> pcl_out;
  vg.filter(pcl_out);
  ASSERT_EQ(ours.cloud.size(), pcl_out.size());
  // Same voxels: match each PCL centroid to ours by voxel index; centroids agree to
  // float rounding of a mean of points ~3000 mm from the origin (~1e-3 mm).
  std::map<std::tuple<int, int, int>, Eigen::Vector3f> by_voxel;
  for (const auto& p : ours.cloud.points_mm) {
    by_voxel[{int(std::floor(p.x() / 20)), int(std::floor(p.y() / 20)), int(std::floor(p.z() / 20))}] = p;
  }
  for (const auto& q : pcl_out) {
    auto it = by_voxel.find({int(std::floor(q.x / 20)), int(std::floor(q.y / 20)), int(std::floor(q.z / 20))});
    ASSERT_NE(it, by_voxel.end());
    EXPECT_NEAR((it->second - Eigen::Vector3f(q.x, q.y, q.z)).norm(), 0.f, 2e-3f);
  }
  EXPECT_EQ(ours.kept, ours.cloud.size());
  EXPECT_EQ(ours.kept + ours.removed, cloud.size());
}

TEST(VoxelGrid, AveragesColourAndRejectsOverflowingLeaf) {
  PointCloud c;
  c.points_mm = {{0.1f, 0.1f, 0.1f}, {0.3f, 0.3f, 0.3f}, {5.f, 5.f, 5.f}};
  c.colors = {{0, 100, 200}, {100, 200, 0}, {9, 9, 9}};
  c.Flatten();
  VoxelGridOptions o;
  o.leaf_mm = 1.0;
  const FilterResult r = VoxelGrid(c, o);
  ASSERT_EQ(r.cloud.size(), 2u);
  EXPECT_EQ(r.cloud.colors[0], (Rgb{50, 150, 100}));
  EXPECT_NEAR(r.cloud.points_mm[0].x(), 0.2f, 1e-6f);
  o.leaf_mm = 1e-6;  // 5 mm / 1e-6 mm = 5e6 voxels along an axis: more than 2^21
  EXPECT_THROW(VoxelGrid(c, o), Error);
}

TEST(CropAndPassThrough, MatchBruteForce) {
  const PointCloud cloud = MixedCloud(5000, 4);
  CropBoxOptions box;
  box.min_mm = {-200, -200, 2000};
  box.max_mm = {200, 250, 2300};
  std::size_t expected = 0;
  for (const auto& p : cloud.points_mm) {
    expected += IsFinite(p) && (p.array() >= box.min_mm.array()).all() && (p.array() <= box.max_mm.array()).all();
  }
  const FilterResult in = CropBox(cloud, box);
  EXPECT_EQ(in.kept, expected);
  EXPECT_GT(expected, 100u);
  box.negative = true;
  EXPECT_EQ(CropBox(cloud, box).kept, cloud.size() - CountNonFinite(cloud) - expected);

  PassThroughOptions pt;
  pt.field = "z";
  pt.min = 2000;
  pt.max = 2300;
  std::size_t z_expected = 0;
  for (const auto& p : cloud.points_mm) z_expected += IsFinite(p) && p.z() >= 2000 && p.z() <= 2300;
  EXPECT_EQ(PassThrough(cloud, pt).kept, z_expected);
  pt.field = "intensity";
  EXPECT_THROW(PassThrough(cloud, pt), Error);
  box.negative = false;
  box.min_mm.x() = 500;  // min above max
  EXPECT_THROW(CropBox(cloud, box), Error);
}

TEST(NonFinite, DropsAndCounts) {
  const PointCloud cloud = MixedCloud(1000, 2);
  const FilterResult r = RemoveNonFinite(cloud);
  EXPECT_EQ(r.nonfinite, CountNonFinite(cloud));
  EXPECT_EQ(r.nonfinite, 11u);  // every 97th of 1000 points
  EXPECT_EQ(r.cloud.size(), 1000u - 11u);
  EXPECT_EQ(CountNonFinite(r.cloud), 0u);
}

}  // namespace
}  // namespace hedgefit::cloud
