#pragma once
// Running the hedgefit executable from the CLI tests.

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace hedgefit::testing {

struct CliResult {
  int code = -1;     ///< exit status, -1 if it did not exit normally
  std::string out;   ///< stdout
  std::string err;   ///< stderr
};

inline std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs `exe args` from `cwd` with DISPLAY unset (as on CI), capturing both streams in
/// files under `scratch`.
inline CliResult RunCli(const std::string& exe, const std::string& args, const std::filesystem::path& cwd,
                        const std::filesystem::path& scratch, const std::string& env = "") {
  const std::filesystem::path out = scratch / "cli_stdout.txt", err = scratch / "cli_stderr.txt";
  const std::string cmd = "cd '" + cwd.string() + "' && env -u DISPLAY " + env + " '" + exe + "' " + args + " >'" +
                          out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = Slurp(out);
  r.err = Slurp(err);
  return r;
}

}  // namespace hedgefit::testing
