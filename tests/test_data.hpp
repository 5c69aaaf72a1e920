#pragma once
// Where tests find the real data (docs/data.md), and a skip with a clear message when it is absent.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace hedgefit::testing {

/// HEDGEFIT_DATA_DIR from the environment, else the path CMake was configured with.
inline std::string DataDir() {
  const char* env = std::getenv("HEDGEFIT_DATA_DIR");
  return env ? env : HEDGEFIT_TEST_DATA_DIR;
}

inline std::string DataPath(const std::string& relative) { return DataDir() + "/" + relative; }

/// A scratch directory unique to the running test, removed and recreated.
inline std::filesystem::path ScratchDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir = std::filesystem::temp_directory_path() /
                              ("hedgefit_test_" + std::string(info->test_suite_name()) + "_" + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace hedgefit::testing

/// Skips the test, naming the file and how to provide it, when real data is absent.
#define HEDGEFIT_REQUIRE_DATA(relative)                                                          \
  do {                                                                                           \
    if (!std::filesystem::exists(hedgefit::testing::DataPath(relative))) {                       \
      GTEST_SKIP() << "real data " << hedgefit::testing::DataPath(relative)                      \
                   << " is absent; docs/data.md says where to get it (scripts/get_data.sh), "   \
                   << "and HEDGEFIT_DATA_DIR may name the folder";                             \
    }                                                                                            \
  } while (0)
