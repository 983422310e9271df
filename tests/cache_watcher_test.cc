// CacheWatcher: caches added, changed, refused and removed while it watches a real folder
// (inotify and the rescan fallback), the store it assembles (which file keeps an object),
// and the names it leaves alone. Banks are tiny (6 views): only loading is under test.
#include "service/cache_watcher.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

#include "core/error.h"
#include "core/hash.h"
#include "synthetic_scene.h"
#include "templates/cache.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;
using std::chrono::seconds;

TemplateBank TinyBank(const std::string& object_id) {
  TemplateBuildOptions options;
  options.views.num_directions = 6;
  options.views.num_inplane = 1;
  InlineExecutor executor;
  return BuildTemplateBank(test::MakeTexturedBox(0.08, 0.06, 0.04, 3), object_id, options, &executor);
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// The stores a watcher published, and a wait for one that satisfies a condition.
class Published {
 public:
  CacheWatcher::OnChange Callback() {
    return [this](std::shared_ptr<const TemplateStore> store, const StoreChange& change) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        latest_ = std::move(store);
        changes_.push_back(change);
      }
      changed_.notify_all();
    };
  }
  /// The latest store once `accept` holds for it (within 30 s), else nullptr.
  template <typename Predicate>
  std::shared_ptr<const TemplateStore> WaitFor(Predicate accept) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!changed_.wait_for(lock, seconds(30), [&] { return latest_ && accept(*latest_); })) return nullptr;
    return latest_;
  }
  std::vector<StoreChange> Changes() {
    std::lock_guard<std::mutex> lock(mutex_);
    return changes_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::shared_ptr<const TemplateStore> latest_;
  std::vector<StoreChange> changes_;
};

bool Refuses(const TemplateStore& store, const std::string& path, const std::string& needle) {
  for (const RefusedCache& refused : store.refused) {
    if (refused.path == path && refused.reason.find(needle) != std::string::npos) return true;
  }
  return false;
}

class CacheWatcherTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    one_ = new TemplateBank(TinyBank("obj_000001"));
    two_ = new TemplateBank(TinyBank("obj_000002"));
  }
  static void TearDownTestSuite() {
    delete one_;
    delete two_;
  }
  void SetUp() override {
    dir_ = test::TempDir(std::string("cache_watcher_") +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    staging_ = dir_ + "_staging";
    std::filesystem::create_directories(staging_);
    WriteTemplateCache(*one_, dir_ + "/one.g6dcache", 1);
  }
  void TearDown() override {
    if (watcher_) watcher_->Stop();
    std::filesystem::remove_all(dir_);
    std::filesystem::remove_all(staging_);
  }
  void StartWatcher(bool inotify, double scan_period_s, double settle_s = 1.0) {
    CacheWatcherOptions options;
    options.dir = dir_;
    options.settle_s = settle_s;
    options.use_inotify = inotify;
    options.scan_period_s = scan_period_s;
    watcher_ = std::make_unique<CacheWatcher>(options, LoadTemplateStore(dir_), published_.Callback());
    watcher_->Start();
  }
  /// Writes `bank` in the staging folder and renames it into the watched one as `name`.
  void MoveIn(const TemplateBank& bank, const std::string& name, int zstd_level = 1) {
    WriteTemplateCache(bank, staging_ + "/" + name, zstd_level);
    std::filesystem::rename(staging_ + "/" + name, dir_ + "/" + name);
  }

  static TemplateBank* one_;
  static TemplateBank* two_;
  std::string dir_, staging_;
  Published published_;
  std::unique_ptr<CacheWatcher> watcher_;
};
TemplateBank* CacheWatcherTest::one_ = nullptr;
TemplateBank* CacheWatcherTest::two_ = nullptr;

TEST_F(CacheWatcherTest, LoadsACacheMovedInAndForgetsARemovedOne) {
  StartWatcher(/*inotify=*/true, /*scan_period_s=*/0.0);
  ASSERT_TRUE(watcher_->Inotify());
  MoveIn(*two_, "two.g6dcache");
  auto store = published_.WaitFor([](const TemplateStore& s) { return s.banks.count("obj_000002") > 0; });
  ASSERT_NE(store, nullptr) << "the moved-in cache was not loaded";
  EXPECT_EQ(store->ObjectIds(), (std::vector<std::string>{"obj_000001", "obj_000002"}));
  EXPECT_EQ(store->generation, 1);
  EXPECT_EQ(store->Find("obj_000002")->hash, HexString(HashFile(dir_ + "/two.g6dcache")));
  EXPECT_TRUE(store->refused.empty());

  std::filesystem::remove(dir_ + "/two.g6dcache");
  store = published_.WaitFor([](const TemplateStore& s) { return s.banks.count("obj_000002") == 0; });
  ASSERT_NE(store, nullptr) << "the removed cache's object is still served";
  EXPECT_EQ(store->ObjectIds(), (std::vector<std::string>{"obj_000001"}));
  const std::vector<StoreChange> changes = published_.Changes();
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].added, (std::vector<std::string>{"obj_000002"}));
  EXPECT_EQ(changes[1].removed, (std::vector<std::string>{"obj_000002"}));
}

TEST_F(CacheWatcherTest, RefusesABadVersionAndKeepsServingTheGoodOne) {
  StartWatcher(/*inotify=*/true, /*scan_period_s=*/0.0);
  const std::string path = dir_ + "/one.g6dcache";
  const std::string good_hash = HexString(HashFile(path));
  std::string corrupted = ReadBytes(path);
  corrupted[corrupted.size() / 2] = static_cast<char>(corrupted[corrupted.size() / 2] ^ 0x01);
  WriteBytes(path, corrupted);
  auto store = published_.WaitFor([&](const TemplateStore& s) { return !s.refused.empty(); });
  ASSERT_NE(store, nullptr) << "the corrupted version was not refused";
  ASSERT_EQ(store->refused.size(), 1u);
  EXPECT_EQ(store->refused[0].path, path);
  EXPECT_THAT(store->refused[0].reason, HasSubstr("corrupted: checksum mismatch"));
  EXPECT_THAT(store->refused[0].reason, HasSubstr("the version loaded before (hash " + good_hash + ") stays"));
  // The good version still serves, under its own hash.
  ASSERT_EQ(store->ObjectIds(), (std::vector<std::string>{"obj_000001"}));
  EXPECT_EQ(store->Find("obj_000001")->hash, good_hash);
  EXPECT_TRUE(published_.Changes().back().replaced.empty());

  // A good version of another hash replaces it.
  std::filesystem::remove(path);  // (a write over it would do as well; a move keeps it atomic)
  MoveIn(*one_, "one.g6dcache", /*zstd_level=*/3);
  store = published_.WaitFor([&](const TemplateStore& s) {
    return s.refused.empty() && s.banks.count("obj_000001") && s.Find("obj_000001")->hash != good_hash;
  });
  ASSERT_NE(store, nullptr) << "the new good version was not loaded";
}

TEST_F(CacheWatcherTest, RefusesNotACacheTruncatedAndDuplicateWithReasons) {
  StartWatcher(/*inotify=*/true, /*scan_period_s=*/0.0);
  const std::string good = ReadBytes(dir_ + "/one.g6dcache");
  WriteBytes(dir_ + "/notes.txt", "not a cache");
  WriteBytes(dir_ + "/truncated.g6dcache", good.substr(0, good.size() / 2));
  WriteBytes(dir_ + "/copy.g6dcache", good);  // obj_000001 again
  auto store = published_.WaitFor([](const TemplateStore& s) { return s.refused.size() == 3; });
  ASSERT_NE(store, nullptr) << "not every bad file was refused";
  EXPECT_TRUE(Refuses(*store, dir_ + "/notes.txt", "bad magic"));
  EXPECT_TRUE(Refuses(*store, dir_ + "/truncated.g6dcache", "truncated"));
  // "copy" sorts before "one", but "one" served the object first and keeps it.
  EXPECT_TRUE(Refuses(*store, dir_ + "/copy.g6dcache",
                      "duplicate object id 'obj_000001' (already loaded from " + dir_ + "/one.g6dcache)"));
  EXPECT_EQ(store->Find("obj_000001")->path, dir_ + "/one.g6dcache");
  // When the file that served it goes, the duplicate takes over: the same bytes, so the
  // object is not replaced.
  std::filesystem::remove(dir_ + "/one.g6dcache");
  store = published_.WaitFor([&](const TemplateStore& s) {
    return s.banks.count("obj_000001") && s.Find("obj_000001")->path == dir_ + "/copy.g6dcache";
  });
  ASSERT_NE(store, nullptr);
  EXPECT_EQ(store->refused.size(), 2u);
  for (const StoreChange& change : published_.Changes()) EXPECT_TRUE(change.replaced.empty());
}

TEST_F(CacheWatcherTest, WithoutInotifyTheRescanFindsCachesAndRescanForcesOne) {
  // The periodic rescan alone, then Rescan() alone (period 0).
  StartWatcher(/*inotify=*/false, /*scan_period_s=*/0.2);
  ASSERT_FALSE(watcher_->Inotify());
  MoveIn(*two_, "two.g6dcache");  // read once its mtime is settle_s old
  auto store = published_.WaitFor([](const TemplateStore& s) { return s.banks.count("obj_000002") > 0; });
  ASSERT_NE(store, nullptr) << "the periodic rescan did not load the new cache";
  watcher_->Stop();

  CacheWatcherOptions options;
  options.dir = dir_;
  options.use_inotify = false;
  options.scan_period_s = 0.0;
  Published forced;
  CacheWatcher watcher(options, LoadTemplateStore(dir_), forced.Callback());
  watcher.Start();
  std::filesystem::remove(dir_ + "/two.g6dcache");
  watcher.Rescan();
  store = forced.WaitFor([](const TemplateStore& s) { return s.banks.count("obj_000002") == 0; });
  ASSERT_NE(store, nullptr) << "Rescan() did not notice the removal";
  EXPECT_EQ(store->generation, 1);
}

TEST_F(CacheWatcherTest, AFileBeingWrittenIsNotReadUntilComplete) {
  // A rescan every 50 ms while a copy is half written for 0.4 s: the half file is too
  // fresh to be read (settle_s 5 s, ample on a loaded machine), and the close event reads
  // the whole file.
  StartWatcher(/*inotify=*/true, /*scan_period_s=*/0.05, /*settle_s=*/5.0);
  WriteTemplateCache(*two_, staging_ + "/two.g6dcache", 1);
  const std::string bytes = ReadBytes(staging_ + "/two.g6dcache");
  {
    std::ofstream out(dir_ + "/two.g6dcache", std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
    out.flush();
    const int64_t scans = watcher_->Scans();
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    EXPECT_GT(watcher_->Scans(), scans) << "no rescan ran while the file was half written";
    out.write(bytes.data() + bytes.size() / 2, static_cast<std::streamsize>(bytes.size() - bytes.size() / 2));
  }
  auto store = published_.WaitFor([](const TemplateStore& s) { return s.banks.count("obj_000002") > 0; });
  ASSERT_NE(store, nullptr);
  for (const StoreChange& change : published_.Changes()) {
    EXPECT_FALSE(change.refusals_changed) << "a half-written file was read and refused";
  }
}

TEST(AssembleStore, AnObjectStaysWithItsFileAndABadVersionKeepsTheLastGoodBank) {
  auto bank = std::make_shared<const TemplateBank>(TinyBank("obj_000007"));
  std::map<std::string, WatchedFile> files;
  files["/d/a.g6dcache"] = {FileSignature{1, 1, 1}, "aa", bank, "aa", ""};
  files["/d/b.g6dcache"] = {FileSignature{1, 1, 2}, "bb", bank, "bb", ""};
  TemplateStore previous;
  previous.generation = 4;
  previous.loaded.push_back({"/d/b.g6dcache", "obj_000007", 6, 0.1, "bb", FileSignature{1, 1, 2}});
  TemplateStore store = AssembleStore(files, previous);
  EXPECT_EQ(store.generation, 4);
  ASSERT_EQ(store.loaded.size(), 1u);
  EXPECT_EQ(store.loaded[0].path, "/d/b.g6dcache");
  ASSERT_EQ(store.refused.size(), 1u);
  EXPECT_THAT(store.refused[0].reason, HasSubstr("duplicate object id 'obj_000007'"));

  files.erase("/d/a.g6dcache");
  files["/d/b.g6dcache"].error = "truncated";
  store = AssembleStore(files, previous);
  ASSERT_EQ(store.loaded.size(), 1u);
  EXPECT_EQ(store.loaded[0].hash, "bb");
  ASSERT_EQ(store.refused.size(), 1u);
  EXPECT_EQ(store.refused[0].reason, "truncated; the version loaded before (hash bb) stays in service");
  const StoreChange change = DiffStores(previous, store);
  EXPECT_TRUE(change.added.empty() && change.replaced.empty() && change.removed.empty());
  EXPECT_TRUE(change.refusals_changed);
}

TEST(IsTemporaryName, SkipsFilesOnTheirWayToACache) {
  for (const char* name : {".obj.g6dcache", "obj.g6dcache~", "obj.g6dcache.part", "obj.tmp",
                           "obj.g6dcache.tmp.1234.0", ""}) {
    EXPECT_TRUE(IsTemporaryName(name)) << name;
  }
  for (const char* name : {"obj_000005.g6dcache", "obj", "tmp.g6dcache"}) EXPECT_FALSE(IsTemporaryName(name)) << name;
}

TEST(CacheWatcherOptions, CheckNamesTheBadField) {
  CacheWatcherOptions options;
  EXPECT_THAT(options.Check(), HasSubstr("dir"));
  options.dir = "/tmp";
  EXPECT_EQ(options.Check(), "");
  options.scan_period_s = -1.0;
  EXPECT_THAT(options.Check(), HasSubstr("scan_period_s"));
  options.scan_period_s = 1.0;
  options.settle_s = std::nan("");
  EXPECT_THAT(options.Check(), HasSubstr("settle_s"));
  EXPECT_THROW({ CacheWatcher watcher(options, TemplateStore(), nullptr); }, Error);
}

}  // namespace
}  // namespace g6d
