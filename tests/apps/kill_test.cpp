// A run killed with SIGKILL mid-write leaves no partial file under an output's final name: every
// output is written to a hidden name beside it and renamed only when the run has succeeded
// (pipelines) or the file is complete (each capture of a batch). Killed at many moments, the
// final name holds either what was there before or a complete, readable cloud.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "cloud/cloud_io.hpp"
#include "cloud/outline_io.hpp"
#include "pipeline/error.hpp"
#include "tests/test_data.hpp"

namespace {

namespace fs = std::filesystem;

// Starts hedgefit with `args` in `cwd` (output discarded), kills it after `delay` unless it has
// finished, reaps it.
void RunAndKill(const std::vector<std::string>& args, const fs::path& cwd, std::chrono::milliseconds delay) {
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (chdir(cwd.c_str()) != 0) _exit(127);
    freopen("/dev/null", "w", stdout);
    freopen("/dev/null", "w", stderr);
    std::vector<char*> argv;
    std::string exe = HEDGEFIT_EXE;
    argv.push_back(exe.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(HEDGEFIT_EXE, argv.data());
    _exit(127);
  }
  // Kill at `delay`, unless it has finished by then.
  const auto until = std::chrono::steady_clock::now() + delay;
  int status = 0;
  while (std::chrono::steady_clock::now() < until) {
    if (waitpid(pid, &status, WNOHANG) == pid) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
}

hedgefit::cloud::PointCloud Ball(std::size_t n) {
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0.f, 1.f);
  hedgefit::cloud::PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3f u(g(rng), g(rng), g(rng));
    c.points_mm.push_back(Eigen::Vector3f(0, 0, 2300) + 300.f * u.normalized());
  }
  c.Flatten();
  return c;
}

TEST(Kill, APipelineKilledMidWriteLeavesTheOldFileOrAWholeOne) {
  const fs::path dir = hedgefit::testing::ScratchDir();
  const std::size_t n = 400000;  // ASCII output of ~12 MB: a write that takes a while
  hedgefit::cloud::WriteCloud((dir / "in.pcd").string(), Ball(n));
  hedgefit::cloud::PointCloud old = Ball(10);
  std::ofstream((dir / "p.json").string()) << R"(["in.pcd", {"type": "writers.pcd", "filename": "out.pcd", "encoding": "ascii"}])";
  int whole = 0, kept = 0;
  for (int ms : {5, 20, 60, 120, 200, 300, 450, 650, 900, 1300, 2000, 10000}) {
    hedgefit::cloud::WriteCloud((dir / "out.pcd").string(), old);
    RunAndKill({"pipeline", "p.json", "-q"}, dir, std::chrono::milliseconds(ms));
    ASSERT_TRUE(fs::exists(dir / "out.pcd"));
    const hedgefit::cloud::PointCloud got = hedgefit::cloud::ReadCloud((dir / "out.pcd").string());  // throws if partial
    ASSERT_TRUE(got.size() == old.size() || got.size() == n) << "killed after " << ms << " ms: " << got.size() << " points";
    (got.size() == n ? whole : kept)++;
  }
  // Both outcomes happened: the kills did land before and after the write finished.
  EXPECT_GT(kept, 0);
  EXPECT_GT(whole, 0);
}

TEST(Kill, ABatchConvertKilledMidRunLeavesOnlyWholeClouds) {
  const fs::path dir = hedgefit::testing::ScratchDir();
  // Six small captures of the simulated lab sphere, all alike.
  ASSERT_EQ(std::system(("cd '" + dir.string() + "' && '" HEDGEFIT_EXE "' simulate --sphere 70,50,2300,300 --scale 0.5 "
                         "--supersample 1 -o sim > /dev/null")
                            .c_str()),
            0);
  fs::create_directories(dir / "in");
  for (int i = 0; i < 6; ++i) {
    fs::copy_file(dir / "sim/sphere_left.png", dir / "in" / ("c" + std::to_string(i) + "_left.png"));
    fs::copy_file(dir / "sim/sphere_right.png", dir / "in" / ("c" + std::to_string(i) + "_right.png"));
  }
  ASSERT_EQ(std::system(("cd '" + dir.string() + "' && '" HEDGEFIT_EXE "' rig --size 960x600 --focal 466.65 --cx 479.5 "
                         "--cy 299.5 --baseline 140 -o rig.yaml > /dev/null")
                            .c_str()),
            0);
  std::size_t complete = 0;
  for (int ms : {150, 400, 700, 1000, 1500, 30000}) {  // the last lets it finish (slow builds)
    fs::remove_all(dir / "out");
    RunAndKill({"convert", "--input", "in", "--rig", "rig.yaml", "--output-dir", "out", "--threads", "1",
                "--full-frame", "--min-z", "1500", "--max-z", "3500"},
               dir, std::chrono::milliseconds(ms));
    if (!fs::exists(dir / "out")) continue;
    for (const auto& e : fs::directory_iterator(dir / "out")) {
      const std::string name = e.path().filename().string();
      if (name[0] == '.') continue;  // a hidden temporary: allowed to be partial
      // Each capture's outline beside its cloud (cloud/outline_io.hpp), written atomically too.
      if (name.size() > 13 && name.compare(name.size() - 13, 13, ".outline.json") == 0) {
        EXPECT_NO_THROW(hedgefit::cloud::ReadOutlines(e.path().string())) << "killed after " << ms << " ms: " << name;
        continue;
      }
      EXPECT_NO_THROW(hedgefit::cloud::ReadCloud(e.path().string())) << "killed after " << ms << " ms: " << name;
      ++complete;
    }
  }
  EXPECT_GT(complete, 0u) << "no kill landed after a capture was written; the runs are too fast for this test";
}

}  // namespace
