// Cleaning filters checked against PCL (same kept set) and brute force, on synthetic
// clouds with known structure and on PCL's real stereo test cloud.

#include "cloud/filters.hpp"
#include "cloud/cleaning.hpp"

#include <gtest/gtest.h>
#include <pcl/filters/radius_outlier_removal.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>

#include <numeric>
#include <random>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "cloud/pcl_adapter.hpp"
#include "pipeline/pipeline.hpp"
#include "cloud/voxel_neighbours.hpp"
#include "cloud/pixel_grid.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::cloud {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
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

// The local outlier factor by its definition (Breunig et al. 2000, with exactly k neighbours as
// scikit-learn takes them), by brute force over every pair.
std::vector<double> BruteForceLof(const PointCloud& cloud, int k) {
  std::vector<std::size_t> fin;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (IsFinite(cloud.points_mm[i])) fin.push_back(i);
  }
  const std::size_t n = fin.size();
  std::vector<std::vector<std::pair<double, std::size_t>>> nn(n);
  std::vector<double> kdist(n), lrd(n);
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = 0; b < n; ++b) {
      if (a != b) nn[a].push_back({(cloud.points_mm[fin[a]] - cloud.points_mm[fin[b]]).cast<double>().norm(), b});
    }
    std::sort(nn[a].begin(), nn[a].end());
    nn[a].resize(std::size_t(k));
    kdist[a] = nn[a].back().first;
  }
  for (std::size_t a = 0; a < n; ++a) {
    double reach = 0;
    for (const auto& [d, b] : nn[a]) reach += std::max(kdist[b], d);
    lrd[a] = 1.0 / std::max(reach / k, 1e-9);
  }
  std::vector<double> lof(cloud.size(), 0.0);
  for (std::size_t a = 0; a < n; ++a) {
    double sum = 0;
    for (const auto& nb : nn[a]) sum += lrd[nb.second];
    lof[fin[a]] = sum / k / lrd[a];
  }
  return lof;
}

TEST(LocalOutlier, FactorsMatchTheDefinition) {
  // Sphere cap, plane, scattered outliers, exact duplicates and NaNs (MixedCloud).
  const PointCloud cloud = MixedCloud(600, 11);
  for (int k : {5, 20}) {
    const std::vector<float> ours = LocalOutlierFactors(cloud, k, 2);
    const std::vector<double> truth = BruteForceLof(cloud, k);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      // Distances are float in the k-d tree and double here: agreement to 1e-4 relative.
      EXPECT_NEAR(ours[i], truth[i], 1e-4 * std::max(1.0, truth[i])) << "point " << i << " k " << k;
    }
  }
}

TEST(LocalOutlier, AFewPointsScannedGetTheKdTreesFactorsToTheBit) {
  // A cloud of 90 points leaves every point to the scan (fewer than 96 need a 3-D search); the
  // same 90 with 400 points 100 m away leave all 490 to the k-d tree. The far points are nobody's
  // neighbour among the 90, so each of the 90 has the same neighbours, distances and factor both
  // ways: bit for bit, as the scan sums each distance as the tree does. (Summing z first instead
  // of x fails it. Ties are ordered differently by the two - by position in the scan, by visit in
  // the tree - and the order within a list barely shows in the double sums: swapping every list's
  // 2nd and 3rd neighbours did not fail it.)
  for (std::uint64_t seed : {3u, 4u, 5u}) {
    const PointCloud few = MixedCloud(90, seed);
    PointCloud many = few;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> u(-50.f, 50.f);
    for (int i = 0; i < 400; ++i) many.points_mm.emplace_back(1e5f + u(rng), u(rng), 2300.f + u(rng));
    many.Flatten();
    for (int k : {5, 20}) {
      const std::vector<float> scanned = LocalOutlierFactors(few, k, 2), tree = LocalOutlierFactors(many, k, 2);
      for (std::size_t i = 0; i < few.size(); ++i) {
        EXPECT_EQ(scanned[i], tree[i]) << "seed " << seed << " k " << k << " point " << i;
      }
    }
  }
}

TEST(LocalOutlier, UniformGridHasFactorOne) {
  // On a square grid every point two or more steps inside has its 4 nearest neighbours at one
  // step, so its density is 1 / step; three or more steps inside, so have all its neighbours:
  // a factor of exactly 1 whatever the step. (The edge's points reach their 4th at step * sqrt 2.)
  for (float step : {0.5f, 7.f}) {
    PointCloud c;
    for (int r = 0; r < 20; ++r)
      for (int q = 0; q < 20; ++q) c.points_mm.emplace_back(step * float(q), step * float(r), 1000.f);
    const std::vector<float> lof = LocalOutlierFactors(c, 4, 1);
    for (int r = 3; r < 17; ++r)
      for (int q = 3; q < 17; ++q) EXPECT_NEAR(lof[std::size_t(r * 20 + q)], 1.0, 1e-5);
  }
}

// A sphere of radius R centred at depth z as a stereo camera samples it: one point per pixel of
// a pinhole (focal f px) where its ray meets the sphere, so the spacing grows from z / f at the
// middle to many times that at the outline (as 1 / cos of the view angle). `cos_view` gets each
// point's cosine between the ray and the sphere's normal.
PointCloud StereoSphere(double f, double z, double radius, std::vector<double>* cos_view, bool pixels = false) {
  PointCloud c;
  std::vector<float> us, vs;
  const Eigen::Vector3d centre(0, 0, z);
  const int half = int(std::ceil(f * radius / std::sqrt(z * z - radius * radius))) + 1;
  for (int v = -half; v <= half; ++v) {
    for (int u = -half; u <= half; ++u) {
      const Eigen::Vector3d ray = Eigen::Vector3d(u / f, v / f, 1).normalized();
      const double b = ray.dot(centre), disc = b * b - (centre.squaredNorm() - radius * radius);
      if (disc <= 0) continue;
      const Eigen::Vector3d p = ray * (b - std::sqrt(disc));
      c.points_mm.push_back(p.cast<float>());
      cos_view->push_back(-ray.dot((p - centre).normalized()));
      us.push_back(float(u + half)), vs.push_back(float(v + half));
    }
  }
  if (pixels) c.fields[kPixelUField] = us, c.fields[kPixelVField] = vs;
  c.Flatten();
  return c;
}

// Which points of `cloud` survive `stages` (a JSON array of filters), by position: the filters
// keep the input order.
std::vector<bool> Survivors(const PointCloud& cloud, const std::string& stages) {
  const PointCloud kept = RunFilterStages(cloud, stages, "test");
  std::vector<bool> k(cloud.size(), false);
  std::size_t j = 0;
  for (std::size_t i = 0; i < cloud.size() && j < kept.size(); ++i) {
    if (cloud.points_mm[i] == kept.points_mm[j]) k[i] = true, ++j;
  }
  EXPECT_EQ(j, kept.size());
  return k;
}

TEST(OutlierFilters, StereoSphereKeepsItsOutlineAndLosesItsFloaters) {
  // The paper's lab sphere (radius 300 mm at 2.3 m) as a 1000 px camera samples it: 2.3 mm
  // between points facing the camera, growing as 1 / cos of the view angle to the outline.
  std::vector<double> cos_view;
  PointCloud c = StereoSphere(1000, 2300, 300, &cos_view);
  const std::size_t surface = c.size();
  std::vector<float> px(surface);
  for (std::size_t i = 0; i < surface; ++i) px[i] = c.points_mm[i].z() / 1000.f;  // Z / f
  // Mismatched pixels: one in 500 moved along its ray 40-300 mm towards the camera (a wrong
  // disparity). Near the outline the ray runs along the surface, so some stay within 20 mm of
  // the sphere: those are no threat to a fit, and are not counted.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> off(40, 300);
  for (std::size_t i = 0; i < surface; i += 500) {
    const Eigen::Vector3f p = c.points_mm[i];
    const Eigen::Vector3f q = p - p.normalized() * float(off(rng));
    c.points_mm.push_back(q);
    px.push_back(q.z() / 1000.f);
  }
  c.fields[kPixelSizeField] = px;
  c.Flatten();
  std::vector<std::size_t> floaters;
  for (std::size_t i = surface; i < c.size(); ++i) {
    if (std::abs((c.points_mm[i] - Eigen::Vector3f(0, 0, 2300)).norm() - 300.f) > 20.f) floaters.push_back(i);
  }
  ASSERT_GT(floaters.size(), 80u);
  const std::vector<bool> lof = Survivors(c, R"([{"type": "filters.local_outlier"}])");
  const std::vector<bool> spacing = Survivors(c, R"([{"type": "filters.spacing_outlier"}])");
  const std::vector<bool> cleaning = Survivors(c, DefaultCleaningJson());
  const std::vector<bool> sor = Survivors(c, R"([{"type": "filters.statistical_outlier", "mean_k": 30}])");
  auto count = [&](const std::vector<bool>& keep, const std::vector<std::size_t>& which) {
    return std::size_t(std::count_if(which.begin(), which.end(), [&](std::size_t i) { return bool(keep[i]); }));
  };
  std::vector<std::size_t> all_surface(surface), band;
  std::iota(all_surface.begin(), all_surface.end(), std::size_t(0));
  for (std::size_t i = 0; i < surface; ++i) {
    if (cos_view[i] < 0.25) band.push_back(i);
  }
  ASSERT_GT(band.size(), 1000u);
  // The surface is a surface however sparse: a point's local outlier factor is about 1 (its
  // neighbours are as sparse as it is), and its spacing ratio at most about 1 / sqrt(cos) of the
  // median point's (under 8 down to cos 0.02, the last pixels of the outline). None is lost.
  EXPECT_EQ(count(lof, all_surface), surface);
  EXPECT_EQ(count(spacing, all_surface), surface);
  EXPECT_EQ(count(cleaning, all_surface), surface);
  // Each filter misses a kind of floater: the local factor those among other floaters (as
  // sparse as their neighbours), the spacing ratio those 20-40 mm off the surface (their nearest
  // points are the surface's, at a few times its spacing); the default cleaning, both, misses none.
  EXPECT_GT(count(lof, floaters), 10u);
  EXPECT_GT(count(spacing, floaters), 3u);
  EXPECT_EQ(count(cleaning, floaters), 0u);
  // The statistical filter's one threshold on the distance takes the sparse outline instead.
  EXPECT_EQ(count(sor, floaters), 0u);
  EXPECT_LT(count(sor, band), band.size() / 2);
}

// A stereo capture's cloud knows each point's pixel (pixel_u, pixel_v): the local outlier factor
// takes neighbours from the 7 x 7 pixels about each point (twice as wide if need be) where those surely
// hold the nearest, else search in 3-D. On the lab sphere as a 1000 px camera samples it, where the
// surface faces the camera (cos > 0.7) the window holds them (a facing grid's 30th nearest is 3 px
// away at most); towards the outline the surface slants and a wider window or the 3-D search takes
// over. Either way it gives the same numbers as the 3-D search (to float rounding: sums in another
// order). Mismatches replace their pixel's point (one
// in 500 moved 40-300 mm along its ray): the cleaning on the grid removes every one more than
// 20 mm off the sphere and keeps every other point, as the 3-D search does (the test above).
TEST(OutlierFilters, OnThePixelGridTheyDecideAsIn3D) {
  std::vector<double> cos_view;
  PointCloud c = StereoSphere(1000, 2300, 300, &cos_view, true);
  std::vector<float> px(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) px[i] = c.points_mm[i].z() / 1000.f;
  c.fields[kPixelSizeField] = px;
  ASSERT_TRUE(internal::PixelGrid::Of(c).has_value());
  const std::vector<float> lof_grid = LocalOutlierFactors(c, 20, 2, true), lof_3d = LocalOutlierFactors(c, 20, 2, false);
  for (std::size_t i = 0; i < c.size(); ++i) {
    ASSERT_NEAR(lof_grid[i], lof_3d[i], 1e-5f * lof_3d[i]) << i << " cos " << cos_view[i];
  }
  // The window served where the surface faces the camera: the sphere's middle.
  const auto grid = internal::PixelGrid::Of(c);
  std::vector<std::uint32_t> idx(20);
  std::vector<float> sq(20);
  std::vector<std::uint64_t> scratch;
  std::size_t facing = 0, served = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (cos_view[i] < 0.9) continue;
    bool exact = false;
    ++facing;
    served += grid->Nearest(i, 20, idx.data(), sq.data(), &scratch, &exact) == 20 && exact;
  }
  ASSERT_GT(facing, 10000u);
  EXPECT_GT(served, facing * 9 / 10);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> off(40, 300);
  std::vector<std::size_t> floaters, surface;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (i % 500 != 0) {
      surface.push_back(i);
      continue;
    }
    const Eigen::Vector3f p = c.points_mm[i];
    c.points_mm[i] = p - p.normalized() * float(off(rng));
    c.fields[kPixelSizeField][i] = c.points_mm[i].z() / 1000.f;
    if (std::abs((c.points_mm[i] - Eigen::Vector3f(0, 0, 2300)).norm() - 300.f) > 20.f) floaters.push_back(i);
  }
  ASSERT_GT(floaters.size(), 80u);
  for (const char* neighbours : {"pixels", "space"}) {
    SCOPED_TRACE(neighbours);
    const std::vector<bool> keep =
        Survivors(c, std::string(R"([{"type": "filters.hedge_outlier", "neighbours": ")") + neighbours + "\"}]");
    EXPECT_EQ(std::count_if(surface.begin(), surface.end(), [&](std::size_t i) { return bool(keep[i]); }),
              std::ptrdiff_t(surface.size()));
    EXPECT_EQ(std::count_if(floaters.begin(), floaters.end(), [&](std::size_t i) { return bool(keep[i]); }), 0);
  }
}

// The grid is one capture's: none for a cloud of several captures (their pixels overlap), for two
// points at one pixel, or without the fields. A point's neighbours are the window's, itself
// excluded, the k-th nearest last; a thinned capture's step (every 3rd pixel) is the grid's.
TEST(PixelGrid, IsOneCapturesAndSearchesItsWindow) {
  PointCloud c;
  std::vector<float> us, vs;
  for (int v = 0; v < 30; v += 3) {
    for (int u = 0; u < 30; u += 3) {
      c.points_mm.emplace_back(float(u), float(v), 1000.f);
      us.push_back(float(u + 100)), vs.push_back(float(v + 50));
    }
  }
  c.Flatten();
  c.fields[kPixelSizeField] = std::vector<float>(c.size(), 1.f);  // 1 mm per pixel at 1 m
  EXPECT_FALSE(internal::PixelGrid::Of(c).has_value());
  c.fields[kPixelUField] = us, c.fields[kPixelVField] = vs;
  const auto grid = internal::PixelGrid::Of(c);
  ASSERT_TRUE(grid.has_value());
  // Point (15, 15) (index 55): its 4 nearest are the 4 grid neighbours 3 mm away; a point outside
  // the 3 x 3 window searched for 4 is at least 2 steps (6 mm) away, so they are the cloud's nearest.
  std::vector<std::uint32_t> idx(32);
  std::vector<float> sq(32);
  std::vector<std::uint64_t> scratch;
  bool exact = false;
  ASSERT_EQ(grid->Nearest(55, 4, idx.data(), sq.data(), &scratch, &exact), 4u);
  std::vector<std::uint32_t> four(idx.begin(), idx.begin() + 4);
  std::sort(four.begin(), four.end());
  EXPECT_EQ(four, (std::vector<std::uint32_t>{45, 54, 56, 65}));
  for (int t = 0; t < 4; ++t) EXPECT_FLOAT_EQ(sq[std::size_t(t)], 9.f);
  EXPECT_TRUE(exact);
  // A corner point's 7 x 7 window holds only (3 + 1)^2 - 1 = 15 others; the window twice as wide
  // holds 48, among them the cloud's 20 nearest (by brute force).
  ASSERT_EQ(grid->Nearest(0, 20, idx.data(), sq.data(), &scratch, &exact), 20u);
  EXPECT_TRUE(exact);
  std::vector<float> brute;
  for (std::size_t j = 1; j < c.size(); ++j) brute.push_back((c.points_mm[j] - c.points_mm[0]).squaredNorm());
  std::sort(brute.begin(), brute.end());
  std::vector<float> found(sq.begin(), sq.begin() + 20);
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, std::vector<float>(brute.begin(), brute.begin() + 20));
  PointCloud fused = c;
  fused.fields["capture"] = std::vector<float>(c.size(), 0.f);
  EXPECT_FALSE(internal::PixelGrid::Of(fused).has_value());
  PointCloud twice = c;
  twice.fields[kPixelUField][1] = twice.fields[kPixelUField][0];
  EXPECT_FALSE(internal::PixelGrid::Of(twice).has_value());
}

TEST(SpacingOutlier, RatioIsOneOnAFacingSurfaceAtAnyDistance) {
  // Two square patches facing the camera, 40 x 40 points at 1 m and 20 x 20 at 4 m, each sampled
  // at its pixel footprint (1 and 4 mm): in units of footprint they are the same surface, so
  // every point two or more rings in has the same mean neighbour distance, which is the cloud's
  // median: a ratio of exactly 1. In millimetres (no pixel_mm field) the far patch is four
  // times as sparse as the near one, which holds the median.
  PointCloud c;
  std::vector<float> px;
  struct Patch {
    float z;
    int side;
  };
  const Patch patches[2] = {{1000.f, 40}, {4000.f, 20}};
  for (const Patch& p : patches) {
    const float step = p.z / 1000.f;
    for (int r = 0; r < p.side; ++r)
      for (int q = 0; q < p.side; ++q) c.points_mm.emplace_back(step * float(q) + p.z, step * float(r), p.z), px.push_back(step);
  }
  c.Flatten();
  PointCloud with = c;
  with.fields[kPixelSizeField] = px;
  const std::vector<float> r = SpacingRatios(with, 8, 1);
  const std::vector<float> mm = SpacingRatios(c, 8, 1);
  std::size_t first = 0;
  for (const Patch& p : patches) {
    for (int row = 3; row < p.side - 3; ++row) {
      for (int q = 3; q < p.side - 3; ++q) {
        const std::size_t i = first + std::size_t(row * p.side + q);
        EXPECT_NEAR(r[i], 1.0, 1e-5);
        EXPECT_NEAR(mm[i], p.z / 1000.0, 1e-4) << "without footprints the far patch is sparser";
      }
    }
    first += std::size_t(p.side * p.side);
  }
  SpacingOutlierOptions o;
  o.mean_k = 8;
  o.max_ratio = 3;  // keeps the whole far patch with footprints, removes it without
  EXPECT_EQ(SpacingOutlierRemoval(with, o).removed, 0u);
  EXPECT_GE(SpacingOutlierRemoval(c, o).removed, 400u);
}

TEST(HedgeOutlier, ChoosesByWhatTheCloudIs) {
  // A stereo sphere with a few floaters: with footprints (pixel_mm) and no hedge_id field it is
  // cleaned by the local factor then the spacing ratio; with hedge_id (hedges found by depth) or
  // without footprints, by the statistical filter (30 neighbours, 1 sigma); shells "local" gives
  // hedges found by depth the local filters. Each is checked against the filters run one by one.
  std::vector<double> cos_view;
  PointCloud c = StereoSphere(800, 2300, 300, &cos_view);
  for (std::size_t i = 0; i < c.size(); i += 400) c.points_mm.push_back(c.points_mm[i] * 0.95f);
  c.Flatten();
  StatisticalOutlierOptions so;
  so.mean_k = 30;
  // Without footprints (a cloud from elsewhere) it is the statistical filter.
  EXPECT_EQ(HedgeOutlierRemoval(c, HedgeOutlierOptions{}).cloud.points_mm, StatisticalOutlierRemoval(c, so).cloud.points_mm);
  EXPECT_FALSE(HedgeOutlierIsLocal(c, HedgeOutlierOptions{}));
  std::vector<float> px(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) px[i] = c.points_mm[i].z() / 800.f;
  c.fields[kPixelSizeField] = px;
  const PointCloud local_then_spacing =
      SpacingOutlierRemoval(LocalOutlierRemoval(c, LocalOutlierOptions{}).cloud, SpacingOutlierOptions{}).cloud;
  EXPECT_EQ(HedgeOutlierRemoval(c, HedgeOutlierOptions{}).cloud.points_mm, local_then_spacing.points_mm);
  PointCloud shells = c;
  shells.fields[kHedgeIdField] = std::vector<float>(c.size(), 1.f);
  const FilterResult statistical = HedgeOutlierRemoval(shells, HedgeOutlierOptions{});
  EXPECT_EQ(statistical.cloud.points_mm, StatisticalOutlierRemoval(shells, so).cloud.points_mm);
  EXPECT_LT(statistical.kept, local_then_spacing.size());  // it trims the outline as well
  HedgeOutlierOptions o;
  o.shells = "local";
  EXPECT_EQ(HedgeOutlierRemoval(shells, o).cloud.points_mm, local_then_spacing.points_mm);
  o.shells = "lof";
  EXPECT_THROW(HedgeOutlierRemoval(shells, o), Error);
}

TEST(LocalOutlier, BadOptionsAreNamed) {
  SpacingOutlierOptions so;
  so.max_ratio = 0.9;
  EXPECT_THROW(SpacingOutlierRemoval(PointCloud{}, so), Error);
  LocalOutlierOptions o;
  o.threshold = 0.5;
  try {
    LocalOutlierRemoval(PointCloud{}, o);
    FAIL() << "a threshold below 1 was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("threshold"), std::string::npos) << e.what();
  }
  o = LocalOutlierOptions{};
  o.k = 1;
  EXPECT_THROW(LocalOutlierRemoval(PointCloud{}, o), Error);
  // Fewer points than k: each is compared with all the others.
  PointCloud few;
  for (int i = 0; i < 5; ++i) few.points_mm.emplace_back(float(i), 0.f, 1000.f);
  EXPECT_EQ(LocalOutlierRemoval(few, LocalOutlierOptions{}).kept, 5u);
}


// Hedges found by depth are each cleaned against their own neighbour distances: a hedge's kept
// points are the same whether its cloud holds another hedge or not (convert writes one file per
// hedge and compare cleans each; measure cleans the capture whole). A second, farther and so
// sparser hedge would move a statistic taken over the whole cloud, and with it the first's cut.
TEST(HedgeOutlier, EachHedgeIsCleanedOnItsOwn) {
  std::vector<double> cos_near, cos_far;
  PointCloud near = StereoSphere(800, 2000, 300, &cos_near), far = StereoSphere(800, 3400, 500, &cos_far);
  for (std::size_t i = 0; i < near.size(); i += 300) near.points_mm.push_back(near.points_mm[i] * 0.97f);
  near.Flatten();
  for (auto& p : far.points_mm) p.x() += 1500.f;
  PointCloud both;
  both.points_mm = near.points_mm;
  both.points_mm.insert(both.points_mm.end(), far.points_mm.begin(), far.points_mm.end());
  both.fields[kHedgeIdField] = std::vector<float>(near.size(), 1.f);
  both.fields[kHedgeIdField].resize(both.size(), 2.f);
  both.Flatten();
  near.fields[kHedgeIdField] = std::vector<float>(near.size(), 1.f);
  const PointCloud alone = HedgeOutlierRemoval(near, HedgeOutlierOptions{}).cloud;
  const PointCloud together = HedgeOutlierRemoval(both, HedgeOutlierOptions{}).cloud;
  std::vector<Eigen::Vector3f> first;
  for (std::size_t i = 0; i < together.size(); ++i) {
    if (together.fields.at(kHedgeIdField)[i] == 1.f) first.push_back(together.points_mm[i]);
  }
  ASSERT_GT(alone.size(), near.size() / 2);
  EXPECT_EQ(first, alone.points_mm);
  // The whole cloud's statistic would have cut the first hedge otherwise.
  StatisticalOutlierOptions so;
  so.mean_k = 30;
  std::size_t whole_first = 0;
  const PointCloud whole = StatisticalOutlierRemoval(both, so).cloud;
  for (std::size_t i = 0; i < whole.size(); ++i) whole_first += whole.fields.at(kHedgeIdField)[i] == 1.f ? 1 : 0;
  EXPECT_NE(whole_first, alone.size());
}

// Points of no hedge (hedge_id 0: the lawn's edge, a stray blob) are judged against the whole
// cloud's statistics, as StatisticalOutlierRemoval would; the whole-cloud pass is skipped only
// when every finite point belongs to a hedge, so skipping it must not change their verdict.
TEST(HedgeOutlier, PointsOfNoHedgeAreJudgedOnTheWholeCloud) {
  std::vector<double> cos_near, cos_far;
  PointCloud a = StereoSphere(800, 2000, 300, &cos_near), b = StereoSphere(800, 3400, 500, &cos_far);
  for (auto& p : b.points_mm) p.x() += 1500.f;
  PointCloud both;
  both.points_mm = a.points_mm;
  both.points_mm.insert(both.points_mm.end(), b.points_mm.begin(), b.points_mm.end());
  std::vector<float> id(a.size(), 1.f);
  id.resize(both.size(), 2.f);
  // Every 50th point of the far hedge, and a few far off it, belong to no hedge.
  for (std::size_t i = a.size(); i < both.size(); i += 50) id[i] = 0.f;
  for (int k = 0; k < 5; ++k) {
    both.points_mm.emplace_back(600.f + 200.f * float(k), 0.f, 2600.f);
    id.push_back(0.f);
  }
  both.fields[kHedgeIdField] = id;
  both.Flatten();
  StatisticalOutlierOptions so;
  so.mean_k = 30;
  so.stddev_mul = 1.0;
  const std::vector<bool> whole = StatisticalInliers(both, so, nullptr);
  HedgeOutlierOptions o;  // per_hedge, statistical shells: the defaults
  const FilterResult r = HedgeOutlierRemoval(both, o);
  std::vector<Eigen::Vector3f> kept_none, expected_none;
  for (std::size_t i = 0; i < r.cloud.size(); ++i) {
    if (r.cloud.fields.at(kHedgeIdField)[i] == 0.f) kept_none.push_back(r.cloud.points_mm[i]);
  }
  for (std::size_t i = 0; i < both.size(); ++i) {
    if (id[i] == 0.f && whole[i]) expected_none.push_back(both.points_mm[i]);
  }
  // The five lone points float 0.4-1.5 m from any surface: the whole cloud's cut drops them.
  ASSERT_GT(expected_none.size(), 10u);
  ASSERT_LT(expected_none.size(), std::size_t(std::count(id.begin(), id.end(), 0.f)));
  EXPECT_EQ(kept_none, expected_none);
}

}  // namespace
}  // namespace hedgefit::cloud
