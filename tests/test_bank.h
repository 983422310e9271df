#pragma once
/// @file test_bank.h
/// A template bank built once per test binary and build tree, not once per test case.
///
/// ctest runs every case of a test binary in its own process (gtest_discover_tests), so a
/// bank built in SetUpTestSuite was built again for each case: under ThreadSanitizer that
/// was most of the solver tests' time. SharedTestBank builds it once, keeps it as a cache
/// file in the build tree, and every process (the first one too) reads that file back, so
/// each case sees the same bank whatever the order the cases ran in. The file name holds
/// the identity of the running test binary (size and modification time): a rebuilt binary
/// (a changed template builder, a changed test) never reads a bank of an older one.

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "core/error.h"
#include "core/executor.h"
#include "core/hash.h"
#include "mesh/mesh.h"
#include "templates/cache.h"
#include "templates/template_bank.h"
#include "test_paths.h"

namespace g6d::test {

/// Size and modification time of the running executable, hashed: what tells one build of a
/// test binary from the next.
inline uint64_t RunningBinaryIdentity() {
  struct stat status {};
  if (::stat("/proc/self/exe", &status) != 0) G6D_THROW("cannot stat /proc/self/exe");
  const int64_t fields[3] = {static_cast<int64_t>(status.st_size), static_cast<int64_t>(status.st_mtim.tv_sec),
                             static_cast<int64_t>(status.st_mtim.tv_nsec)};
  return Fnv1a64(fields, sizeof(fields));
}

/// The bank BuildTemplateBank(mesh, object_id, options) gives, read from its cache file in
/// <build>/test-banks/. `key` names the bank among those of one test binary (the mesh and
/// options it stands for, e.g. "box21-default"). Processes running at the same time wait for
/// the one that builds it (an flock on a lock file beside it).
inline TemplateBank SharedTestBank(const std::string& key, const Mesh& mesh, const std::string& object_id,
                                   const TemplateBuildOptions& options, Executor* executor) {
  const std::filesystem::path dir = std::filesystem::path(BinaryDir()) / "test-banks";
  std::filesystem::create_directories(dir);
  const std::string stem = key + "-" + HexString(RunningBinaryIdentity());
  const std::string path = (dir / (stem + ".g6dcache")).string();
  const std::string lock_path = (dir / (stem + ".lock")).string();
  const int lock = ::open(lock_path.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (lock < 0) G6D_THROW("cannot open the test bank lock '" << lock_path << "'");
  struct Unlock {
    int fd;
    ~Unlock() {
      ::flock(fd, LOCK_UN);
      ::close(fd);
    }
  } unlock{lock};
  if (::flock(lock, LOCK_EX) != 0) G6D_THROW("cannot lock '" << lock_path << "'");
  if (!std::filesystem::exists(path)) {
    WriteTemplateCache(BuildTemplateBank(mesh, object_id, options, executor), path, /*zstd_level=*/1);
  }
  return ReadTemplateCache(path);
}

/// A bank builder (the shape of synthetic::BankBuilder) that returns SharedTestBank's copy
/// under `key`.
inline std::function<TemplateBank(const Mesh&, const std::string&, const TemplateBuildOptions&, Executor*)>
SharedBankBuilder(const std::string& key) {
  return [key](const Mesh& mesh, const std::string& object_id, const TemplateBuildOptions& options,
               Executor* executor) { return SharedTestBank(key, mesh, object_id, options, executor); };
}

}  // namespace g6d::test
