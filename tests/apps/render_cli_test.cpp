// hedgefit render and compare --plot end to end, without a display.

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <sys/wait.h>

#include <fstream>
#include <sstream>

#include "tests/cli_helpers.hpp"
#include "tests/test_data.hpp"

namespace {

namespace fs = std::filesystem;

using Result = hedgefit::testing::CliResult;
using hedgefit::testing::Slurp;

// Runs from the source tree (for sample_clouds/) with DISPLAY unset, as on CI.
Result RunHedgefit(const std::string& args, const fs::path& scratch) {
  return hedgefit::testing::RunCli(HEDGEFIT_EXE, args, HEDGEFIT_SOURCE_DIR, scratch);
}

TEST(RenderCli, RendersFitsFromCompareJson) {
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string fits = (dir / "fits.json").string(), png = (dir / "cap.png").string();
  Result r = RunHedgefit("compare sample_clouds/cap_z2300_a60_o10.pcd --format json", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ofstream(fits) << r.out;
  r = RunHedgefit("render sample_clouds/cap_z2300_a60_o10.pcd --fits '" + fits +
                      "' --color distance --view front,side --size 320x240 -o '" + png + "'",
                  dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const cv::Mat img = cv::imread(png);
  EXPECT_EQ(img.cols, 640);  // two 320-px views side by side
  EXPECT_EQ(img.rows, 240);
}

TEST(RenderCli, PlotOfErrorsAgainstDistance) {
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string png = (dir / "plot.png").string();
  const Result r = RunHedgefit("compare sample_clouds/cap_z2000_a60_o10.pcd sample_clouds/cap_z2600_a60_o10.pcd "
                               "--methods kasa,hyper --plot '" + png + "'",
                               dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const cv::Mat img = cv::imread(png);
  EXPECT_EQ(img.cols, 1200);
  EXPECT_EQ(img.rows, 500);
  // The lines are drawn in the method colours (kasa red, hyper blue), not just axes.
  int red = 0, blue = 0;
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      red += p[2] > 180 && p[1] < 80 && p[0] < 80;
      blue += p[0] > 150 && p[2] < 100;
    }
  }
  EXPECT_GT(red, 50);
  EXPECT_GT(blue, 50);
}

TEST(RenderCli, BadArgumentsAreOneLine) {
  const auto dir = hedgefit::testing::ScratchDir();
  Result r = RunHedgefit("render sample_clouds/cap_z2300_a60_o10.pcd --fits missing.json -o x.png", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: missing.json: cannot open the fits file; write one with `hedgefit compare CLOUD "
                   "--format json > FILE`\n");
  // A method the table does not know draws nothing: an error, not an empty picture.
  r = RunHedgefit("render sample_clouds/cap_z2300_a60_o10.pcd --method bogus -o x.png", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err.rfind("hedgefit: --method: unknown method 'bogus'", 0), 0u) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
  r = RunHedgefit("render sample_clouds/cap_z2300_a60_o10.pcd --size 12x10 -o x.png", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --size '12x10': each side must be 16..8192 px\n");
  r = RunHedgefit("render sample_clouds/cap_z2300_a60_o10.pcd --view below -o x.png", dir);
  EXPECT_EQ(r.err, "hedgefit: --view: 'below' is not a view; use front, side, top, iso, a comma list of them, or all\n");
  r = RunHedgefit("render sample_clouds/cap_z2300_a60_o10.pcd --color distance -o '" + (dir / "x.png").string() + "'", dir);
  EXPECT_EQ(r.err, "hedgefit: color: 'distance' needs a fitted sphere; give --fits (or --truth)\n");
  EXPECT_FALSE(fs::exists(dir / "x.png"));
}

}  // namespace
