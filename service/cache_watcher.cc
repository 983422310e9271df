#include "service/cache_watcher.h"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <system_error>

#include "core/error.h"

namespace g6d {
namespace {

// inotify events that say a file is complete (closed after writing, moved in) or gone.
constexpr uint32_t kWatchMask = IN_CLOSE_WRITE | IN_MOVED_TO | IN_DELETE | IN_MOVED_FROM | IN_DELETE_SELF |
                                IN_MOVE_SELF;

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string FileName(const std::string& path) { return std::filesystem::path(path).filename().string(); }

// The regular, non-temporary files of `dir`, or nothing (and *error) when it cannot be listed.
std::optional<std::vector<std::string>> ListCacheFiles(const std::string& dir, std::string* error) {
  namespace fs = std::filesystem;
  std::error_code code;
  std::vector<std::string> paths;
  for (fs::directory_iterator it(dir, code), end; !code && it != end; it.increment(code)) {
    std::error_code type_error;
    if (it->is_regular_file(type_error) && !IsTemporaryName(it->path().filename().string()))
      paths.push_back(it->path().string());
  }
  if (code) {
    *error = code.message();
    return std::nullopt;
  }
  return paths;
}

std::string Join(const std::vector<std::string>& items) {
  std::string joined;
  for (const std::string& item : items) joined += (joined.empty() ? "" : ", ") + item;
  return joined;
}

}  // namespace

std::string CacheWatcherOptions::Check() const {
  std::ostringstream out;
  if (dir.empty())
    out << "dir must be set";
  else if (!std::isfinite(scan_period_s) || scan_period_s < 0.0)
    out << "scan_period_s must be >= 0 (got " << scan_period_s << ")";
  else if (!std::isfinite(settle_s) || settle_s < 0.0)
    out << "settle_s must be >= 0 (got " << settle_s << ")";
  return out.str();
}

TemplateStore AssembleStore(const std::map<std::string, WatchedFile>& files, const TemplateStore& previous) {
  TemplateStore store;
  store.generation = previous.generation;
  auto claim = [&store](const std::string& path, const WatchedFile& file) {
    const TemplateBank& bank = *file.bank;
    store.loaded.push_back({path, bank.object_id, static_cast<int>(bank.templates.size()), bank.diameter_m,
                            file.bank_hash, file.signature.value_or(FileSignature())});
    store.banks.emplace(bank.object_id, file.bank);
  };
  // An object stays with its file while that file holds it: a copy of it under another
  // name is the duplicate, whatever the names' order.
  for (const LoadedCache& old : previous.loaded) {
    const auto file = files.find(old.path);
    if (file == files.end() || !file->second.bank || file->second.bank->object_id != old.object_id) continue;
    if (store.banks.count(old.object_id) == 0) claim(old.path, file->second);
  }
  for (const auto& [path, file] : files) {
    if (!file.bank) continue;
    const LoadedCache* owner = store.Find(file.bank->object_id);
    if (owner == nullptr) {
      claim(path, file);
    } else if (owner->path != path && file.error.empty()) {
      store.refused.push_back({path, "duplicate object id '" + file.bank->object_id + "' (already loaded from " +
                                         owner->path + ")"});
    }
  }
  for (const auto& [path, file] : files) {
    if (file.error.empty()) continue;
    const LoadedCache* served = file.bank ? store.Find(file.bank->object_id) : nullptr;
    if (served != nullptr && served->path == path) {
      store.refused.push_back({path, file.error + "; the version loaded before (hash " + file.bank_hash +
                                         ") stays in service"});
    } else {
      store.refused.push_back({path, file.error});
    }
  }
  std::sort(store.loaded.begin(), store.loaded.end(),
            [](const LoadedCache& a, const LoadedCache& b) { return a.path < b.path; });
  std::sort(store.refused.begin(), store.refused.end(),
            [](const RefusedCache& a, const RefusedCache& b) { return a.path < b.path; });
  return store;
}

StoreChange DiffStores(const TemplateStore& before, const TemplateStore& after) {
  StoreChange change;
  for (const LoadedCache& old : before.loaded) {
    const LoadedCache* now = after.Find(old.object_id);
    if (now == nullptr) {
      change.removed.push_back(old.object_id);
    } else if (now->hash != old.hash) {
      change.replaced.push_back(old.object_id);
    }
  }
  for (const LoadedCache& now : after.loaded) {
    if (before.Find(now.object_id) == nullptr) change.added.push_back(now.object_id);
  }
  auto same = [](const RefusedCache& a, const RefusedCache& b) { return a.path == b.path && a.reason == b.reason; };
  change.refusals_changed = !std::equal(before.refused.begin(), before.refused.end(), after.refused.begin(),
                                        after.refused.end(), same);
  return change;
}

void FillStoreStatus(const TemplateStore& store, bool reload, service_status_t* status) {
  status->objects = store.ObjectIds();
  status->num_objects = static_cast<int32_t>(status->objects.size());
  status->object_cache_hashes.clear();
  for (const std::string& id : status->objects) {
    const LoadedCache* cache = store.Find(id);
    status->object_cache_hashes.push_back(cache ? cache->hash : std::string());
  }
  status->num_cache_hashes = static_cast<int32_t>(status->object_cache_hashes.size());
  status->reload = reload ? 1 : 0;
  status->cache_generation = store.generation;
  status->refused_files.clear();
  status->refused_reasons.clear();
  for (const RefusedCache& refused : store.refused) {
    status->refused_files.push_back(refused.path);
    status->refused_reasons.push_back(refused.reason);
  }
  status->num_refused = static_cast<int32_t>(store.refused.size());
}

CacheWatcher::CacheWatcher(const CacheWatcherOptions& options, const TemplateStore& initial, OnChange on_change)
    : options_(options), on_change_(std::move(on_change)), current_(std::make_shared<const TemplateStore>(initial)) {
  if (const std::string error = options_.Check(); !error.empty()) G6D_THROW("CacheWatcherOptions: " << error);
  for (const LoadedCache& cache : initial.loaded) {
    if (cache.hash.empty()) continue;  // not from a file
    WatchedFile& file = files_[cache.path];
    file.signature = cache.signature;
    file.hash = file.bank_hash = cache.hash;
    file.bank = initial.banks.at(cache.object_id);
  }
  // Refused files keep no signature: the first scan reads them again (a duplicate's bank
  // is then known, should its object's file go away); until then they stay refused.
  for (const RefusedCache& cache : initial.refused) files_[cache.path].error = cache.reason;
}

CacheWatcher::~CacheWatcher() { Stop(); }

void CacheWatcher::Start() {
  std::lock_guard<std::mutex> lifecycle(lifecycle_mutex_);
  if (started_) G6D_THROW("CacheWatcher::Start: already started");
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) G6D_THROW("CacheWatcher: eventfd failed: " << std::strerror(errno));
  if (options_.use_inotify) {
    inotify_fd_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (inotify_fd_ >= 0 && ::inotify_add_watch(inotify_fd_, options_.dir.c_str(), kWatchMask) < 0) {
      spdlog::warn("reload: cannot watch '{}' ({}); rescanning every {} s only", options_.dir, std::strerror(errno),
                   options_.scan_period_s);
      ::close(inotify_fd_);
      inotify_fd_ = -1;
    } else if (inotify_fd_ < 0) {
      spdlog::warn("reload: inotify unavailable ({}); rescanning every {} s only", std::strerror(errno),
                   options_.scan_period_s);
    }
  }
  started_ = true;
  thread_ = std::thread([this] { Loop(); });
}

void CacheWatcher::Stop() {
  std::lock_guard<std::mutex> lifecycle(lifecycle_mutex_);
  if (!started_ || stopped_) {
    stopped_ = true;
    return;
  }
  stopped_ = true;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  Wake();
  thread_.join();  // not under mutex_: the loop takes it when it wakes
  if (inotify_fd_ >= 0) ::close(inotify_fd_);
  ::close(wake_fd_);
}

void CacheWatcher::Rescan() {
  std::lock_guard<std::mutex> lifecycle(lifecycle_mutex_);
  if (!started_ || stopped_) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rescan_ = true;
  }
  Wake();
}

void CacheWatcher::Wake() {
  // An eventfd write of 1 only fails when the counter would overflow; EINTR is retried.
  const uint64_t one = 1;
  while (::write(wake_fd_, &one, sizeof(one)) < 0 && errno == EINTR) {
  }
}

void CacheWatcher::Loop() {
  Scan({}, /*force=*/false);
  // The periodic rescan is the poll timeout: a folder whose events are lost (a network
  // file system, an overflowed queue) is still read within a period.
  const int timeout_ms =
      options_.scan_period_s > 0.0 ? std::max(1, static_cast<int>(std::lround(options_.scan_period_s * 1e3))) : -1;
  for (;;) {
    pollfd fds[2] = {{wake_fd_, POLLIN, 0}, {inotify_fd_, POLLIN, 0}};  // a negative fd is skipped
    const int ready = ::poll(fds, 2, timeout_ms);
    if (ready < 0) {
      if (errno == EINTR) continue;
      spdlog::error("reload: poll failed ({}); caches are no longer watched", std::strerror(errno));
      return;
    }
    bool force = false;
    if (fds[0].revents != 0) {
      uint64_t count = 0;
      while (::read(wake_fd_, &count, sizeof(count)) < 0 && errno == EINTR) {
      }
      std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) return;
      force = rescan_;
      rescan_ = false;
    }
    std::set<std::string> complete;
    const bool events = fds[1].revents != 0 && ReadEvents(&complete);
    if (ready == 0 || events || force) Scan(complete, force);
  }
}

bool CacheWatcher::ReadEvents(std::set<std::string>* complete) {
  alignas(struct inotify_event) char buffer[16384];
  bool any = false;
  for (;;) {
    const ssize_t got = ::read(inotify_fd_, buffer, sizeof(buffer));
    if (got <= 0) {
      if (got < 0 && errno == EINTR) continue;
      return any;  // EAGAIN: drained
    }
    for (ssize_t offset = 0; offset < got;) {
      const auto* event = reinterpret_cast<const struct inotify_event*>(buffer + offset);
      offset += static_cast<ssize_t>(sizeof(struct inotify_event) + event->len);
      any = true;
      if (event->mask & (IN_DELETE_SELF | IN_MOVE_SELF)) {
        spdlog::warn("reload: '{}' was removed or moved; its caches stay loaded", options_.dir);
      }
      if (event->len > 0 && (event->mask & (IN_CLOSE_WRITE | IN_MOVED_TO))) complete->insert(event->name);
    }
  }
}

bool CacheWatcher::Settled(const FileSignature& signature) const {
  return static_cast<double>(NowNs() - signature.mtime_ns) >= options_.settle_s * 1e9;
}

void CacheWatcher::Scan(const std::set<std::string>& complete, bool force) {
  scans_.fetch_add(1);
  std::string error;
  const std::optional<std::vector<std::string>> paths = ListCacheFiles(options_.dir, &error);
  if (!paths) {
    // Keep serving what is loaded: a folder that went away for a moment is no reason to
    // drop every object.
    if (!listing_failed_) spdlog::error("reload: cannot list '{}' ({}); the loaded caches stay", options_.dir, error);
    listing_failed_ = true;
    return;
  }
  listing_failed_ = false;
  const std::set<std::string> present(paths->begin(), paths->end());
  for (auto it = files_.begin(); it != files_.end();) {
    it = present.count(it->first) ? std::next(it) : files_.erase(it);
  }
  for (const std::string& path : *paths) {
    const std::optional<FileSignature> signature = SignatureOf(path);
    if (!signature) continue;  // gone since the listing
    const auto known = files_.find(path);
    if (known != files_.end() && known->second.signature == signature) continue;
    // A changed file no event called complete may still be being written: wait until it
    // has not been modified for settle_s (its close event usually comes first).
    if (!force && complete.count(FileName(path)) == 0 && !Settled(*signature)) continue;
    CacheFileRead read = ReadCacheFile(path);
    WatchedFile& file = files_[path];
    file.signature = read.hash.empty() ? *signature : read.signature;
    file.hash = read.hash;
    file.error = read.error;
    if (read.bank && read.hash != file.bank_hash) {
      file.bank = std::move(read.bank);
      file.bank_hash = read.hash;
    }
  }
  TemplateStore next = AssembleStore(files_, *current_);
  const StoreChange change = DiffStores(*current_, next);
  if (change.Empty()) return;
  next.generation = current_->generation + 1;
  for (const std::string& id : change.added) {
    const LoadedCache& cache = *next.Find(id);
    spdlog::info("reload: loaded '{}' from {} ({} templates, diameter {:.1f} mm, hash {})", id, cache.path,
                 cache.num_templates, cache.diameter_m * 1e3, cache.hash);
  }
  for (const std::string& id : change.replaced) {
    spdlog::info("reload: replaced '{}' from {} (hash {} -> {}); its tracks are dropped", id, next.Find(id)->path,
                 current_->Find(id)->hash, next.Find(id)->hash);
  }
  for (const std::string& id : change.removed) {
    spdlog::info("reload: removed '{}' ({} is gone or holds another object); its tracks are dropped", id,
                 current_->Find(id)->path);
  }
  for (const RefusedCache& refused : next.refused) {
    const bool known = std::any_of(current_->refused.begin(), current_->refused.end(), [&](const RefusedCache& r) {
      return r.path == refused.path && r.reason == refused.reason;
    });
    if (!known) spdlog::warn("reload: refused {}: {}", refused.path, refused.reason);
  }
  spdlog::info("reload: generation {}: objects {}", next.generation,
               next.banks.empty() ? std::string("none") : Join(next.ObjectIds()));
  current_ = std::make_shared<const TemplateStore>(std::move(next));
  on_change_(current_, change);
}

}  // namespace g6d
