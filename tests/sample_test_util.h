#pragma once
/// @file sample_test_util.h
/// Scratch folders for the sample tests (issue 6). ctest runs every case of a test binary
/// as its own process, two at a time, so a folder name must be unique per process; the
/// folders are removed when the process exits.

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "test_util.h"

namespace g6d::test {

/// Fresh empty folders named after the test and this process id, removed at exit.
class ScratchDirs {
 public:
  /// A new empty folder /tmp/g6d_test_<name>_<pid>.
  static std::string Make(const std::string& name) {
    static ScratchDirs dirs;
    const std::string dir = TempDir(name + "_" + std::to_string(::getpid()));
    dirs.paths_.push_back(dir);
    return dir;
  }

  ~ScratchDirs() {
    for (const std::string& path : paths_) {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  }

 private:
  ScratchDirs() = default;
  std::vector<std::string> paths_;
};

}  // namespace g6d::test
