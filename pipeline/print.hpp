#pragma once
/// printf-style formatting into a stream, for the fixed-width tables and reports hedgefit prints.
/// The format attribute lets the compiler check each call's arguments against its format.

#include <cstdarg>
#include <cstdio>
#include <ostream>
#include <string>
#include <vector>

namespace hedgefit::pipeline {

/// Formats the arguments with `format` (printf's syntax) and writes the result to `out`, however long.
[[gnu::format(printf, 2, 3)]] inline void Print(std::ostream& out, const char* format, ...) {
  va_list args, again;
  va_start(args, format);
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  if (n > 0) {
    std::vector<char> buf(std::size_t(n) + 1);
    std::vsnprintf(buf.data(), buf.size(), format, again);
    out.write(buf.data(), n);
  }
  va_end(again);
}

/// The same, into a string: for messages built from numbers.
[[gnu::format(printf, 1, 2)]] inline std::string Format(const char* format, ...) {
  va_list args, again;
  va_start(args, format);
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  std::string out;
  if (n > 0) {
    out.resize(std::size_t(n) + 1);
    std::vsnprintf(out.data(), out.size(), format, again);
    out.resize(std::size_t(n));
  }
  va_end(again);
  return out;
}

}  // namespace hedgefit::pipeline
