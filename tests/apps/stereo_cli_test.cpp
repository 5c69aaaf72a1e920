// hedgefit calibrate and simulate end to end: real pairs calibrate with the documented
// output, and bad arguments give one line and exit code 1.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include <fstream>
#include <sstream>

#include "tests/cli_helpers.hpp"
#include "tests/test_data.hpp"

namespace {

namespace fs = std::filesystem;

using Result = hedgefit::testing::CliResult;
using hedgefit::testing::Slurp;

Result RunHedgefit(const std::string& args, const fs::path& scratch) {
  return hedgefit::testing::RunCli(HEDGEFIT_EXE, args, scratch, scratch);
}

TEST(CalibrateCli, RealPairsGiveRigAndJson) {
  HEDGEFIT_REQUIRE_DATA("calib_chessboard/left01.jpg");
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string data = hedgefit::testing::DataPath("calib_chessboard");
  const Result r = RunHedgefit("calibrate --left '" + data + "/left*.jpg' --right '" + data +
                                   "/right*.jpg' --board 9x6 --square 1 -o rig.yaml --json",
                               dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_LE(j["rms_stereo_px"].get<double>(), 0.44);
  EXPECT_NEAR(j["baseline"].get<double>(), 3.34, 0.05);
  EXPECT_EQ(j["pairs_total"], 13);
  EXPECT_TRUE(fs::exists(dir / "rig.yaml"));
}

TEST(CalibrateCli, BadArgumentsAreOneLine) {
  const auto dir = hedgefit::testing::ScratchDir();
  Result r = RunHedgefit("calibrate --left 'nothing*.png' --right 'nothing*.png'", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --left 'nothing*.png': no file matches; check the pattern (quote it)\n");
  r = RunHedgefit("calibrate --list pairs.txt --board 9by6", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --board '9by6': give inner corners as COLSxROWS, e.g. 9x6\n");
  std::ofstream(dir / "pairs.txt") << "a.png b.png\nc.png\n";
  r = RunHedgefit("calibrate --list pairs.txt", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: pairs.txt:2: expected 'LEFT RIGHT'\n");
  std::ofstream(dir / "pairs.txt") << "a.png b.png\n";
  r = RunHedgefit("calibrate --list pairs.txt", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("only 0 of 1 pairs are usable"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "rig.yaml"));  // nothing written on failure
}

TEST(SimulateCli, WritesAPairWithTruthAndRejectsBadScenes) {
  const auto dir = hedgefit::testing::ScratchDir();
  Result r = RunHedgefit("simulate --sphere 70,50,2300,300 --scale 0.2 -o sim", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "sim" / "sphere_left.png"));
  EXPECT_TRUE(fs::exists(dir / "sim" / "sphere_right.png"));
  const auto truth = nlohmann::json::parse(Slurp(dir / "sim" / "sphere.truth.json"));
  EXPECT_EQ(truth["radius_mm"], 300.0);
  const auto rig = nlohmann::json::parse(Slurp(dir / "sim" / "rig_truth.json"));
  EXPECT_EQ(rig["image_size"][0], 384);
  r = RunHedgefit("simulate --sphere 1,2,3 -o sim", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --sphere '1,2,3': expected 4 comma-separated numbers\n");
  r = RunHedgefit("simulate --sphere 0,0,100,300 -o sim", dir);
  EXPECT_EQ(r.code, 1);
  r = RunHedgefit("simulate -o sim", dir);
  EXPECT_EQ(r.err, "hedgefit: give exactly one of --preset, --sphere or --board\n");
}

}  // namespace
