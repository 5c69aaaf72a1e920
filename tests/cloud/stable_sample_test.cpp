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

}  // namespace
}  // namespace hedgefit::cloud
