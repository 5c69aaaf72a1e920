// hedgefit stream on video files (the device code is OpenCV's VideoCapture, the same calls),
// a side-by-side video and a watched directory: one JSON line per hedge and frame, in order,
// each within the capture's tolerance of the simulator's truth.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "tests/cli_helpers.hpp"
#include "tests/test_data.hpp"

namespace {

namespace fs = std::filesystem;

hedgefit::testing::CliResult RunHedgefit(const std::string& args, const fs::path& scratch) {
  return hedgefit::testing::RunCli(HEDGEFIT_EXE, args, scratch, scratch);  // relative paths in the scratch dir
}

std::vector<nlohmann::json> Lines(const std::string& out) {
  std::vector<nlohmann::json> v;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) v.push_back(nlohmann::json::parse(line));
  return v;
}

constexpr int kZ[3] = {2100, 2300, 2500};

// Half the paper's resolution: the lab's 0.5 mm becomes about 1-2 mm; 4 mm on the radius and
// 8 mm on the centre still catch a frame measured against the wrong truth (the spheres are
// 200 mm apart) or a wrong rig.
void ExpectSphere(const nlohmann::json& f, int z) {
  ASSERT_TRUE(f.value("converged", false)) << f.dump();
  EXPECT_NEAR(f["radius_mm"].get<double>(), 300.0, 4.0) << f.dump();
  const double dx = f["center_mm"][0].get<double>() - 70, dy = f["center_mm"][1].get<double>() - 50,
               dz = f["center_mm"][2].get<double>() - z;
  EXPECT_LT(std::sqrt(dx * dx + dy * dy + dz * dz), 8.0) << f.dump();
}

TEST(StreamCli, VideosSideBySideAndAWatchedDirectory) {
  const auto dir = hedgefit::testing::ScratchDir();
  std::vector<cv::Mat> lefts, rights;
  for (int z : kZ) {
    const std::string sub = "z" + std::to_string(z);
    const auto r = RunHedgefit("simulate --sphere 70,50," + std::to_string(z) + ",300 --scale 0.5 -o " + sub, dir);
    ASSERT_EQ(r.code, 0) << r.err;
    lefts.push_back(cv::imread((dir / sub / "sphere_left.png").string()));
    rights.push_back(cv::imread((dir / sub / "sphere_right.png").string()));
  }
  const cv::Size size = lefts[0].size();
  // FFV1 (lossless, FFmpeg): the frames arrive as rendered. MJPEG at its best quality loses
  // ~1.7 grey levels in 8x8 blocks that stay put while the scene shifts between the views, and
  // that moves this half-resolution sphere by 7-14 mm (see README, `stream`).
  const int codec = cv::VideoWriter::fourcc('F', 'F', 'V', '1');
  {
    cv::VideoWriter l((dir / "left.avi").string(), codec, 5, size), r((dir / "right.avi").string(), codec, 5, size);
    cv::VideoWriter sbs((dir / "sbs.avi").string(), codec, 5, cv::Size(size.width * 2, size.height));
    ASSERT_TRUE(l.isOpened() && r.isOpened() && sbs.isOpened()) << "OpenCV's FFmpeg cannot write FFV1";
    for (std::size_t i = 0; i < 3; ++i) {
      l.write(lefts[i]), r.write(rights[i]);
      cv::Mat both;
      cv::hconcat(lefts[i], rights[i], both);
      sbs.write(both);
    }
  }
  // Two videos: every frame, in order, none dropped (files are not live).
  auto r = RunHedgefit("stream --rig z2100/rig.yaml --left left.avi --right right.avi", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  auto lines = Lines(r.out);
  ASSERT_EQ(lines.size(), 3u) << r.out;
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(lines[std::size_t(i)]["frame"].get<int>(), i);
    EXPECT_FALSE(lines[std::size_t(i)].contains("dropped"));
    ExpectSphere(lines[std::size_t(i)], kZ[i]);
  }
  EXPECT_NE(r.err.find("stream: 3 frames, 0 dropped"), std::string::npos) << r.err;
  // One side-by-side video, stopped after two frames.
  r = RunHedgefit("stream --rig z2100/rig.yaml --side-by-side sbs.avi --max-frames 2", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  lines = Lines(r.out);
  ASSERT_EQ(lines.size(), 2u) << r.out;
  ExpectSphere(lines[1], kZ[1]);
  // A directory the captures arrived in, every one measured (--no-drop), named.
  fs::create_directories(dir / "incoming");
  for (int z : kZ) {
    const std::string sub = "z" + std::to_string(z);
    fs::copy_file(dir / sub / "sphere_left.png", dir / "incoming" / (sub + "_left.png"));
    fs::copy_file(dir / sub / "sphere_right.png", dir / "incoming" / (sub + "_right.png"));
  }
  // A damaged capture among them is retried while it might still be being written, then reported
  // with its error when the stream stops, not skipped in silence.
  std::ofstream(dir / "incoming" / "bad_left.png") << "not a png";
  std::ofstream(dir / "incoming" / "bad_right.png") << "not a png";
  r = RunHedgefit("stream --rig z2100/rig.yaml --watch incoming --idle-timeout 0.5 --no-drop", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  lines = Lines(r.out);
  ASSERT_EQ(lines.size(), 4u) << r.out;
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(lines[std::size_t(i)]["name"], "z" + std::to_string(kZ[i]));
    ExpectSphere(lines[std::size_t(i)], kZ[i]);
  }
  EXPECT_EQ(lines[3]["name"], "bad");
  EXPECT_EQ(lines[3]["hedges"], 0);
  EXPECT_NE(lines[3]["message"].get<std::string>().find("bad_left.png: not a PNG, JPEG, TIFF, BMP or PNM image"),
            std::string::npos)
      << lines[3].dump();
  // Bad sources: one line naming the flag, exit 1.
  r = RunHedgefit("stream --rig z2100/rig.yaml --left left.avi", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --left and --right: give both (video files or camera numbers)\n");
  r = RunHedgefit("stream --rig z2100/rig.yaml --left missing.avi --right right.avi", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "hedgefit: --left missing.avi: no such video file or camera number\n");
  // A directory nothing arrives in: exit 2 and one line saying so.
  fs::create_directories(dir / "empty");
  r = RunHedgefit("stream --rig z2100/rig.yaml --watch empty --idle-timeout 0.2", dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("hedgefit: --watch empty: no capture arrived within 0.2 s"), std::string::npos) << r.err;
  r = RunHedgefit("stream --rig z2100/rig.yaml --left left.avi --right right.avi --watch incoming", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("give one source"), std::string::npos) << r.err;
}

}  // namespace
