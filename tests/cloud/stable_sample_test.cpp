#include "cloud/stable_sample.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <iterator>
#include <limits>
#include <random>
#include <set>
#include <vector>

namespace hedgefit::cloud {
namespace {

template <class Point>
std::set<std::array<double, 3>> AsSet(const std::vector<Point>& from, const std::vector<std::size_t>& idx) {
  std::set<std::array<double, 3>> out;
  for (const std::size_t i : idx) out.insert({double(from[i].x()), double(from[i].y()), double(from[i].z())});
  return out;
}

// Which points are kept is a property of each point, not of the list: a fit whose cloud lost
// one point of 13,760 (a cleaning decision on a paper-size hedge) used to see another sixth of
// its front (every 6th by index from there on), and its centre moved 0.35 mm.
TEST(StableSample, DependsOnEachPointAlone) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-500, 500);
  std::vector<Eigen::Vector3d> pts(20000);
  for (auto& p : pts) p = Eigen::Vector3d(u(rng), u(rng), 2000 + u(rng));
  const std::size_t most = 3000;
  const std::vector<std::size_t> kept = StableSample(pts, most);
  // Each point is kept with probability most / n = 0.15: the count is binomial, sd 50; 5 sd.
  EXPECT_NEAR(double(kept.size()), double(most), 250.0);
  EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end()));
  EXPECT_TRUE(std::adjacent_find(kept.begin(), kept.end()) == kept.end());
  const auto before = AsSet(pts, kept);
  // The first point removed: the others keep their fate (every n-th by index would redraw all).
  std::vector<Eigen::Vector3d> fewer(pts.begin() + 1, pts.end());
  auto expected = before;
  expected.erase({pts[0].x(), pts[0].y(), pts[0].z()});
  // Asked for the same share of the list one shorter (most (n - 1) / n, rounded down), the keys'
  // threshold drops by under 1 / n of the share, which drops 0.14 points in expectation: at most
  // a few may differ, where every n-th by index (every 7th here) drew a disjoint set: 5,714 differ.
  const auto after = AsSet(fewer, StableSample(fewer, std::size_t(most * (pts.size() - 1) / pts.size())));
  std::vector<std::array<double, 3>> changed;
  std::set_symmetric_difference(after.begin(), after.end(), expected.begin(), expected.end(), std::back_inserter(changed));
  EXPECT_LE(changed.size(), 3u);
  // Another order, the same points.
  std::vector<Eigen::Vector3d> reversed(pts.rbegin(), pts.rend());
  EXPECT_EQ(AsSet(reversed, StableSample(reversed, most)), before);
  std::vector<Eigen::Vector3d> shuffled = pts;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  EXPECT_EQ(AsSet(shuffled, StableSample(shuffled, most)), before);
  // A point that cannot be fitted is never kept, whether the list is thinned or kept whole.
  std::vector<Eigen::Vector3d> with_nan = pts;
  with_nan[5] = Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  for (const std::size_t i : StableSample(with_nan, most)) EXPECT_TRUE(with_nan[i].allFinite());
  EXPECT_EQ(StableSample(with_nan, with_nan.size()).size(), with_nan.size() - 1);
  EXPECT_EQ(StableSample(fewer, fewer.size()).size(), fewer.size());
}

// A cloud's float points (PointCloud) and the fits' double ones keep the same points: the cell
// is taken from the coordinate in mm either way (points on a 0.25 mm grid, exact in both).
TEST(StableSample, FloatAndDoublePointsKeepTheSame) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> u(-8000, 8000);
  std::vector<Eigen::Vector3f> f(10000);
  std::vector<Eigen::Vector3d> d(f.size());
  for (std::size_t i = 0; i < f.size(); ++i) {
    f[i] = Eigen::Vector3f(0.25f * float(u(rng)), 0.25f * float(u(rng)), 0.25f * float(u(rng)));
    d[i] = f[i].cast<double>();
  }
  EXPECT_EQ(StableSample(f, 1000), StableSample(d, 1000));
  const std::vector<Eigen::Vector3f> pts = StablePoints(f, 1000);
  EXPECT_EQ(pts.size(), StableSample(f, 1000).size());
  // Each point in a cell of its own (a 4 m cube, 10,000 points): about a tenth kept, binomial, sd 30.
  EXPECT_NEAR(double(pts.size()), 1000.0, 150.0);
}

// An order that belongs to the points: a shuffled list, or one with a point that cannot be
// fitted added, gives the same sequence of coordinates (find reads its points in it, so one
// set of points is one answer whatever order a file lists them in), and neighbours in the order
// lie near each other, so every n-th point is a sample spread over the cloud. 20,000 points in a
// 1 m cube: a random pair lies ~0.66 m apart; along a Z-order curve consecutive points lie ~40 mm
// apart on average (the cube's side / 20000^(1/3) ~ 37 mm, and a few long jumps where the curve
// leaves an octant). A list order, the file's, would give the random ~660 mm.
TEST(SpatialOrder, IsAPropertyOfThePointsAndKeepsNeighboursNear) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-500, 500);
  std::vector<Eigen::Vector3f> pts(20000);
  for (auto& p : pts) p = Eigen::Vector3f(float(u(rng)), float(u(rng)), float(2000 + u(rng)));
  pts[7] = pts[9];  // an exact duplicate
  auto sequence = [](const std::vector<Eigen::Vector3f>& from) {
    std::vector<std::array<float, 3>> out;
    for (const std::size_t i : SpatialOrder(from)) out.push_back({from[i].x(), from[i].y(), from[i].z()});
    return out;
  };
  const auto as_read = sequence(pts);
  ASSERT_EQ(as_read.size(), pts.size());
  std::vector<Eigen::Vector3f> shuffled = pts;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  EXPECT_EQ(sequence(shuffled), as_read);
  std::vector<Eigen::Vector3f> reversed(pts.rbegin(), pts.rend());
  EXPECT_EQ(sequence(reversed), as_read);
  // A point that cannot be fitted is left out and moves nothing else.
  std::vector<Eigen::Vector3f> with_nan = shuffled;
  with_nan.insert(with_nan.begin() + 100, Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 0, 0));
  EXPECT_EQ(sequence(with_nan), as_read);
  // Every index once.
  std::vector<std::size_t> idx = SpatialOrder(pts);
  std::sort(idx.begin(), idx.end());
  for (std::size_t k = 0; k < idx.size(); ++k) ASSERT_EQ(idx[k], k);
  double step = 0;
  for (std::size_t k = 1; k < as_read.size(); ++k) {
    step += (Eigen::Vector3f(as_read[k].data()) - Eigen::Vector3f(as_read[k - 1].data())).norm();
  }
  EXPECT_LT(step / double(as_read.size() - 1), 80.0);
  EXPECT_TRUE(SpatialOrder(std::vector<Eigen::Vector3f>{}).empty());
}

}  // namespace
}  // namespace hedgefit::cloud
