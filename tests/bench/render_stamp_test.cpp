// A bench's rendered captures are reused only under today's stamp: a set rendered by another
// build, or with other options, is rendered again, so its figures are never an older renderer's
// images scored against today's truth.

#include "bench/render_stamp.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "bench/around_bench.hpp"

namespace hedgefit::bench {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("hedgefit_stamp_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(RenderStamp, NamesTheRendererItsOptionsAndWhatTheBuildRenders) {
  const std::string a = RenderStamp("hedgefit", "scale 0.5"), b = RenderStamp("hedgefit", "scale 1");
  const std::string pov = RenderStamp("povray", "scale 0.5");
  EXPECT_NE(a, b);
  EXPECT_NE(a, pov);
  EXPECT_EQ(a, RenderStamp("hedgefit", "scale 0.5"));  // the same build: the same stamp
  // Each renderer's fingerprint is its own (16 hex digits), not a constant.
  const std::regex fp("fingerprint ([0-9a-f]{16})$");
  std::smatch ma, mp;
  ASSERT_TRUE(std::regex_search(a, ma, fp)) << a;
  ASSERT_TRUE(std::regex_search(pov, mp, fp)) << pov;
  EXPECT_NE(ma[1].str(), mp[1].str());
}

TEST(RenderStamp, ASetIsReusedOnlyUnderItsOwnStamp) {
  const fs::path dir = FreshDir("sets");
  const std::string s1 = RenderStamp("hedgefit", "one"), s2 = RenderStamp("hedgefit", "two");
  EXPECT_FALSE(StampMatches(dir.string(), "lab", s1, false, "test"));  // nothing there yet
  WriteStamp(dir.string(), "lab", s1);
  EXPECT_TRUE(StampMatches(dir.string(), "lab", s1, true, "test"));
  EXPECT_FALSE(StampMatches(dir.string(), "lab", s2, true, "test"));      // other options or build
  EXPECT_FALSE(StampMatches(dir.string(), "gardens", s1, true, "test"));  // another set in the same folder
  WriteStamp(dir.string(), "gardens", s2);
  EXPECT_TRUE(StampMatches(dir.string(), "lab", s1, true, "test"));  // each set keeps its own
  RemoveStamp(dir.string(), "lab");
  EXPECT_FALSE(StampMatches(dir.string(), "lab", s1, true, "test"));
  EXPECT_TRUE(StampMatches(dir.string(), "gardens", s2, true, "test"));
  fs::remove_all(dir);
}

ino_t Inode(const fs::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 ? st.st_ino : 0;
}

// `bench around` end to end at a fifth of the size: a second run reuses the set's images (the
// same files), a run with another --seed renders them again (the odometry and the camera noise
// are the seed's), and so does a run over a set whose stamp another build left.
TEST(RenderStamp, BenchAroundRendersAStaleSetAgain) {
  const fs::path dir = FreshDir("around");
  AroundBenchOptions o;
  o.scenes = "single";
  o.layouts = "arc";
  o.captures = "3";
  o.poses = "exact";
  o.scale = 0.2;
  o.dir = dir.string();
  RunAroundBench(o);
  const fs::path set = dir / "hedgefit" / "single_arc_3", image = set / "1.000_left.png";
  const ino_t first = Inode(image);
  ASSERT_NE(first, 0u);
  RunAroundBench(o);
  EXPECT_EQ(Inode(image), first) << "the same build and options: the set is reused";
  o.seed = 2;
  RunAroundBench(o);
  const ino_t reseeded = Inode(image);
  EXPECT_NE(reseeded, first) << "another seed: the set is rendered again";
  for (const auto& e : fs::directory_iterator(set)) {
    if (e.path().extension() == ".stamp") std::ofstream(e.path()) << "renderer hedgefit; an older build\n";
  }
  RunAroundBench(o);
  EXPECT_NE(Inode(image), reseeded) << "a stamp another build left: the set is rendered again";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hedgefit::bench
