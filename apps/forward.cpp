// hedgefit simulate / hedgefit bench handed to hedgefit-bench, the program beside this one that
// links the simulator and the benches (as git hands `git foo` to git-foo), so the hedgefit a robot
// runs carries neither.

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "apps/commands.hpp"

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

}  // namespace hedgefit::apps
