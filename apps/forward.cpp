// What hedgefit and hedgefit-bench share at start-up, and hedgefit simulate / hedgefit bench
// handed to hedgefit-bench, the program beside this one that
// links the simulator and the benches (as git hands `git foo` to git-foo), so the hedgefit a robot
// runs carries neither.

#include <malloc.h>
#include <opencv2/core/utils/logger.hpp>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "fitting/methods.hpp"

namespace hedgefit::apps {

namespace {

// The folder this program was started from (/proc/self/exe, so symlinks and PATH lookups resolve).
std::string OwnFolder() {
  std::vector<char> buf(4096);
  const ssize_t n = readlink("/proc/self/exe", buf.data(), buf.size() - 1);
  if (n <= 0) return ".";
  std::string path(buf.data(), std::size_t(n));
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

}  // namespace

int ForwardToBenchProgram(int argc, char** argv) {
  if (argc < 2) return -1;
  const std::string command = argv[1];
  if (command != "simulate" && command != "bench") return -1;
  const std::string program = OwnFolder() + "/" + kBenchProgram;
  std::vector<char*> args(argv, argv + argc);
  args.push_back(nullptr);
  execv(program.c_str(), args.data());
  std::fprintf(stderr,
               "hedgefit %s: cannot run %s (%s); it is built beside hedgefit by 'cmake --build build --target hedgefit' "
               "and installed with it\n",
               command.c_str(), program.c_str(), std::strerror(errno));
  return kExitBadInput;
}

void PrepareProcess() {
  // Each capture allocates and frees images of several megabytes (rectified views, B-spline
  // coefficients, disparity maps). glibc serves blocks that large from fresh mmap'd pages that the
  // kernel must fault in and zero every time: a tenth of a garden capture's CPU time. Served
  // from the heap and reused instead, a row of three hedges measures 5 % faster in `stream`
  // (488-497 -> 460-465 ms per frame) and peaks lower (433 -> 392 MB).
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // hedgefit reports problems itself, one line each: OpenCV's own warnings would come first.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  hedgefit::fitting::QuietSolverWarnings();  // and Ceres' (glog) warnings: each fit reports its own trouble
}

}  // namespace hedgefit::apps
