#pragma once
// Shared by the fuzz harnesses: the input as a file (the readers under test take paths), and the
// rule every harness checks: bad input is a hedgefit::Error, never a crash, a hang or another
// exception type (libFuzzer reports an uncaught exception as a crash).

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>

namespace hedgefit::fuzz {

/// Writes the input to a file of this process with the given extension and returns its path.
inline std::string AsFile(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  const std::string path = "/tmp/hedgefit_fuzz_" + std::to_string(::getpid()) + extension;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace hedgefit::fuzz
