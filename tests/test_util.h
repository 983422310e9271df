#pragma once
/// @file test_util.h
/// Helpers shared by the tests: where the shared real data lives, and a skip when absent.

#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "test_paths.h"

namespace g6d::test {

/// ../shared/data beside the checkout (empty string when the folder is absent).
inline std::string SharedDataDir() {
  const std::filesystem::path dir(SharedDataRoot());
  return std::filesystem::is_directory(dir) ? dir.string() : std::string();
}

/// Path of a file under the shared data folder (may not exist).
inline std::string SharedDataPath(const std::string& relative) {
  return (std::filesystem::path(SharedDataRoot()) / relative).string();
}

/// A fresh temporary directory for one test, removed by the caller if wanted. The name
/// carries the process id: ctest runs every case in a process of its own, two at a time,
/// and cases sharing a fixture (hence a name) must not wipe each other's files.
inline std::string TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("g6d_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

}  // namespace g6d::test

/// Skips the current test with a message when ../shared/data/<relative> does not exist.
#define G6D_REQUIRE_SHARED_DATA(relative)                                                 \
  do {                                                                                    \
    if (!std::filesystem::exists(::g6d::test::SharedDataPath(relative))) {                \
      GTEST_SKIP() << "shared data '" << ::g6d::test::SharedDataPath(relative)            \
                   << "' is absent (fresh machine without ../shared); skipping";          \
    }                                                                                     \
  } while (false)
