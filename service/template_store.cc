#include "service/template_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "core/error.h"
#include "core/hash.h"
#include "templates/cache.h"

namespace g6d {
namespace {

FileSignature SignatureFromStat(const struct stat& status) {
  FileSignature signature;
  signature.size = static_cast<uint64_t>(status.st_size);
  signature.mtime_ns = static_cast<int64_t>(status.st_mtim.tv_sec) * 1000000000LL + status.st_mtim.tv_nsec;
  signature.inode = static_cast<uint64_t>(status.st_ino);
  return signature;
}

bool EndsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Reads the whole open file `fd` into *bytes; false (errno set) on a read error.
bool ReadAll(int fd, uint64_t size, std::string* bytes) {
  bytes->clear();
  bytes->reserve(static_cast<size_t>(size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t got = ::read(fd, buffer, sizeof(buffer));
    if (got == 0) return true;
    if (got < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    bytes->append(buffer, static_cast<size_t>(got));
  }
}

}  // namespace

std::optional<FileSignature> SignatureOf(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0 || !S_ISREG(status.st_mode)) return std::nullopt;
  return SignatureFromStat(status);
}

std::vector<std::string> TemplateStore::ObjectIds() const {
  std::vector<std::string> ids;
  ids.reserve(banks.size());
  for (const auto& entry : banks) ids.push_back(entry.first);
  return ids;  // std::map keeps them sorted
}

const LoadedCache* TemplateStore::Find(const std::string& object_id) const {
  for (const LoadedCache& cache : loaded) {
    if (cache.object_id == object_id) return &cache;
  }
  return nullptr;
}

CacheFileRead ReadCacheFile(const std::string& path) {
  CacheFileRead read;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    read.error = "cannot open template cache '" + path + "': " + std::strerror(errno);
    return read;
  }
  struct stat status {};
  std::string bytes;
  // The signature from the open file: a rename over `path` while this reads gives the
  // next scan another inode, so that version is read then.
  const bool ok = ::fstat(fd, &status) == 0 && S_ISREG(status.st_mode) &&
                  ReadAll(fd, static_cast<uint64_t>(status.st_size), &bytes);
  const int read_errno = errno;
  ::close(fd);
  if (!ok) {
    read.error = "cannot read template cache '" + path + "': " + std::strerror(read_errno);
    return read;
  }
  read.signature = SignatureFromStat(status);
  read.hash = HexString(Fnv1a64(bytes.data(), bytes.size()));
  try {
    TemplateBank bank = ParseTemplateCache(bytes, "template cache '" + path + "'");
    DeriveOnlineMeshes(&bank);  // as ReadTemplateCache does
    read.bank = std::make_shared<const TemplateBank>(std::move(bank));
  } catch (const std::exception& e) {
    read.error = e.what();
  }
  return read;
}

bool IsTemporaryName(const std::string& file_name) {
  return file_name.empty() || file_name[0] == '.' || EndsWith(file_name, "~") || EndsWith(file_name, ".part") ||
         EndsWith(file_name, ".tmp") || file_name.find(".tmp.") != std::string::npos;
}

TemplateStore LoadTemplateStore(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(dir, error)) G6D_THROW("templates: '" << dir << "' is not a directory");
  std::vector<fs::path> files;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    std::error_code type_error;
    if (it->is_regular_file(type_error) && !IsTemporaryName(it->path().filename().string()))
      files.push_back(it->path());
  }
  if (error) G6D_THROW("templates: cannot list '" << dir << "': " << error.message());
  std::sort(files.begin(), files.end());

  TemplateStore store;
  for (const fs::path& file : files) {
    const std::string path = file.string();
    CacheFileRead read = ReadCacheFile(path);
    if (!read.bank) {
      store.refused.push_back({path, read.error});
      continue;
    }
    const std::string& object_id = read.bank->object_id;
    if (const LoadedCache* existing = store.Find(object_id)) {
      store.refused.push_back(
          {path, "duplicate object id '" + object_id + "' (already loaded from " + existing->path + ")"});
      continue;
    }
    store.loaded.push_back({path, object_id, static_cast<int>(read.bank->templates.size()), read.bank->diameter_m,
                            read.hash, read.signature});
    store.banks.emplace(object_id, std::move(read.bank));
  }
  return store;
}

}  // namespace g6d
