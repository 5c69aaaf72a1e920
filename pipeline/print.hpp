#pragma once
/// printf-style formatting into a stream, for the fixed-width tables and reports hedgefit prints.

#include <cstdio>
#include <ostream>
#include <vector>

namespace hedgefit::pipeline {

/// Formats `args` with `format` (printf's syntax) and writes the result to `out`, however long.
template <class... Args>
void Print(std::ostream& out, const char* format, Args... args) {
  const int n = std::snprintf(nullptr, 0, format, args...);
  if (n <= 0) return;
  std::vector<char> buf(std::size_t(n) + 1);
  std::snprintf(buf.data(), buf.size(), format, args...);
  out.write(buf.data(), n);
}

}  // namespace hedgefit::pipeline
