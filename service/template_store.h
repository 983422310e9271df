#pragma once
/// @file template_store.h
/// The template banks a service serves, loaded once at start from a directory of cache
/// files. A file that is not a valid cache is reported with its reason and skipped.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "templates/template_bank.h"

namespace g6d {

/// One cache file that loaded.
struct LoadedCache {
  std::string path;
  std::string object_id;  ///< from the cache header
  int num_templates = 0;
  double diameter_m = 0.0;
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

  /// Object ids of the loaded banks, sorted.
  std::vector<std::string> ObjectIds() const;
};

/// Tries every regular file in `dir` (sorted by name) as a template cache. A file that
/// does not read (not a cache, wrong version, truncated, corrupted, ...) or repeats an
/// object id already loaded is refused with the reason. Throws g6d::Error only when `dir`
/// is not a readable directory.
TemplateStore LoadTemplateStore(const std::string& dir);

}  // namespace g6d
