#pragma once
// Timing and option helpers shared by the benchmarks.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace hedgefit::bench {

/// Median wall time of `repeats` calls of fn, in ms.
template <class Fn>
double MedianMs(int repeats, Fn&& fn) {
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

/// Reads `--name value` pairs through take(name, value), which returns false for a name it does
/// not know, and single words (a flag, or a positional argument such as a file) through
/// single(word), which returns false for a word it does not take. -h or --help prints `usage` and
/// gives 0; a name with no value or an unknown one says so with the usage on stderr and gives 2;
/// otherwise -1 (go on).
inline int ParseOptions(int argc, char** argv, const char* program, const char* usage,
                        const std::function<bool(const std::string&, const char*)>& take,
                        const std::function<bool(const std::string&)>& single) {
  for (int i = 1; i < argc;) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::printf("usage: %s %s\n", program, usage);
      return 0;
    }
    if (single && single(a)) {
      ++i;
      continue;
    }
    const char* why = i + 1 >= argc ? "needs a value" : (take(a, argv[i + 1]) ? nullptr : "is not an option");
    if (why) {
      std::fprintf(stderr, "%s: %s %s\nusage: %s %s\n", program, a.c_str(), why, program, usage);
      return 2;
    }
    i += 2;
  }
  return -1;
}

/// ParseOptions with `--name value` pairs only.
inline int ParseOptionPairs(int argc, char** argv, const char* program, const char* usage,
                            const std::function<bool(const std::string&, const char*)>& take) {
  return ParseOptions(argc, argv, program, usage, take, nullptr);
}

}  // namespace hedgefit::bench
