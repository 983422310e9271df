#pragma once
/// @file soak_cases.h
/// g6d-bench-soak's cases: the good frames (an LCM log, cycled) and the bad ones (every
/// kind of wire/bad_frames.h), and how each answer is matched to the message it answers
/// and judged against what that message should get.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "g6d/pose_array_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "g6d/service_status_t.hpp"
#include "soak_options.h"
#include "wire/bad_frames.h"

namespace g6d::soak {

using g6d::synthetic::BadCase;

/// What happened to the messages of one bad kind.
struct KindCounts {
  int64_t sent = 0;
  int64_t answered = 0;
  int64_t expected = 0;     ///< answered with the expected status and words
  int64_t other_error = 0;  ///< answered with an error, but not the expected one
  int64_t not_error = 0;    ///< answered with a pose: a bad frame taken for a good one
  std::string example;      ///< the message of the first unexpected answer
};

/// Counts of the good frames.
struct GoodCounts {
  int64_t sent = 0;
  int64_t answered = 0;
  int64_t frame_ok = 0;                      ///< answered STATUS_OK
  int64_t rejected = 0;                      ///< answered STATUS_BAD_FRAME: a good frame refused
  std::string example;                       ///< the message of the first rejection
  std::map<std::string, int64_t> estimates;  ///< estimates of the answers per status name
};

/// Everything the collector knows, copied out under its lock.
struct Tally {
  GoodCounts good;
  std::vector<KindCounts> kinds;        ///< per bad case
  int64_t answers = 0;                  ///< answers on the output channel, all of them
  int64_t unmatched = 0;                ///< answers to no message of this run
  int64_t duplicates = 0;               ///< second answers to a message
  std::vector<double> good_latency_s;   ///< publish -> answer of good frames
  std::vector<double> good_service_s;   ///< total_s of their answers
  std::vector<double> error_latency_s;  ///< publish -> answer of bad frames
  /// The "decode" timing of every answer: the service's LCM handler time for the message
  /// (LCM drops new messages while its subscription queue is full, so this bounds how
  /// far the handler can fall behind).
  std::vector<double> decode_s;
  bool has_status = false;
  g6d::service_status_t status{};  ///< the last one
};

/// Matches answers on the output channel to the messages sent and keeps the service's
/// last status; called from the LCM pump thread and the publishing thread.
class AnswerCollector {
 public:
  explicit AnswerCollector(const std::vector<BadCase>* cases) : cases_(cases) {
    tally_.kinds.resize(cases->size());
  }

  /// Records that message `seq` was withheld (never sent): its seq is a gap for the service.
  void Withheld(int64_t seq);

  /// Records message `seq` (= 1, 2, ... in send order) of kind `kind` (-1 = good).
  void Sent(int64_t seq, int kind, Clock::time_point at);

  /// LCM handler of the answers.
  void OnAnswer(const lcm::ReceiveBuffer*, const std::string&, const g6d::pose_array_t* answer);

  /// LCM handler of the service's status.
  void OnStatus(const lcm::ReceiveBuffer*, const std::string&, const g6d::service_status_t* status);

  /// Answers matched to a message so far.
  int64_t answered() const;

  /// A copy of everything counted so far.
  Tally Snapshot() const;

  /// Waits up to `timeout` for a status published at or after `utime`; true when one came.
  bool WaitForStatusSince(int64_t utime, Clock::duration timeout);

  /// Waits up to `timeout` until the service is idle in a status published at or after
  /// `utime` (nothing being solved or waiting in the mailbox) and every answer it
  /// published has arrived here; true when that happened.
  bool WaitForDrain(int64_t utime, Clock::duration timeout);

 private:
  static constexpr int kWithheld = -2;
  struct Message {
    int kind = -1;  ///< -1 good, kWithheld, else index into cases_
    Clock::time_point sent;
    bool answered = false;
  };

  void Evaluate(const Message& message, const g6d::pose_array_t& answer, double latency_s);

  const std::vector<BadCase>* cases_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Message> messages_;  ///< index seq - 1
  std::deque<int64_t> unnamed_;    ///< unanswered messages the service answers with seq -1
  int64_t answered_ = 0;
  Tally tally_;
};

/// The frames of the log, encoded once; each send patches seq and utime in. `first` gets
/// the first frame (the bad cases are made from it). Throws g6d::Error when the log holds
/// no frame on options.log_channel or the first frame has no instances.
std::vector<std::vector<uint8_t>> LoadGoodFrames(const SoakOptions& options,
                                                 g6d::rgbd_frame_t* first);

}  // namespace g6d::soak
