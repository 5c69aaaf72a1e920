// Several captures around a hedge, end to end: `bench around` renders a ring of four captures
// (hedgefit's renderer at half scale, to keep the test short) with exact and odometry-like poses;
// `measure --manifest` and `--trajectory` fuse them; the fused cloud goes to trim and find; bad
// manifests and outputs give one line naming what to fix.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

#include "tests/cli_helpers.hpp"
#include "tests/test_data.hpp"

namespace {

namespace fs = std::filesystem;
using Result = hedgefit::testing::CliResult;
using nlohmann::json;

Result RunHedgefit(const std::string& args, const fs::path& scratch) {
  return hedgefit::testing::RunCli(HEDGEFIT_EXE, args, HEDGEFIT_SOURCE_DIR, scratch);
}

std::vector<json> Lines(const std::string& out) {
  std::vector<json> lines;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty()) lines.push_back(json::parse(line));
  }
  return lines;
}

TEST(Around, ARingOfCapturesFusesIntoOneBallAndItsFusedCloudFeedsTrimAndFind) {
  const auto dir = hedgefit::testing::ScratchDir();
  const Result made = RunHedgefit("bench around --scenes single --layouts ring --captures 4 --scale 0.5 --poses odometry "
                                  "--dir '" + dir.string() + "'",
                                  dir);
  ASSERT_EQ(made.code, 0) << made.err;
  const fs::path set = dir / "hedgefit" / "single_ring_4";
  const json truth = json::parse(hedgefit::testing::Slurp(set / "around.truth.json"))["hedges"][0];
  const fs::path fused = dir / "fused.pcd", plot = dir / "around.png";
  const Result r = RunHedgefit("measure --manifest '" + (set / "manifest_odometry.json").string() + "' --fused '" +
                                   fused.string() + "' --plot '" + plot.string() + "'",
                               dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::vector<json> lines = Lines(r.out);
  ASSERT_EQ(lines.size(), 5u) << r.out;  // one hedge, four captures
  const json& h = lines[0];
  EXPECT_EQ(h["hedge"], 1);
  EXPECT_EQ(h["captures"].size(), 4u);
  // At half scale one capture's envelope radius is good to about 2 mm (its stated standard
  // error); four together, their poses 60-70 mm and a degree off until registered, to 3 mm.
  EXPECT_NEAR(h["radius_mm"].get<double>(), truth["radius_mm"].get<double>(), 3.0);
  double centre_error = 0;
  for (int k = 0; k < 3; ++k) centre_error += std::pow(h["center_mm"][k].get<double>() - truth["center_mm"][k].get<double>(), 2);
  EXPECT_LT(std::sqrt(centre_error), 6.0);
  // A ring of four sees the ball all round but for its top and its foot.
  EXPECT_GT(h["coverage"].get<double>(), 0.7);
  for (std::size_t k = 1; k < lines.size(); ++k) {
    EXPECT_TRUE(lines[k]["used"].get<bool>()) << lines[k].dump();
    EXPECT_EQ(lines[k]["world_from_camera"].size(), 16u);
  }
  EXPECT_TRUE(fs::exists(plot));
  ASSERT_TRUE(fs::exists(fused));
  // The fused cloud is an ordinary cloud: trim plans it (the vertical is its -y), find finds the ball.
  const Result t = RunHedgefit("trim '" + fused.string() + "' --radius 460 --method envelope --up -y --format json", dir);
  ASSERT_EQ(t.code, 0) << t.err;
  const json plan = json::parse(t.out)["hedges"][0];
  EXPECT_GT(plan["seen_share"].get<double>(), 0.4);
  EXPECT_GT(plan["unseen"].size(), 0u);
  EXPECT_GT(plan["volume_unseen_max_l"].get<double>(), 0.0);
  const Result f = RunHedgefit("find '" + fused.string() + "' --up -y --format json", dir);
  ASSERT_EQ(f.code, 0) << f.err;
  const json found = json::parse(f.out)["clouds"][0]["hedges"];
  ASSERT_EQ(found.size(), 1u) << f.out;
  EXPECT_EQ(found[0]["verdict"], "ball");
  // The same captures through the TUM trajectory (time-named files) give the same hedge.
  const Result tum = RunHedgefit("measure --trajectory '" + (set / "trajectory_odometry.tum").string() + "' --captures '" +
                                     set.string() + "' --rig '" + (set / "rig.yaml").string() + "'",
                                 dir);
  ASSERT_EQ(tum.code, 0) << tum.err;
  EXPECT_NEAR(Lines(tum.out)[0]["radius_mm"].get<double>(), h["radius_mm"].get<double>(), 1e-6);
}

TEST(Around, BadManifestsAndOutputsSayWhatToFix) {
  const auto dir = hedgefit::testing::ScratchDir();
  std::ofstream(dir / "no_rig.json") << R"({"captures": [{"left": "a_left.png", "right": "a_right.png",
      "world_from_camera": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}]})";
  Result r = RunHedgefit("measure --manifest '" + (dir / "no_rig.json").string() + "'", dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("no rig"), std::string::npos) << r.err;
  std::ofstream(dir / "broken.json") << "{ not json";
  r = RunHedgefit("measure --manifest '" + (dir / "broken.json").string() + "'", dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("broken.json"), std::string::npos) << r.err;
  r = RunHedgefit("measure --manifest '" + (dir / "broken.json").string() + "' --left a.png --right b.png", dir);
  EXPECT_NE(r.code, 0);
  r = RunHedgefit("measure --trajectory '" + (dir / "t.tum").string() + "'", dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("--captures"), std::string::npos) << r.err;
  r = RunHedgefit("measure", dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("--manifest"), std::string::npos) << r.err;
}

}  // namespace
