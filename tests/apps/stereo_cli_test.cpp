// hedgefit calibrate and simulate end to end: real pairs calibrate with the documented
// output, and bad arguments give one line and exit code 1.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "cloud/cloud_io.hpp"
#include "sim/simulator.hpp"
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
  EXPECT_EQ(r.err, "hedgefit: --board '9by6': give inner corners as COLSxROWS, each at least 2, e.g. 9x6\n");
  std::ofstream(dir / "pairs.txt") << "a.png b.png\nc.png\n";
  r = RunHedgefit("calibrate --list pairs.txt", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: pairs.txt:2: expected 'LEFT RIGHT'\n");
  std::ofstream(dir / "pairs.txt") << "a.png b.png\n";
  r = RunHedgefit("calibrate --list pairs.txt", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("only 0 of 1 pairs are usable"), std::string::npos) << r.err;
  // Missing images are named as such, not blamed on --board.
  EXPECT_NE(r.err.find("1 pair(s) cannot be read (cannot read left image a.png: no such image file"), std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("--board"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "rig.yaml"));  // nothing written on failure
}

// The wide board set reaches the image's edges: calibrating from it alone (half size) finds
// every board, covers at least 75 % of the 8 x 8 grid (the paper's lab covers 36 %) and pins
// the principal point to within 0.1 px standard deviation; `--coverage` draws it.
TEST(CalibrateCli, WideBoardsCoverTheImageAndPinThePrincipalPoint) {
  const auto dir = hedgefit::testing::ScratchDir();
  Result r = RunHedgefit("simulate --preset wide-boards --scale 0.5 -o wide", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  r = RunHedgefit("calibrate --left 'wide/board_*_left.png' --right 'wide/board_*_right.png' --board 12x11 --square 30 "
                  "-o wide/rig.yaml --coverage wide/coverage.png --json",
                  dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["pairs_used"].get<int>(), 12);
  EXPECT_GE(j["corner_coverage"][0].get<double>(), 0.75);
  EXPECT_GE(j["corner_coverage"][1].get<double>(), 0.75);
  for (const char* p : {"left.cx", "left.cy", "right.cx", "right.cy"}) EXPECT_LT(j["std"][p].get<double>(), 0.1) << p;
  EXPECT_TRUE(fs::exists(dir / "wide" / "coverage.png"));
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
  // POV-Ray renders the presets only: asked for one sphere, it says so and writes nothing.
  r = RunHedgefit("simulate --sphere 70,50,2300,300 --renderer povray -o pov", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err,
            "hedgefit: --renderer povray: renders the presets (paper-lab, garden, wide-boards); drop it for --sphere or "
            "--board\n");
  EXPECT_FALSE(fs::exists(dir / "pov"));
}

}  // namespace

namespace {

// The issue's end-to-end lab test and its targets: render the paper-lab preset, calibrate
// from the 16 board pairs (never from the simulator's truth), convert the 7 sphere
// captures and fit. For the best method, mean |AER| <= 0.5 mm and mean LD <= 1.0 mm. The
// paper's method on stock OpenCV gives 1.6-3.5 mm and 1.9-5.8 mm on renders of this kind,
// so a regression anywhere on the path (calibration, rectification, matching, refinement,
// fitting) shows here. About 45 s on 2 cores.
TEST(BenchLabCli, PaperLabMeetsTheTargets) {
  const auto dir = hedgefit::testing::ScratchDir();
  const Result r = RunHedgefit("bench lab --dir lab --json lab.json", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(Slurp(dir / "lab.json"));
  double best_aer = 1e9, best_ld = 1e9;
  for (const auto& [method, s] : j["summary"].items()) {
    EXPECT_EQ(s["failures"].get<int>(), 0) << method;
    best_aer = std::min(best_aer, s["mean_abs_aer_mm"].get<double>());
    best_ld = std::min(best_ld, s["mean_ld_mm"].get<double>());
  }
  EXPECT_LE(best_aer, 0.5);
  EXPECT_LE(best_ld, 1.0);
  // The paper's own algebraic fit (Kasa) must at least match its published 1.58 mm here.
  EXPECT_LT(j["summary"]["kasa"]["mean_abs_aer_mm"].get<double>(), 1.58);
  EXPECT_FALSE(j["rig"]["exact"].get<bool>());  // calibrated, not the simulator's rig
}

// --noise-draws records each sphere again with new draws of the real camera's noise, from the
// render kept in as_rendered/: every draw has all seven positions, draws differ only by noise (so
// their fits differ, but not wildly), and the summary is the mean over all draws' captures. At half
// scale, about 20 s. Without a real camera there is no noise to draw: one line, nothing written;
// so too for a --pipeline that is not filter stages.
TEST(BenchLabCli, NoiseDrawsRecordTheSameRenderAgain) {
  const auto dir = hedgefit::testing::ScratchDir();
  Result r = RunHedgefit("bench lab --noise-draws 2 --dir lab", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --noise-draws: only a real camera draws noise; add --camera real or leave --noise-draws at 1\n");
  EXPECT_FALSE(fs::exists(dir / "lab"));
  // A cleaning pipeline the benches cannot run is refused before anything is rendered.
  r = RunHedgefit("bench lab --pipeline missing.json --dir lab", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --pipeline missing.json: cannot open it; give a JSON array of filter stages\n");
  std::ofstream(dir / "writer.json") << R"([{"type": "writers.pcd", "filename": "x.pcd"}])";
  r = RunHedgefit("bench lab --pipeline writer.json --dir lab", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: bench lab's cleaning: give filters.* stages only ({\"filename\":\"x.pcd\",\"type\":\"writers.pcd\"} is not one)\n");
  std::ofstream(dir / "typo.json") << R"([{"type": "filters.local_outlier", "treshold": 3}])";
  r = RunHedgefit("bench garden --pipeline typo.json --dir garden", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("unknown option 'treshold' (did you mean 'threshold'?)"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "lab"));
  EXPECT_FALSE(fs::exists(dir / "garden"));
  r = RunHedgefit("bench lab --camera real --scale 0.5 --noise-draws 2 --dir lab --json lab.json", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(Slurp(dir / "lab.json"));
  EXPECT_EQ(j["noise_draws"].get<int>(), 2);
  for (int z = 2000; z <= 2600; z += 100) {
    const std::string name = "sphere_" + std::to_string(z);
    EXPECT_TRUE(fs::exists(dir / "lab" / "as_rendered" / (name + "_left.png"))) << name;
    EXPECT_TRUE(fs::exists(dir / "lab" / "as_rendered" / (name + "_right.png"))) << name;
  }
  // (draw, z) -> ransac_geometric's radius and its stated standard error from the points' scatter
  std::map<std::pair<int, int>, std::pair<double, double>> radius;
  for (const auto& row : j["rows"]) {
    if (row["method"] != "ransac_geometric") continue;
    radius[{row["draw"].get<int>(), int(row["z_mm"].get<double>())}] = {row["mr_mm"].get<double>(),
                                                                         row["std_error_mm"][3].get<double>()};
  }
  ASSERT_EQ(radius.size(), 14u);
  int differ = 0;
  for (int z = 2000; z <= 2600; z += 100) {
    const auto [a, sa] = radius.at({1, z});
    const auto [b, sb] = radius.at({2, z});
    differ += a != b;
    // Two draws of the same capture differ by noise alone, which each fit states (1-3 mm at half
    // scale): more than 4 standard deviations of the difference apart would be another capture.
    EXPECT_LT(std::abs(a - b), 4 * std::hypot(sa, sb)) << z;
  }
  EXPECT_GE(differ, 6);  // independent noise moves (almost) every fit
  for (const auto& [method, s] : j["summary"].items()) {
    const auto& draws = j["per_draw"][method];
    ASSERT_EQ(draws.size(), 2u) << method;
    // Every draw has the same seven positions, so the mean over all 14 is the draws' mean.
    const double mean = (draws[0]["mean_abs_aer_mm"].get<double>() + draws[1]["mean_abs_aer_mm"].get<double>()) / 2;
    EXPECT_NEAR(s["mean_abs_aer_mm"].get<double>(), mean, 1e-9) << method;
  }
  // Without the noise (and the other effects) every draw records the same pair again: the two
  // draws' fits agree to the bit, where with noise they differed.
  r = RunHedgefit("bench lab --reuse --camera real --scale 0.5 --noise-draws 2 --dir lab --json quiet.json "
                  "--camera-without noise,bayer,gains,vignetting", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("spheres recorded without the camera's noise, bayer, gains, vignetting"), std::string::npos);
  const auto q = nlohmann::json::parse(Slurp(dir / "quiet.json"));
  std::map<std::pair<int, int>, double> quiet;
  for (const auto& row : q["rows"]) {
    if (row["method"] == "ransac_geometric") quiet[{row["draw"].get<int>(), int(row["z_mm"].get<double>())}] = row["mr_mm"];
  }
  ASSERT_EQ(quiet.size(), 14u);
  for (int z = 2000; z <= 2600; z += 100) EXPECT_EQ(quiet.at({1, z}), quiet.at({2, z})) << z;
  r = RunHedgefit("bench lab --reuse --camera-without noise --dir lab", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --camera-without: only a real camera has effects to leave out; add --camera real\n");
}

}  // namespace

namespace {

// PCL's real outdoor pair (rectified, grey): a rig from its published numbers, then the
// round shrub segmented by depth inside a box around it. What must hold, from the
// segmentation's own contract: every point reprojects inside the box, and its disparity
// lies within the tolerance (plus the refinement's <= 1 px) of the points' median.
TEST(ConvertCli, RealGreyPairSegmentedByDepthInABox) {
  HEDGEFIT_REQUIRE_DATA("stereo_plants/pcl_outdoor_stereo_pair/stereo_left.png");
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string d = hedgefit::testing::DataPath("stereo_plants/pcl_outdoor_stereo_pair");
  Result r = RunHedgefit(
      "rig --size 640x480 --focal 368.5347 --cx 318.1122 --cy 224.3349 --baseline 838.7445 -o rig.yaml", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  // Without colour, excess green cannot work, and the search by depth the default then makes finds
  // nothing standing on a ground in this range: one line saying both and what to do, exit code 2.
  const std::string pair = "--left '" + d + "/stereo_left.png' --right '" + d + "/stereo_right.png' --rig rig.yaml";
  r = RunHedgefit("convert " + pair + " -o shrub.pcd -q", dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err.rfind("hedgefit: shrub: no hedge found: the image has no colour, so excess green cannot segment it; "
                        "segment by depth inside a box around the hedge (convert --box X,Y,W,H) or give a mask; by "
                        "depth: no hedge found: ",
                        0),
            0u)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  r = RunHedgefit("convert " + pair + " -o shrub.pcd --box 270,178,44,34 --erode 1 --min-z 10000 --max-z 60000", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const hedgefit::cloud::PointCloud pc = hedgefit::cloud::ReadCloud((dir / "shrub.pcd").string());
  ASSERT_GT(pc.size(), 400u);
  std::vector<float> disp = pc.fields.at("disparity");
  std::vector<float> sorted = disp;
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
  const float median = sorted[sorted.size() / 2];
  for (std::size_t i = 0; i < pc.size(); ++i) {
    const auto& p = pc.points_mm[i];
    const double u = 368.5347 * p.x() / p.z() + 318.1122, v = 368.5347 * p.y() / p.z() + 224.3349;
    ASSERT_TRUE(u > 269.5 && u < 314.5 && v > 177.5 && v < 212.5) << u << ", " << v;
    ASSERT_LT(std::abs(disp[i] - median), 1.0 + 1.0 + 0.5) << i;  // tolerance + refinement + median offset
  }
}

// convert's stage flags come from the stages' declarations, so a bad value is reported with
// the flag as typed and the declared range, before any file is read.
// The garden path on the command line: simulate the garden set, convert the row with --garden
// (one PCD per hedge), compare every hedge against the capture's truth list.
TEST(ConvertCli, GardenRowGivesOnePcdPerHedgeAndComparePerHedge) {
  const auto dir = hedgefit::testing::ScratchDir();
  auto r = RunHedgefit("simulate --preset garden --scale 0.5 --supersample 2 -o garden", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  r = RunHedgefit("convert --garden --left garden/garden_row_left.png --right garden/garden_row_right.png "
          "--rig garden/rig.yaml -o row.pcd",
          dir);
  ASSERT_EQ(r.code, 0) << r.err;
  for (int id = 1; id <= 3; ++id) EXPECT_TRUE(std::filesystem::exists(dir / ("row_" + std::to_string(id) + ".pcd"))) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "row_4.pcd")) << r.out;  // the pot is not a hedge
  r = RunHedgefit("compare row_1.pcd row_2.pcd row_3.pcd --truth garden/garden_row.truth.json --methods envelope --format json",
          dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["clouds"].size(), 3u);
  const double radii[3] = {450, 520, 600};  // the row preset, left to right
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& c = j["clouds"][i];
    EXPECT_EQ(c["hedge_id"].get<int>(), int(i) + 1);
    ASSERT_FALSE(c["truth"].is_null()) << "hedge " << i + 1 << " matched no truth";
    EXPECT_DOUBLE_EQ(c["truth"]["radius_mm"].get<double>(), radii[i]);
    // Half the paper's resolution doubles the depth error per point: 10 mm still separates the
    // envelope from a wrong hedge (radii differ by 70-150 mm). Accuracy at full resolution is
    // tested in garden_test.
    EXPECT_LT(std::abs(c["fits"][0]["errors"]["aer_mm"].get<double>()), 10.0) << "hedge " << i + 1;
  }
  // One answer whichever path measures it: convert wrote each hedge's outline beside its cloud
  // (row_N.pcd.outline.json), so compare's envelope on the saved clouds is measure's on the
  // capture, to 0.1 mm (the issue's bar; both read the same float32 points, clean them alike and
  // fit the same rays, so they agree to rounding). Without the outline the envelope is another fit.
  for (int id = 1; id <= 3; ++id) {
    EXPECT_TRUE(std::filesystem::exists(dir / ("row_" + std::to_string(id) + ".pcd.outline.json"))) << id;
  }
  r = RunHedgefit("measure --garden --method envelope --rig garden/rig.yaml --left garden/garden_row_left.png "
                  "--right garden/garden_row_right.png",
                  dir);
  ASSERT_EQ(r.code, 0) << r.err;
  std::vector<nlohmann::json> measured;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) measured.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(measured.size(), 3u) << r.out;
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& fit = j["clouds"][i]["fits"][0];
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(fit["center_mm"][k].get<double>(), measured[i]["center_mm"][k].get<double>(), 0.1) << "hedge " << i + 1;
    }
    EXPECT_NEAR(fit["radius_mm"].get<double>(), measured[i]["radius_mm"].get<double>(), 0.1) << "hedge " << i + 1;
  }
  // Without --garden the default segmentation finds the hedges by depth too; with no '#' in -o
  // they share one file, each point carrying its hedge_id. This report used to throw ("basic_string::
  // replace") after the file was written, and convert exited 2.
  r = RunHedgefit("convert --left garden/garden_row_left.png --right garden/garden_row_right.png "
          "--rig garden/rig.yaml -o all.pcd",
          dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("replace"), std::string::npos) << r.err;
  for (int id = 1; id <= 3; ++id) EXPECT_NE(r.out.find("hedge " + std::to_string(id) + ":"), std::string::npos) << r.out;
  r = RunHedgefit("compare all.pcd --truth garden/garden_row.truth.json --methods envelope --format json", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["clouds"].size(), 3u) << r.out;
  // One way to find the hedge at a time.
  r = RunHedgefit("convert --garden --mask m.png --left garden/garden_row_left.png --right garden/garden_row_right.png "
          "--rig garden/rig.yaml -o x.pcd",
          dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("--garden"), std::string::npos) << r.err;
}

// One of the garden presets (hard ones too) at half the paper's resolution into `dir`, as
// `simulate --preset garden --scale 0.5 --supersample 2` renders the standard ones.
void WriteHalfScaleGarden(const std::filesystem::path& dir, const std::string& preset) {
  const hedgefit::sim::SimRig rig = hedgefit::sim::PaperRig(0.5);
  hedgefit::sim::RenderOptions ro;
  ro.supersample = 2;
  ro.blur_sigma_px = 0.5;
  ro.noise_sigma = 1.0;
  hedgefit::sim::WriteGardenWith(
      dir.string(), rig, {preset},
      [&](const hedgefit::sim::GardenScene& sc, bool right) { return hedgefit::sim::RenderGarden(rig, right, sc, ro); },
      [](const hedgefit::sim::GardenScene& sc, std::size_t i) { return hedgefit::sim::GardenHedgeSurfaceRadius(sc, i); });
}

// A hedge the image's edge cuts says so in its line: the fit saw part of the ball, so its centre
// is extrapolated. Half out of the frame on the right; found with the defaults.
TEST(MeasureCli, AHedgeCutByTheFrameSaysSo) {
  const auto dir = hedgefit::testing::ScratchDir();
  WriteHalfScaleGarden(dir / "g", "cut_by_frame");
  const auto r = RunHedgefit("measure --method envelope --rig g/rig.yaml --left g/garden_cut_by_frame_left.png "
                             "--right g/garden_cut_by_frame_right.png",
                             dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto f = nlohmann::json::parse(r.out.substr(0, r.out.find('\n')));
  EXPECT_TRUE(f.value("cut_by_frame", false)) << r.out;
}

// Shrubs beside a ball are taken for hedges by depth (they stand on the lawn, round enough in
// outline) but their fits say they are not a ball: a four-lobed shrub against the ball and a
// two-lobed one apart. The default fit (ransac_ray), ransac_geometric and the envelope fit put a sphere on one
// lobe, with 12-42 % of the shrub's points more than a tenth of its radius outside it
// (fitting::kMaxOutsideShare: 5 %), or one many times wider than the shrub (kMaxSphereToSpan:
// 2.5). The ball has at most 0.1 % of its points so far out and its sphere is 1.3-1.6 times its
// points' span, and it is within 10 mm of its truth (half the paper's resolution, as in
// GardenRowGivesOneJsonLinePerHedgeAndAnOverlay).
// A nearest depth no disparity search can reach in these images (metres typed for mm, say) is
// refused before matching, naming the option and the nearest this rig can match; it aborted
// inside OpenCV (exit 134) before.
TEST(MeasureCli, ANearestDepthTheRigCannotMatchIsRefused) {
  const auto dir = hedgefit::testing::ScratchDir();
  ASSERT_EQ(RunHedgefit("simulate --sphere 70,50,2300,300 --scale 0.5 -o s", dir).code, 0);
  const std::string measure = "measure --rig s/rig.yaml --left s/sphere_left.png --right s/sphere_right.png ";
  for (const std::string z : {"1", "10"}) {
    const Result r = RunHedgefit(measure + "--min-z " + z, dir);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("min_z " + z + " mm (--min-z) needs a disparity of"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("the nearest this rig can match in a 960 px wide image is"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  // The same in convert, and in the depth segmentation (--garden).
  Result r = RunHedgefit("convert --rig s/rig.yaml --left s/sphere_left.png --right s/sphere_right.png -o o.pcd --min-z 5", dir);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("needs a disparity of"), std::string::npos) << r.err;
  r = RunHedgefit(measure + "--garden --min-z 5", dir);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("needs a disparity of"), std::string::npos) << r.err;
}

TEST(MeasureCli, ShrubsTakenForHedgesAreToldNotABall) {
  const auto dir = hedgefit::testing::ScratchDir();
  WriteHalfScaleGarden(dir / "g", "shrubs");
  const auto truth = nlohmann::json::parse(std::ifstream(dir / "g" / "garden_shrubs.truth.json"))["hedges"];
  ASSERT_EQ(truth.size(), 1u);
  for (const std::string method : {"ransac_ray", "ransac_geometric", "envelope"}) {
    const auto r = RunHedgefit("measure --method " + method +
                                   " --rig g/rig.yaml --left g/garden_shrubs_left.png --right g/garden_shrubs_right.png",
                               dir);
    ASSERT_EQ(r.code, 0) << r.err;
    std::istringstream lines(r.out);
    int balls = 0, not_balls = 0;
    for (std::string line; std::getline(lines, line);) {
      const auto f = nlohmann::json::parse(line);
      ASSERT_TRUE(f["converged"].get<bool>()) << line;
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += std::pow(f["center_mm"][k].get<double>() - truth[0]["center_mm"][k].get<double>(), 2);
      if (std::sqrt(d2) < 100) {  // the ball
        ++balls;
        EXPECT_FALSE(f.contains("not_a_ball")) << method << ": " << line;
        EXPECT_NEAR(f["radius_mm"].get<double>(), truth[0]["radius_mm"].get<double>(), 10.0) << method;
      } else {
        ++not_balls;
        EXPECT_TRUE(f.contains("not_a_ball")) << method << ": " << line;
      }
    }
    EXPECT_EQ(balls, 1) << method << ": " << r.out;
    EXPECT_EQ(not_balls, 2) << method << ": " << r.out;  // both shrubs were taken for hedges by depth
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), not_balls) << r.err;  // a warning for each
    EXPECT_NE(r.err.find("not a ball"), std::string::npos) << r.err;
  }
}

// measure: the capture path, cleaning and a fit in one step, one JSON line per hedge.
TEST(MeasureCli, GardenRowGivesOneJsonLinePerHedgeAndAnOverlay) {
  const auto dir = hedgefit::testing::ScratchDir();
  auto r = RunHedgefit("simulate --preset garden --scale 0.5 --supersample 2 -o garden", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string capture = " --rig garden/rig.yaml --left garden/garden_row_left.png --right garden/garden_row_right.png";
  r = RunHedgefit("measure --garden --method envelope --overlay row.png" + capture, dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "row.png"));
  const auto truth = nlohmann::json::parse(std::ifstream(dir / "garden" / "garden_row.truth.json"))["hedges"];
  std::istringstream lines(r.out);
  std::vector<nlohmann::json> fits;
  for (std::string line; std::getline(lines, line);) fits.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(fits.size(), 3u) << r.out;  // three hedges, not the pot
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& f = fits[i];
    EXPECT_EQ(f["hedge"].get<int>(), int(i) + 1);
    EXPECT_EQ(f["method"], "envelope");
    ASSERT_TRUE(f["converged"].get<bool>()) << f.dump();
    EXPECT_EQ(f["image_box"].size(), 4u);
    EXPECT_FALSE(f.contains("cut_by_frame")) << "hedge " << i + 1;  // the row is inside the image
    // As in ConvertCli.GardenRow...: half the paper's resolution doubles the depth error per
    // point, so 10 mm on the radius; the centre, seen from one side, moves along the line of
    // sight about 1.5 times as far as the radius errs. Neighbouring hedges are 1.4 m apart.
    EXPECT_NEAR(f["radius_mm"].get<double>(), truth[i]["radius_mm"].get<double>(), 10.0) << "hedge " << i + 1;
    double d2 = 0;
    for (int k = 0; k < 3; ++k) d2 += std::pow(f["center_mm"][k].get<double>() - truth[i]["center_mm"][k].get<double>(), 2);
    EXPECT_LT(std::sqrt(d2), 15.0) << "hedge " << i + 1;
    EXPECT_GT(f["capture_ms"].get<double>(), 0.0);
  }
  EXPECT_EQ(r.err, "");  // with --garden, no hint to use it
  // By default the colour mask is tried first; here it takes in the lawn and the hedge row (about
  // two thirds of this frame), so every hedge is found by depth instead, with nothing to warn of.
  r = RunHedgefit("measure --method envelope" + capture, dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 3) << r.out;
  EXPECT_EQ(r.err, "");
  // Left and right swapped: nothing matches in the working range, neither by depth nor in the
  // colour mask's region; exit 2 and one line saying what to check (it used to fit the few chance
  // matches and exit 0).
  r = RunHedgefit("measure --rig garden/rig.yaml --left garden/garden_row_right.png --right garden/garden_row_left.png",
                  dir);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.err.find("match between the views: the images are not a stereo pair of this rig, left and right are "
                       "swapped, or the hedge lies outside --min-z/--max-z"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  // Forced to the colour mask (--garden-above 0), the fit may find one ball, so stderr says to use
  // --garden.
  r = RunHedgefit("measure --garden-above 0" + capture, dir);
  EXPECT_NE(r.err.find("hedgefit: warning: garden/garden_row_left.png: the colour mask covers "), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--garden finds every hedge by depth"), std::string::npos) << r.err;
  // The pipeline it runs, as JSON; a bad method or an overlay into a missing directory is one
  // line naming the flag, before any work, and writes nothing.
  r = RunHedgefit("measure --print-pipeline --method kasa" + capture, dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("\"fitters.algebraic\""), std::string::npos) << r.out;
  r = RunHedgefit("measure --method bogus" + capture, dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err.rfind("hedgefit: --method: unknown method 'bogus'", 0), 0u) << r.err;
  r = RunHedgefit("measure --overlay missing/o.png" + capture, dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --overlay missing/o.png: directory 'missing' does not exist; create it first\n");
  // No hedge in the working range: exit 2, one line, no overlay.
  r = RunHedgefit("measure --garden --min-z 8000 --max-z 9000 --overlay none.png" + capture, dir);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "none.png"));
}

// A rig whose rows no longer agree (the right camera moved by a pixel's height since calibration):
// measure removes the offset before its refinement, still fits the sphere, and says to recalibrate.
TEST(MeasureCli, MisalignedRowsAreRemovedAndReportedAndCheckRigSaysSo) {
  const auto dir = hedgefit::testing::ScratchDir();
  auto r = RunHedgefit("simulate --sphere 70,50,2300,300 --scale 0.5 -o sim", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string rig = " --rig sim/rig.yaml --left sim/sphere_left.png";
  auto radius = [](const std::string& out) {
    return nlohmann::json::parse(out.substr(0, out.find('\n')))["radius_mm"].get<double>();
  };
  r = RunHedgefit("measure" + rig + " --right sim/sphere_right.png", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");  // aligned rows: nothing to say
  const double aligned = radius(r.out);
  // Every right-image row one down: the left pixel (x, y) is seen at row y + 1.
  const cv::Mat right = cv::imread((dir / "sim" / "sphere_right.png").string());
  cv::Mat moved = right.clone();
  right.rowRange(0, right.rows - 1).copyTo(moved.rowRange(1, right.rows));
  ASSERT_TRUE(cv::imwrite((dir / "sim" / "moved_right.png").string(), moved));
  r = RunHedgefit("measure" + rig + " --right sim/moved_right.png", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  // The capture's rig check sees it (stereo.rig_check): the rows 1 px apart around the hedge and
  // in the frame's plane, the interval widened by what that can cost, a warning to recalibrate.
  const std::string said = "hedgefit: warning: sim/sphere_left.png: the rectified rows are ";
  ASSERT_EQ(r.err.rfind(said, 0), 0u) << r.err;
  EXPECT_NEAR(std::stod(r.err.substr(said.size())), 1.0, 0.1) << r.err;
  EXPECT_NE(r.err.find("recalibrate"), std::string::npos) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out.substr(0, r.out.find('\n')))["rig_check"], "widened") << r.out;
  // With the offset removed the fit is as good as with aligned rows: within 1 mm, three times
  // the radius's spread over the lab's seven positions at full size.
  EXPECT_NEAR(radius(r.out), aligned, 1.0);
  EXPECT_NEAR(radius(r.out), 300.0, 2.0);
  // Refined along the rows as they are, the sphere comes out several mm small.
  r = RunHedgefit("measure" + rig + " --right sim/moved_right.png --no-correct-vertical", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GT(std::abs(radius(r.out) - aligned), 2.0);
  // check-rig over the whole frame: the exact rig leaves the rows within a tenth of a pixel (the
  // windows settle to ~0.02 px; the sphere's curved flanks add a few hundredths); the moved
  // image is 1 px out everywhere, exit 2.
  r = RunHedgefit("check-rig --json" + rig + " --right sim/sphere_right.png", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_LT(j["max_abs_px"].get<double>(), 0.1) << r.out;
  EXPECT_TRUE(j["fits"].get<bool>());
  r = RunHedgefit("check-rig --json" + rig + " --right sim/moved_right.png", dir);
  EXPECT_EQ(r.code, 2) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["offset_px"].get<double>(), 1.0, 0.1) << r.out;
  EXPECT_FALSE(j["fits"].get<bool>());
  r = RunHedgefit("check-rig" + rig + " --right sim/moved_right.png", dir);
  EXPECT_NE(r.out.find("recalibrate"), std::string::npos) << r.out;
  // Bad input: one line naming what to fix, exit 1.
  r = RunHedgefit("check-rig" + rig + " --right sim/missing.png", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("sim/missing.png"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  cv::Mat small;
  cv::resize(moved, small, cv::Size(moved.cols / 2, moved.rows / 2));
  ASSERT_TRUE(cv::imwrite((dir / "sim" / "small_right.png").string(), small));
  r = RunHedgefit("check-rig" + rig + " --right sim/small_right.png", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("use the rig of these cameras"), std::string::npos) << r.err;
  // A nearest depth of 1 mm would search disparities wider than the image.
  r = RunHedgefit("check-rig --min-z 1" + rig + " --right sim/sphere_right.png", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err.rfind("hedgefit: --min-z 1: ", 0), 0u) << r.err;
}

TEST(ConvertCli, StageFlagErrorsNameTheFlag) {
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string one = "convert --left l.png --right r.png --rig rig.yaml -o o.pcd ";
  Result r = RunHedgefit(one + "--block-size 40", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --block-size: 40 is out of range; use a value in [1, 31] px\n");
  r = RunHedgefit(one + "--block-size 4", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --block-size: must be odd (1, 3, 5, ... 31 px)\n");
  r = RunHedgefit(one + "--mode hhh", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --mode: 'hhh' is not one of hh, sgbm, 3way, hh4 (did you mean 'hh'?)\n");
  r = RunHedgefit(one + "--mask m.png --box 1,2,30,40", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --mask, --box and --garden: give one way to find the hedge, not several\n");
  r = RunHedgefit(one + "--input somewhere", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --input and --left/--right: give one capture or a batch, not both\n");
  // An output that is not a cloud file: refused before the rig or images are read, naming -o
  // (not the writer's temporary file after the work, as it was).
  r = RunHedgefit("convert --left l.png --right r.png --rig rig.yaml -o o.foo", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: -o o.foo: not a cloud file name; end it in .pcd, .ply, .xyz or .las\n");
  fs::create_directories(dir / "out");
  for (const std::string out : {"out", "out/"}) {
    r = RunHedgefit("convert --left l.png --right r.png --rig rig.yaml -o " + out, dir);
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "hedgefit: -o " + out + ": is a directory; give a file name in it\n");
  }
  // The equivalent pipeline, printed without reading anything.
  r = RunHedgefit(one + "--box 1,2,30,40 --erode 2 --print-pipeline", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.size(), 8u);
  EXPECT_EQ(j[2]["type"], "stereo.segment_depth");
  EXPECT_EQ(j[2]["box"], nlohmann::json({1.0, 2.0, 30.0, 40.0}));
  EXPECT_EQ(j[2]["erode"], 2);
  EXPECT_EQ(j[4]["type"], "stereo.rig_check");  // every capture checks its rig
  EXPECT_EQ(j[6]["filename"], "o.pcd");
  EXPECT_EQ(j[7]["type"], "writers.outline");  // the outline beside the cloud, for compare's envelope
  EXPECT_EQ(j[7]["filename"], "o.pcd.outline.json");
}

// Every number of a rig is checked when it is made or read: non-finite or absurd values are one
// line naming the option or the key, never a crash later in convert.
TEST(RigCli, NonFiniteAndAbsurdNumbersAreRejected) {
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string base = "rig --size 640x480 -o rig.yaml";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {" --focal 368 --cx 318 --cy 224 --baseline inf", "hedgefit: --baseline: must be in 0.1..100000 mm\n"},
      {" --focal 368 --cx 318 --cy 224 --baseline 1e300", "hedgefit: --baseline: must be in 0.1..100000 mm\n"},
      {" --focal 368 --cx 318 --cy 224 --baseline 0", "hedgefit: --baseline: must be in 0.1..100000 mm\n"},
      {" --focal 368 --cx nan --cy 224 --baseline 838", "hedgefit: --cx/cy: must be finite numbers (px)\n"},
      {" --focal 1e-300 --cx 318 --cy 224 --baseline 838", "hedgefit: --focal: must be in 1..1e6 px\n"}};
  for (const auto& [args, err] : cases) {
    const Result r = RunHedgefit(base + args, dir);
    EXPECT_EQ(r.code, 1) << args;
    EXPECT_EQ(r.err, err) << args;
    EXPECT_FALSE(fs::exists(dir / "rig.yaml")) << args;
  }
  // A rig file with a NaN in T, or T = 0, is refused when read, before any image is touched.
  Result r = RunHedgefit(base + " --focal 368 --cx 318 --cy 224 --baseline 838", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string good = Slurp(dir / "rig.yaml");
  // A missing or unreadable image of a single capture is bad input (exit 1), not a failure.
  std::ofstream(dir / "notes.png") << "not a png";
  r = RunHedgefit("convert --left missing.png --right notes.png --rig rig.yaml -o x.pcd", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: missing.png: no such image file; check the path\n");
  // A PNG cut short is found only when the pipeline reads it; it is still the input's fault.
  std::ofstream(dir / "cut.png", std::ios::binary) << std::string("\x89PNG\r\n\x1a\n", 8) << std::string(100, 'x');
  for (const std::string& cmd : {std::string("convert --left cut.png --right cut.png --rig rig.yaml -o x.pcd"),
                                 std::string("measure --left cut.png --right cut.png --rig rig.yaml")}) {
    r = RunHedgefit(cmd, dir);
    EXPECT_EQ(r.code, 1) << cmd;
    EXPECT_NE(r.err.find("cut.png: the PNG file is cut short (no IEND chunk)"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "x.pcd"));
  }
  std::filesystem::create_directories(dir / "shots");
  r = RunHedgefit("convert --left shots --right notes.png --rig rig.yaml -o x.pcd", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: shots: is a directory; give the image file in it\n");
  r = RunHedgefit("convert --left notes.png --right notes.png --rig rig.yaml -o x.pcd", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: notes.png: not a PNG, JPEG, TIFF, BMP or PNM image; give the camera's PNG or JPEG file\n");
  for (const std::string& t : {std::string(".nan, 0., 0."), std::string("0., 0., 0.")}) {
    std::string bad = good;
    const auto at = bad.find("data: [", bad.find("\nT: "));
    bad.replace(at, bad.find(']', at) - at + 1, "data: [ " + t + " ]");
    std::ofstream(dir / "bad.yaml") << bad;
    r = RunHedgefit("convert --left l.png --right r.png --rig bad.yaml -o x.pcd", dir);
    EXPECT_EQ(r.code, 1) << t;
    EXPECT_EQ(r.err.rfind("hedgefit: bad.yaml: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(t[0] == '.' ? "'T' holds a NaN" : "the baseline |T| is 0.000000 mm"), std::string::npos) << r.err;
  }
}

// An output that names one of the command's inputs (by any path) is refused before any work, and
// the input is left as it was: `--overlay` over the right image used to replace the capture with
// the drawing. An image output whose extension the writer does not write is refused too.
TEST(OutputsCli, AnOutputThatIsAnInputIsRefusedAndTheInputKept) {
  const auto dir = hedgefit::testing::ScratchDir();
  ASSERT_EQ(RunHedgefit("rig --size 64x48 --focal 60 --cx 32 --cy 24 --baseline 100 -o rig.yaml", dir).code, 0);
  cv::Mat img(48, 64, CV_8UC3, cv::Scalar(20, 200, 40));
  ASSERT_TRUE(cv::imwrite((dir / "l.png").string(), img) && cv::imwrite((dir / "r.png").string(), img));
  const std::string right = Slurp(dir / "r.png");
  Result r = RunHedgefit("measure --left l.png --right r.png --rig rig.yaml --overlay ./r.png", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --overlay ./r.png: is the input r.png; write it to another file\n");
  EXPECT_EQ(Slurp(dir / "r.png"), right);
  r = RunHedgefit("measure --left l.png --right r.png --rig rig.yaml --overlay o.bmpx", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --overlay o.bmpx: not an image file name this writes; end it in .png or .jpg or .jpeg\n");
  const fs::path cloud = fs::path(HEDGEFIT_SOURCE_DIR) / "sample_clouds" / "cap_z2300_a60_o0.pcd";
  fs::copy_file(cloud, dir / "c.pcd");
  const std::string before = Slurp(dir / "c.pcd");
  r = RunHedgefit("trim c.pcd --radius 280 -o " + (dir / "c.pcd").string(), dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(": is the input c.pcd; write it to another file"), std::string::npos) << r.err;
  EXPECT_EQ(Slurp(dir / "c.pcd"), before);
  r = RunHedgefit("render c.pcd -o c.jpg", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: -o c.jpg: not an image file name this writes; end it in .png\n");
  EXPECT_FALSE(fs::exists(dir / "c.jpg"));
}

}  // namespace

// The issue's nominal rig (the right size and focal length, the principal point at the centre,
// 140 mm) on a capture of the paper's rig: before, `measure` gave the centre 250-300 mm off inside
// a +-27 mm interval and exit 0. Every capture now checks its rig against its own images: the
// rows are over 10 px apart, so the result is unusable (exit 3, the line says why, a warning),
// and `convert` says so too. The exact rig draws nothing: rig_check "ok", exit 0.
TEST(MeasureCli, ARigThatNoLongerFitsTheCamerasIsUnusableNotConfident) {
  const auto dir = hedgefit::testing::ScratchDir();
  ASSERT_EQ(RunHedgefit("simulate --sphere 70,50,2300,300 -o s", dir).code, 0);
  ASSERT_EQ(RunHedgefit("rig --size 1920x1200 --focal 933.3 --cx 960 --cy 600 --baseline 140 -o nominal.yaml", dir).code, 0);
  const std::string pair = " --left s/sphere_left.png --right s/sphere_right.png";
  Result r = RunHedgefit("measure --rig s/rig.yaml" + pair, dir);
  ASSERT_EQ(r.code, 0) << r.err;
  auto line = nlohmann::json::parse(r.out.substr(0, r.out.find('\n')));
  EXPECT_EQ(line.value("rig_check", ""), "ok");
  EXPECT_FALSE(line.contains("unusable"));
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;

  r = RunHedgefit("measure --rig nominal.yaml" + pair, dir);
  ASSERT_EQ(r.code, 3) << r.err;
  line = nlohmann::json::parse(r.out.substr(0, r.out.find('\n')));
  EXPECT_EQ(line.value("rig_check", ""), "unusable");
  EXPECT_NE(line.value("unusable", "").find("does not fit these cameras"), std::string::npos) << line.dump();
  EXPECT_GT(line.value("rig_rows_frame_px", 0.0), 2.0);
  EXPECT_NE(r.err.find("warning: s/sphere_left.png: unusable: "), std::string::npos) << r.err;

  r = RunHedgefit("convert --rig nominal.yaml" + pair + " -o o.pcd", dir);
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("does not fit these cameras"), std::string::npos) << r.err;
}

// --square in metres (0.025 for 25 mm) used to write a 0.08 "mm" baseline without a word, and the
// next measure matched nothing. hedgefit reads rigs in mm: a baseline outside 20 mm-2 m draws a
// warning naming --square's unit; the same boards at 25 mm give an 83 mm baseline and none.
TEST(CalibrateCli, ASquareInMetresGetsAWarningNamingItsUnit) {
  HEDGEFIT_REQUIRE_DATA("calib_chessboard/left01.jpg");
  const auto dir = hedgefit::testing::ScratchDir();
  const std::string data = hedgefit::testing::DataPath("calib_chessboard");
  const std::string boards = "calibrate --left '" + data + "/left*.jpg' --right '" + data + "/right*.jpg' --board 9x6 -o rig.yaml";
  Result r = RunHedgefit(boards + " --square 0.025", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("warning: the baseline is 0.08323 in --square's unit"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("give --square in mm"), std::string::npos) << r.out;
  r = RunHedgefit(boards + " --square 25", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ((r.out + r.err).find("give --square in mm"), std::string::npos) << r.out;
}

// Some other file given as the rig: "image_width and image_height must be positive" before; now
// it says it is not a rig file. A baseline_mm that disagrees with |T| (.nan, edited by hand) was
// read without a word; now it names the key.
TEST(RigCli, AFileThatIsNotARigSaysSoAndABaselineThatDisagreesIsNamed) {
  const auto dir = hedgefit::testing::ScratchDir();
  std::ofstream(dir / "pipeline.json") << R"({"pipeline": [{"type": "readers.pcd", "filename": "a.pcd"}]})";
  std::ofstream(dir / "camera.yaml") << "%YAML:1.0\n---\ncamera_name: left\nexposure_us: 1200\n";
  for (const std::string file : {"pipeline.json", "camera.yaml"}) {
    const Result r = RunHedgefit("measure --rig " + file + " --left l.png --right r.png", dir);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_EQ(r.err, "hedgefit: " + file + ": not a rig file (it has none of image_width, K1, K2, R, T); give the file "
                     "`hedgefit calibrate` or `hedgefit rig` wrote\n");
  }
  ASSERT_EQ(RunHedgefit("rig --size 640x480 --focal 368 --cx 318 --cy 224 --baseline 140 -o rig.yaml", dir).code, 0);
  std::string text = Slurp(dir / "rig.yaml");
  const auto at = text.find("baseline_mm: ");
  ASSERT_NE(at, std::string::npos) << text;
  text.replace(at, text.find('\n', at) - at, "baseline_mm: .nan");
  std::ofstream(dir / "nan.yaml") << text;
  const Result r = RunHedgefit("check-rig --rig nan.yaml --left l.png --right r.png", dir);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("nan.yaml: key 'baseline_mm' is not a number but |T| is 140 mm"), std::string::npos) << r.err;
}

// Smaller confident or confusing answers of the issue, each as a user meets it:
// - --max-z in metres said "--min-z/'max_z': need min_z < max_z (mm)"; now it names the flag as
//   typed, the unit and the value it likely meant;
// - an overlay that cannot be written (/proc takes no new files, even for root) named the input
//   image and a hidden staged file, and the measurement was lost; now it names --overlay's path,
//   the JSON lines are printed and the error says no overlay was kept;
// - convert --mask (the user's own mask) warned that "the colour mask covers 96 % of the frame".
TEST(MeasureCli, MessagesNameWhatTheUserTypedAndKeepWhatWasMeasured) {
  const auto dir = hedgefit::testing::ScratchDir();
  ASSERT_EQ(RunHedgefit("simulate --sphere 70,50,2300,300 --scale 0.5 -o s", dir).code, 0);
  const std::string measure = "measure --rig s/rig.yaml --left s/sphere_left.png --right s/sphere_right.png";
  Result r = RunHedgefit(measure + " --max-z 3.5", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --max-z: 3.5 mm is not beyond --min-z (1000 mm); depths are in mm (3500 for 3.5 m)\n");
  r = RunHedgefit(measure + " --overlay /proc/hedgefit_overlay.png", dir);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("hedgefit: --overlay /proc/hedgefit_overlay.png: cannot be written"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the measurements were printed, no overlay was kept"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(".staged"), std::string::npos) << r.err;
  ASSERT_FALSE(r.out.empty());
  EXPECT_NEAR(nlohmann::json::parse(r.out.substr(0, r.out.find('\n')))["radius_mm"].get<double>(), 300.0, 3.0);
  // A mask covering most of the frame, the user's own: no hint about the colour mask.
  cv::Mat mask(600, 960, CV_8U, cv::Scalar(255));
  ASSERT_TRUE(cv::imwrite((dir / "mask.png").string(), mask));
  r = RunHedgefit("convert --rig s/rig.yaml --left s/sphere_left.png --right s/sphere_right.png --mask mask.png -o o.pcd",
                  dir);
  EXPECT_EQ(r.err.find("colour mask covers"), std::string::npos) << r.err;
}

// convert --full-frame --organized is a dense map of the whole frame: it thinned a large hedge to
// every s-th pixel and row (max_points, 60,000) without a word. It now keeps every pixel unless
// --max-points is given. The paper's outdoor ball at half size covers about 75,000 pixels: kept
// whole it gives over 60,000 points, thinned to every 2nd pixel and row under 30,000.
TEST(ConvertCli, FullFrameOrganizedKeepsEveryPixel) {
  const auto dir = hedgefit::testing::ScratchDir();
  WriteHalfScaleGarden(dir / "g", "outdoor");
  const std::string convert = "convert --rig g/rig.yaml --left g/garden_outdoor_left.png "
                              "--right g/garden_outdoor_right.png --full-frame --organized -o o.pcd";
  auto finite_points = [&]() {
    std::size_t n = 0;
    for (const auto& p : hedgefit::cloud::ReadCloud((dir / "o.pcd").string()).points_mm) n += p.allFinite();
    return n;
  };
  Result r = RunHedgefit(convert, dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(hedgefit::cloud::ReadCloud((dir / "o.pcd").string()).size(), 960u * 600u);
  EXPECT_GT(finite_points(), 60000u);
  r = RunHedgefit(convert + " --max-points 60000", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_LT(finite_points(), 30000u);
}
