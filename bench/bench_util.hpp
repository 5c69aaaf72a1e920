#pragma once
// Timing helper shared by the benchmarks.

#include <algorithm>
#include <chrono>
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

}  // namespace hedgefit::bench
