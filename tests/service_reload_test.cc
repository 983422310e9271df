// Objects added, replaced, refused and removed while g6d::Service runs (issue 24): real
// cache files in a real folder, the service in-process on a real LCM bus (memq), and the
// g6d-service binary over udpm for SIGHUP. A new cache is answered without a restart, a
// bad one is refused with its reason while the loaded objects are still answered, a
// replaced object's track is dropped, a removed object is unknown again.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "core/hash.h"
#include "process_util.h"
#include "service/service.h"
#include "service_fixture.h"
#include "service_test_util.h"
#include "templates/cache.h"
#include "test_bank.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;
using std::chrono::seconds;
using Clock = std::chrono::steady_clock;

constexpr char kSecondId[] = "box_000002";
constexpr char kThirdId[] = "box_000003";
constexpr int64_t kFramePeriodUs = 33333;

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

bool Serves(const service_status_t& status, const std::string& object_id) {
  return std::find(status.objects.begin(), status.objects.end(), object_id) != status.objects.end();
}

// The hash the status gives for `object_id` ("" when it is not served).
std::string HashIn(const service_status_t& status, const std::string& object_id) {
  for (int i = 0; i < status.num_objects; ++i) {
    if (status.objects[i] == object_id) return status.object_cache_hashes[i];
  }
  return "";
}

// The reason the status gives for refusing `path` ("" when it is not refused).
std::string RefusalOf(const service_status_t& status, const std::string& path) {
  for (int i = 0; i < status.num_refused; ++i) {
    if (status.refused_files[i] == path) return status.refused_reasons[i];
  }
  return "";
}

class ServiceReloadTest : public test::InProcessServiceTest {
 protected:
  static void SetUpTestSuite() {
    scene_ = new test::ServiceScene(test::MakeServiceScene(1, 11, test::SharedBankBuilder("reload-scene")));
  }
  static void TearDownTestSuite() { delete scene_; }

  void SetUp() override {
    dir_ = test::TempDir(std::string("service_reload_") +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    staging_ = dir_ + "_staging";
    std::filesystem::create_directories(staging_);
    WriteCache(test::kBoxId, dir_ + "/" + test::kBoxId + ".g6dcache");
  }
  void TearDown() override {
    InProcessServiceTest::TearDown();
    std::filesystem::remove_all(dir_);
    std::filesystem::remove_all(staging_);
  }

  /// The scene's bank under `object_id` as a cache file (another zstd level gives other
  /// bytes: a new version of the same object).
  static void WriteCache(const std::string& object_id, const std::string& path, int zstd_level = 1) {
    TemplateBank bank = scene_->bank;
    bank.object_id = object_id;
    WriteTemplateCache(bank, path, zstd_level);
  }

  void StartService(const std::string& suffix) {
    test::SetInProcessServiceOptions(suffix, &options_);
    options_.templates_dir = dir_;
    options_.status_period_s = 0.1;
    ASSERT_TRUE(options_.reload) << "reloading is on by default";
    InProcessServiceTest::StartService(options_, LoadTemplateStore(dir_));
  }

  /// The estimate answering a frame of the scene's view naming `object_id` (frames 33 ms
  /// apart on the capture clock, so a track continues from one to the next).
  pose_estimate_t Solve(const std::string& object_id) {
    rgbd_frame_t frame = test::MakeRgbdFrame(scene_->views[0], seq_, object_id);
    frame.utime = kStartUtime + seq_ * kFramePeriodUs;
    ++seq_;
    EXPECT_EQ(lcm_.publish(options_.input_channel, &frame), 0);
    const std::optional<pose_array_t> answer =
        listener_->answers.PopUntil(std::chrono::milliseconds(60000), [&](const pose_array_t& a) { return a.seq == frame.seq; });
    if (!answer || answer->num_estimates != 1) {
      ADD_FAILURE() << "no answer with one estimate for frame " << frame.seq;
      return pose_estimate_t{};
    }
    return answer->estimates[0];
  }

  /// The first status for which `accept` holds, within 30 s; fails the test otherwise.
  template <typename Predicate>
  service_status_t WaitForStatus(const std::string& what, Predicate accept) {
    std::optional<service_status_t> status = listener_->statuses.PopUntil(std::chrono::milliseconds(30000), accept);
    if (!status) ADD_FAILURE() << "no status within 30 s where " << what;
    return status.value_or(service_status_t{});
  }

  static constexpr int64_t kStartUtime = 1700000000000000LL;
  static test::ServiceScene* scene_;
  std::string dir_, staging_;
  int64_t seq_ = 1;
};
test::ServiceScene* ServiceReloadTest::scene_ = nullptr;

TEST_F(ServiceReloadTest, NewCachesAreAnsweredWithoutARestart) {
  StartService("reload_new");
  const service_status_t first = WaitForStatus("box_000001 is served", [](const service_status_t& s) {
    return Serves(s, test::kBoxId);
  });
  EXPECT_EQ(first.reload, 1);
  EXPECT_EQ(first.cache_generation, 0);
  EXPECT_EQ(first.num_objects, 1);
  ASSERT_EQ(first.object_cache_hashes.size(), 1u);
  EXPECT_EQ(first.object_cache_hashes[0], HexString(HashFile(dir_ + "/box_000001.g6dcache")));
  EXPECT_EQ(Solve(kSecondId).status, +pose_estimate_t::STATUS_UNKNOWN_OBJECT);

  // 1. Written under a temporary name in the folder, then renamed (IN_MOVED_TO).
  WriteCache(kSecondId, staging_ + "/second");
  std::filesystem::copy_file(staging_ + "/second", dir_ + "/.box_000002.partial");
  const Clock::time_point renamed = Clock::now();
  std::filesystem::rename(dir_ + "/.box_000002.partial", dir_ + "/box_000002.g6dcache");
  const service_status_t second = WaitForStatus("box_000002 is served", [](const service_status_t& s) {
    return Serves(s, kSecondId);
  });
  EXPECT_EQ(second.cache_generation, 1);
  EXPECT_EQ(HashIn(second, kSecondId), HexString(HashFile(dir_ + "/box_000002.g6dcache")));
  const pose_estimate_t answer = Solve(kSecondId);
  const double rename_s = std::chrono::duration<double>(Clock::now() - renamed).count();
  EXPECT_EQ(answer.status, +pose_estimate_t::STATUS_OK) << answer.message;
  EXPECT_EQ(answer.object_id, kSecondId);

  // 2. A plain copy into the folder (IN_CLOSE_WRITE).
  WriteCache(kThirdId, staging_ + "/third");
  const Clock::time_point copied = Clock::now();
  std::filesystem::copy_file(staging_ + "/third", dir_ + "/box_000003.g6dcache");
  WaitForStatus("box_000003 is served", [](const service_status_t& s) { return Serves(s, kThirdId); });
  const pose_estimate_t third = Solve(kThirdId);
  const double copy_s = std::chrono::duration<double>(Clock::now() - copied).count();
  EXPECT_EQ(third.status, +pose_estimate_t::STATUS_OK) << third.message;
  // Recorded, not asserted (a unit test asserts no timing; bench/RESULTS.md has the numbers).
  std::printf("[reload] cache in the folder -> first OK answer: rename %.3f s, copy %.3f s\n", rename_s, copy_s);
  RecordProperty("rename_to_answer_ms", static_cast<int>(rename_s * 1e3));
  RecordProperty("copy_to_answer_ms", static_cast<int>(copy_s * 1e3));
  // The first object is still answered.
  EXPECT_EQ(Solve(test::kBoxId).status, +pose_estimate_t::STATUS_OK);
}

TEST_F(ServiceReloadTest, ABadCacheIsRefusedWithItsReasonAndTheServiceKeepsAnswering) {
  WriteCache(kThirdId, dir_ + "/box_000003.g6dcache");
  StartService("reload_bad");
  const std::string good = ReadBytes(dir_ + "/box_000001.g6dcache");
  // A new file that is corrupted, and a corrupted version of a loaded object's file.
  std::string corrupted = good;
  corrupted[corrupted.size() / 2] = static_cast<char>(corrupted[corrupted.size() / 2] ^ 0x01);
  WriteBytes(dir_ + "/corrupted.g6dcache", corrupted);
  const std::string third_path = dir_ + "/box_000003.g6dcache";
  const std::string third_hash = HexString(HashFile(third_path));
  const std::string third = ReadBytes(third_path);
  WriteBytes(third_path, third.substr(0, third.size() / 2));
  WriteBytes(dir_ + "/duplicate.g6dcache", good);
  const service_status_t status = WaitForStatus("three files are refused", [](const service_status_t& s) {
    return s.num_refused == 3;
  });
  EXPECT_THAT(RefusalOf(status, dir_ + "/corrupted.g6dcache"), HasSubstr("corrupted: checksum mismatch"));
  EXPECT_THAT(RefusalOf(status, third_path), HasSubstr("truncated"));
  EXPECT_THAT(RefusalOf(status, third_path), HasSubstr("the version loaded before (hash " + third_hash + ") stays"));
  EXPECT_THAT(RefusalOf(status, dir_ + "/duplicate.g6dcache"), HasSubstr("duplicate object id 'box_000001'"));
  // Both objects are still served, the truncated one by its last good version.
  EXPECT_EQ(status.objects, (std::vector<std::string>{test::kBoxId, kThirdId}));
  EXPECT_EQ(HashIn(status, kThirdId), third_hash);
  const pose_estimate_t first = Solve(test::kBoxId);
  EXPECT_EQ(first.status, +pose_estimate_t::STATUS_OK) << first.message;
  const pose_estimate_t kept = Solve(kThirdId);
  EXPECT_EQ(kept.status, +pose_estimate_t::STATUS_OK) << kept.message;
}

TEST_F(ServiceReloadTest, AReplacedObjectLosesItsTrackAndARemovedOneIsUnknown) {
  WriteCache(kSecondId, dir_ + "/box_000002.g6dcache");
  StartService("reload_replace");
  EXPECT_EQ(Solve(test::kBoxId).mode, +pose_estimate_t::MODE_DETECTED);
  const pose_estimate_t tracked = Solve(test::kBoxId);
  ASSERT_EQ(tracked.status, +pose_estimate_t::STATUS_OK) << tracked.message;
  ASSERT_EQ(tracked.mode, +pose_estimate_t::MODE_TRACKED) << "the premise: the second frame continues the track";

  // A new version of box_000001 (other bytes), moved in over the old one.
  const std::string path = dir_ + "/box_000001.g6dcache";
  const std::string old_hash = HexString(HashFile(path));
  WriteCache(test::kBoxId, staging_ + "/first", /*zstd_level=*/3);
  std::filesystem::copy_file(staging_ + "/first", dir_ + "/.box_000001.partial");
  std::filesystem::rename(dir_ + "/.box_000001.partial", path);
  const std::string new_hash = HexString(HashFile(path));
  ASSERT_NE(new_hash, old_hash);
  WaitForStatus("box_000001 has its new hash", [&](const service_status_t& s) {
    return HashIn(s, test::kBoxId) == new_hash;
  });
  const pose_estimate_t after = Solve(test::kBoxId);
  EXPECT_EQ(after.status, +pose_estimate_t::STATUS_OK) << after.message;
  EXPECT_EQ(after.mode, +pose_estimate_t::MODE_DETECTED) << "the replaced object's track was not dropped";
  EXPECT_NE(after.track_id, tracked.track_id);

  // Removed: unknown again, the other object still answered.
  EXPECT_EQ(Solve(kSecondId).status, +pose_estimate_t::STATUS_OK);
  std::filesystem::remove(dir_ + "/box_000002.g6dcache");
  const service_status_t status = WaitForStatus("box_000002 is gone", [](const service_status_t& s) {
    return !Serves(s, kSecondId) && s.cache_generation >= 2;
  });
  EXPECT_EQ(status.objects, (std::vector<std::string>{test::kBoxId}));
  const pose_estimate_t removed = Solve(kSecondId);
  EXPECT_EQ(removed.status, +pose_estimate_t::STATUS_UNKNOWN_OBJECT);
  EXPECT_THAT(removed.message, HasSubstr("no template cache for object id 'box_000002'"));
  EXPECT_EQ(Solve(test::kBoxId).status, +pose_estimate_t::STATUS_OK);
}

// The binary: SIGHUP rescans (it does not end the process), and --reload off keeps the
// caches of the start. A hard link made in the folder raises no event the watcher
// listens to (IN_CREATE), and the periodic rescan is off: only SIGHUP finds it.
class ServiceReloadProcessTest : public ServiceReloadTest {
 protected:
  /// A udpm URL on a port of this test's range (7630-7649), by process id.
  static std::string BusUrl() {
    return "udpm://239.255.76.67:" + std::to_string(7630 + getpid() % 20) + "?ttl=0&recv_buf_size=4194304";
  }
};

TEST_F(ServiceReloadProcessTest, SighupRescansTheFolder) {
  const std::string url = BusUrl();
  lcm::LCM bus(url);
  ASSERT_TRUE(bus.good());
  test::ServiceListener listener(&bus, "G6D_POSES_hup", "G6D_STATUS_hup");
  LcmHandleThread handle(&bus);
  const std::string log = dir_ + "_service.log";
  test::ChildProcess service({test::BinaryDir() + "/service/g6d-service", "--templates", dir_, "--lcm-url", url,
                              "--input", "G6D_RGBD_hup", "--output", "G6D_POSES_hup", "--status", "G6D_STATUS_hup",
                              "--reload-scan-period-s", "0", "--hypotheses", "2"},
                             log);
  ASSERT_TRUE(service.started());
  auto wait = [&](const std::string& what, auto accept) {
    std::optional<service_status_t> status = listener.statuses.PopUntil(std::chrono::milliseconds(60000), accept);
    EXPECT_TRUE(status.has_value()) << "no status within 60 s where " << what << "; log:\n" << ReadBytes(log);
    return status.value_or(service_status_t{});
  };
  wait("box_000001 is served", [](const service_status_t& s) { return Serves(s, test::kBoxId); });
  WriteCache(kSecondId, dir_ + "/.box_000002.staged");
  ASSERT_EQ(::link((dir_ + "/.box_000002.staged").c_str(), (dir_ + "/box_000002.g6dcache").c_str()), 0);
  ASSERT_TRUE(service.Running());
  ASSERT_EQ(service.Signal(SIGHUP), 0);
  const service_status_t status = wait("box_000002 is served", [](const service_status_t& s) {
    return Serves(s, kSecondId);
  });
  EXPECT_EQ(status.cache_generation, 1);
  EXPECT_TRUE(service.Running()) << "SIGHUP ended the service";
  EXPECT_EQ(service.Stop(), 0);
  EXPECT_THAT(ReadBytes(log), HasSubstr("reload: rescanning"));
  std::filesystem::remove(log);
}

}  // namespace
}  // namespace g6d
