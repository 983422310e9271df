#pragma once
/// @file template_store.h
/// The template banks a service serves, loaded at start from a directory of cache files
/// (and reloaded while it runs by the CacheWatcher, cache_watcher.h). A file that is not a
/// valid cache is reported with its reason and skipped.

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "templates/template_bank.h"

namespace g6d {

/// What tells one version of a file from the next without reading it: a rewrite changes
/// the size or the modification time, a rename over it the inode.
struct FileSignature {
  uint64_t size = 0;
  int64_t mtime_ns = 0;  ///< modification time, nanoseconds since the Unix epoch
  uint64_t inode = 0;

  bool operator==(const FileSignature& other) const {
    return size == other.size && mtime_ns == other.mtime_ns && inode == other.inode;
  }
  bool operator!=(const FileSignature& other) const { return !(*this == other); }
};

/// The signature of the regular file at `path`; nothing when it is missing or not a
/// regular file.
std::optional<FileSignature> SignatureOf(const std::string& path);

/// One cache file that loaded.
struct LoadedCache {
  std::string path;
  std::string object_id;  ///< from the cache header
  int num_templates = 0;
  double diameter_m = 0.0;
  std::string hash;         ///< FNV-1a 64 of the file's bytes, 16 hex digits (empty: not from a file)
  FileSignature signature;  ///< of the file as it was read
};

/// One file that did not load, and why.
struct RefusedCache {
  std::string path;
  std::string reason;
};

/// Banks by object id, plus what happened to every file.
struct TemplateStore {
  std::map<std::string, std::shared_ptr<const TemplateBank>> banks;
  std::vector<LoadedCache> loaded;    ///< in file name order
  std::vector<RefusedCache> refused;  ///< in file name order
  /// Changes since the service started (0: as loaded at start); the CacheWatcher counts.
  int64_t generation = 0;

  /// Object ids of the loaded banks, sorted.
  std::vector<std::string> ObjectIds() const;
  /// The loaded entry of `object_id`, or nullptr.
  const LoadedCache* Find(const std::string& object_id) const;
};

/// One cache file read whole: its bank, or why it was refused.
struct CacheFileRead {
  FileSignature signature;  ///< of the file read (taken from the open file)
  std::string hash;         ///< FNV-1a 64 of its bytes, 16 hex digits; empty when unreadable
  std::shared_ptr<const TemplateBank> bank;  ///< null when refused
  std::string error;        ///< why it was refused (empty when it loaded)
};

/// Reads the cache file at `path` once (the hash and the bank come from the same bytes).
/// Never throws: a file that cannot be read or is not a valid cache comes back with
/// `error` set.
CacheFileRead ReadCacheFile(const std::string& path);

/// True for file names that are not caches but files on their way to one: hidden files
/// (".name"), editor backups ("name~"), partial downloads ("name.part", "name.tmp") and
/// WriteTemplateCache's temporary files ("name.tmp.<pid>...").
bool IsTemporaryName(const std::string& file_name);

/// Tries every regular file in `dir` (sorted by name; temporary names skipped) as a
/// template cache. A file that does not read (not a cache, wrong version, truncated,
/// corrupted, ...) or repeats an object id already loaded is refused with the reason.
/// Throws g6d::Error only when `dir` is not a readable directory.
TemplateStore LoadTemplateStore(const std::string& dir);

}  // namespace g6d
