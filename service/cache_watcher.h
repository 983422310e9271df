#pragma once
/// @file cache_watcher.h
/// Objects added, replaced or removed while the service runs: the CacheWatcher watches the
/// templates directory (inotify, a periodic rescan as a fallback, and Rescan() on request,
/// e.g. SIGHUP), reads new and changed caches on a loader thread of its own, and hands the
/// service a whole new TemplateStore when what it serves changed. The service swaps its
/// snapshot pointer; solves running on an old bank finish on it (banks are shared).
///
/// A file is read only once it is complete: after its writer closed it (IN_CLOSE_WRITE) or
/// it was moved in (IN_MOVED_TO); a change found by a rescan alone waits until the file
/// has not been modified for `settle_s`. A bad version of a file is refused with its
/// reason (in the log and the store's `refused`), and the bank of its last good version
/// stays in service; removing the file removes its object.

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "g6d/service_status_t.hpp"
#include "service/template_store.h"

namespace g6d {

/// Options of the CacheWatcher.
struct CacheWatcherOptions {
  std::string dir;           ///< the templates directory
  /// Period of the fallback rescan, seconds; 0 = only inotify events and Rescan().
  double scan_period_s = 2.0;
  /// A change seen by a rescan (no close or move event for it) is read once the file has
  /// not been modified for this long, seconds: a file being written is not read half-way.
  double settle_s = 1.0;
  bool use_inotify = true;   ///< false: rescans only (tests of the fallback)

  std::string Check() const;
};

/// What one file of the directory held when last read.
struct WatchedFile {
  /// The version last read; nothing: read it at the next scan.
  std::optional<FileSignature> signature;
  std::string hash;  ///< of the version last read
  /// The bank of the last version that loaded: kept (and served) while a later version
  /// is refused.
  std::shared_ptr<const TemplateBank> bank;
  std::string bank_hash;  ///< the hash of that version
  std::string error;      ///< why the version last read was refused; empty when it loaded
};

/// The store `files` make: an object stays with the file that served it in `previous`
/// while that file still holds it; other files are taken in name order, and one naming
/// an object already served is refused as a duplicate. Files with an error are refused
/// with it (their last good bank, if any, still serves). `generation` is previous's.
TemplateStore AssembleStore(const std::map<std::string, WatchedFile>& files, const TemplateStore& previous);

/// How the served objects changed between two stores.
struct StoreChange {
  std::vector<std::string> added;     ///< objects served now and not before
  std::vector<std::string> replaced;  ///< objects served by a cache of another hash now
  std::vector<std::string> removed;   ///< objects no longer served
  bool refusals_changed = false;      ///< the refused files or their reasons changed

  bool Empty() const { return added.empty() && replaced.empty() && removed.empty() && !refusals_changed; }
};

/// The change from `before` to `after`.
StoreChange DiffStores(const TemplateStore& before, const TemplateStore& after);

/// Fills the status fields about `store`: objects and their cache hashes, refused files
/// with their reasons, the generation, and `reload` (the directory is watched).
void FillStoreStatus(const TemplateStore& store, bool reload, service_status_t* status);

/// Watches a templates directory on a thread of its own (see the file comment).
class CacheWatcher {
 public:
  /// Called on the loader thread with each new store (its generation one more than the
  /// last) and what changed; must not throw.
  using OnChange = std::function<void(std::shared_ptr<const TemplateStore> store, const StoreChange& change)>;

  /// `initial` is what the service serves now (LoadTemplateStore(options.dir)): its loaded
  /// files are not read again unless they change; its refused files are read again at the
  /// first scan (quietly when their reason is the same). Throws g6d::Error when
  /// options.Check() fails.
  CacheWatcher(const CacheWatcherOptions& options, const TemplateStore& initial, OnChange on_change);
  ~CacheWatcher();
  CacheWatcher(const CacheWatcherOptions&) = delete;
  CacheWatcher& operator=(const CacheWatcher&) = delete;

  /// Starts watching (inotify when it can; when it cannot, says why and rescans only) and
  /// the loader thread, which scans once at once. Throws g6d::Error when the wake-up
  /// descriptor cannot be made.
  void Start();
  /// Ends the loader thread (a read in progress finishes first). Idempotent.
  void Stop();
  /// Asks for a scan now, reading changed files without the settle wait (SIGHUP).
  void Rescan();

  /// Scans done so far (every trigger counts once).
  int64_t Scans() const { return scans_.load(); }
  /// True while inotify events arrive (false: rescans only).
  bool Inotify() const { return inotify_fd_ >= 0; }

 private:
  void Loop();
  /// Drains the inotify events: names closed after writing or moved in go to *complete;
  /// returns true when any event came (or the queue overflowed).
  bool ReadEvents(std::set<std::string>* complete);
  /// Lists the directory, reads the files that changed (those in `complete`, or settled,
  /// or all when `force`), forgets removed ones, and publishes the store when it changed.
  void Scan(const std::set<std::string>& complete, bool force);
  /// True when a changed file of this signature may be read now (settle_s old).
  bool Settled(const FileSignature& signature) const;
  /// Wakes the loader thread out of poll().
  void Wake();

  const CacheWatcherOptions options_;
  OnChange on_change_;
  // Loader thread only (after Start()):
  std::map<std::string, WatchedFile> files_;  ///< by path
  std::shared_ptr<const TemplateStore> current_;
  bool listing_failed_ = false;  ///< the last listing failed (logged once until it works again)

  int inotify_fd_ = -1;
  int wake_fd_ = -1;
  std::thread thread_;
  std::mutex lifecycle_mutex_;  ///< serializes Start(), Stop() and Rescan()
  bool started_ = false, stopped_ = false;
  std::mutex mutex_;  ///< the loader thread's requests:
  bool stop_ = false, rescan_ = false;
  std::atomic<int64_t> scans_{0};
};

}  // namespace g6d
