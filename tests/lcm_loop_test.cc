// LcmHandleThread on a real in-process LCM bus (memq): messages published from another
// thread reach their handler on the handle thread, Stop() returns while the bus is idle,
// and LcmChannelRegex() subscribes to exactly one literal channel.

#include "wire/lcm_loop.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "g6d/service_status_t.hpp"

namespace g6d {
namespace {

// Records the channel and service name of every status received, and the handling thread.
class Recorder {
 public:
  void Handle(const lcm::ReceiveBuffer*, const std::string& channel,
              const service_status_t* status) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      received_.push_back(channel + ":" + status->service_name);
      handler_thread_ = std::this_thread::get_id();
    }
    changed_.notify_all();
  }
  // Waits until `count` messages arrived (up to 10 s); the received ones.
  std::vector<std::string> WaitFor(size_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_for(lock, std::chrono::seconds(10), [&] { return received_.size() >= count; });
    return received_;
  }
  std::thread::id handler_thread() {
    std::lock_guard<std::mutex> lock(mutex_);
    return handler_thread_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::string> received_;
  std::thread::id handler_thread_;
};

service_status_t Status(const std::string& name) {
  service_status_t status{};
  status.service_name = name;
  return status;
}

TEST(LcmHandleThread, DeliversMessagesOnItsOwnThreadUntilStopped) {
  lcm::LCM bus("memq://");
  ASSERT_TRUE(bus.good());
  Recorder recorder;
  bus.subscribe(LcmChannelRegex("G6D.STATUS"), &Recorder::Handle, &recorder);
  LcmHandleThread handle_thread(&bus);
  const service_status_t first = Status("first"), other = Status("other channel"),
                         second = Status("second"), later = Status("after stop");
  ASSERT_EQ(bus.publish("G6D.STATUS", &first), 0);
  ASSERT_EQ(bus.publish("G6DxSTATUS", &other), 0);  // an unescaped '.' would match it
  ASSERT_EQ(bus.publish("G6D.STATUS", &second), 0);
  EXPECT_THAT(recorder.WaitFor(2), testing::ElementsAre("G6D.STATUS:first", "G6D.STATUS:second"));
  EXPECT_NE(recorder.handler_thread(), std::this_thread::get_id());
  handle_thread.Stop();
  handle_thread.Stop();  // idempotent
  // The loop has let go of the bus: this thread may handle it now.
  ASSERT_EQ(bus.publish("G6D.STATUS", &later), 0);
  ASSERT_GT(bus.handleTimeout(10000), 0);
  EXPECT_THAT(recorder.WaitFor(3), testing::ElementsAre("G6D.STATUS:first", "G6D.STATUS:second",
                                                        "G6D.STATUS:after stop"));
  EXPECT_EQ(recorder.handler_thread(), std::this_thread::get_id());
}

TEST(LcmHandleThread, RefusesAnUnusableLcm) { EXPECT_THROW(LcmHandleThread(nullptr), Error); }

TEST(LcmChannelRegex, EscapesEveryRegexCharacter) {
  EXPECT_EQ(LcmChannelRegex("CAM_0"), "CAM_0");
  EXPECT_EQ(LcmChannelRegex("a.b*c+d?(e)[f]{g}|h^i$j\\"),
            "a\\.b\\*c\\+d\\?\\(e\\)\\[f\\]\\{g\\}\\|h\\^i\\$j\\\\");
}

}  // namespace
}  // namespace g6d
