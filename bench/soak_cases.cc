// g6d-bench-soak (bench/soak_main.cc says what it does and how to run it): the cases and the
// matching of answers.
#include "soak_cases.h"

#include <cstdio>

#include "core/error.h"
#include "replay/frame_log.h"
#include "wire/names.h"

namespace g6d::soak {

void AnswerCollector::Withheld(int64_t seq) {
  std::lock_guard<std::mutex> lock(mutex_);
  G6D_CHECK(seq == static_cast<int64_t>(messages_.size()) + 1);
  messages_.push_back({kWithheld, Clock::now(), false});
}

void AnswerCollector::Sent(int64_t seq, int kind, Clock::time_point at) {
  std::lock_guard<std::mutex> lock(mutex_);
  G6D_CHECK(seq == static_cast<int64_t>(messages_.size()) + 1);
  messages_.push_back({kind, at, false});
  if (kind < 0) {
    ++tally_.good.sent;
  } else {
    ++tally_.kinds[kind].sent;
    if (!(*cases_)[kind].seq_known) unnamed_.push_back(seq);
  }
}

void AnswerCollector::OnAnswer(const lcm::ReceiveBuffer*, const std::string&,
                               const g6d::pose_array_t* answer) {
  const Clock::time_point now = Clock::now();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++tally_.answers;
    for (size_t i = 0; i < answer->timing_names.size() && i < answer->timing_s.size(); ++i) {
      if (answer->timing_names[i] == "decode") tally_.decode_s.push_back(answer->timing_s[i]);
    }
    int64_t seq = answer->seq;
    if (seq == -1 && !unnamed_.empty()) {
      // Not our message type: the service cannot read the seq. It answers these at once
      // from its LCM thread, in arrival order, so they go to the oldest such message.
      seq = unnamed_.front();
      unnamed_.pop_front();
    }
    if (seq < 1 || seq > static_cast<int64_t>(messages_.size()) ||
        messages_[seq - 1].kind == kWithheld) {
      ++tally_.unmatched;
    } else if (messages_[seq - 1].answered) {
      ++tally_.duplicates;
    } else {
      messages_[seq - 1].answered = true;
      ++answered_;
      Evaluate(messages_[seq - 1], *answer, Seconds(now - messages_[seq - 1].sent));
    }
  }
  changed_.notify_all();
}

void AnswerCollector::OnStatus(const lcm::ReceiveBuffer*, const std::string&,
                               const g6d::service_status_t* status) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    tally_.status = *status;
    tally_.has_status = true;
  }
  changed_.notify_all();
}

int64_t AnswerCollector::answered() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return answered_;
}

Tally AnswerCollector::Snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tally_;
}

bool AnswerCollector::WaitForStatusSince(int64_t utime, Clock::duration timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, timeout,
                           [&] { return tally_.has_status && tally_.status.utime >= utime; });
}

bool AnswerCollector::WaitForDrain(int64_t utime, Clock::duration timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] {
    const g6d::service_status_t& s = tally_.status;
    return tally_.has_status && s.utime >= utime && s.busy == 0 && s.mailbox_full == 0 &&
           tally_.answers >= s.frames_processed + s.frames_rejected;
  });
}

void AnswerCollector::Evaluate(const Message& message, const g6d::pose_array_t& answer,
                               double latency_s) {
  const bool frame_ok = answer.status == g6d::pose_array_t::STATUS_OK;
  if (message.kind < 0) {
    GoodCounts& good = tally_.good;
    ++good.answered;
    if (frame_ok) {
      ++good.frame_ok;
      for (const g6d::pose_estimate_t& estimate : answer.estimates)
        ++good.estimates[g6d::EstimateStatusName(estimate.status)];
      tally_.good_latency_s.push_back(latency_s);
      tally_.good_service_s.push_back(answer.total_s);
    } else {
      if (good.rejected++ == 0) good.example = answer.message;
    }
    return;
  }
  const BadCase& bad = (*cases_)[message.kind];
  KindCounts& counts = tally_.kinds[message.kind];
  ++counts.answered;
  tally_.error_latency_s.push_back(latency_s);
  // An error answer: the frame refused, or every estimate failed. The message shown for
  // an unexpected answer is the frame's, or that of the first unexpected estimate.
  bool all_failed = !answer.estimates.empty(), all_expected = !answer.estimates.empty();
  std::string message_text = answer.message;
  for (const g6d::pose_estimate_t& estimate : answer.estimates) {
    const bool as_expected = estimate.status == bad.estimate_status &&
                             estimate.message.find(bad.words) != std::string::npos;
    if (frame_ok && all_expected && !as_expected) message_text = estimate.message;
    all_failed = all_failed && estimate.status != g6d::pose_estimate_t::STATUS_OK;
    all_expected = all_expected && as_expected;
  }
  const bool is_error = !frame_ok || all_failed;
  const bool expected =
      answer.status == bad.frame_status &&
      (frame_ok ? all_expected : answer.message.find(bad.words) != std::string::npos);
  if (expected) {
    ++counts.expected;
  } else {
    if (counts.other_error + counts.not_error == 0) counts.example = message_text;
    ++(is_error ? counts.other_error : counts.not_error);
  }
}

std::vector<std::vector<uint8_t>> LoadGoodFrames(const SoakOptions& options,
                                                 g6d::rgbd_frame_t* first) {
  g6d::FrameLogReader reader(options.log_path, options.log_channel);
  std::vector<std::vector<uint8_t>> frames;
  g6d::FrameEvent event;
  while (reader.Next(&event)) {
    if (frames.empty()) *first = event.frame;
    frames.push_back(g6d::synthetic::EncodeMessage(event.frame));
  }
  for (const std::string& problem : reader.stats().Problems())
    std::fprintf(stderr, "[soak] %s\n", problem.c_str());
  if (frames.empty())
    G6D_THROW(options.log_path << " holds no g6d_rgbd_frame_t on '" << options.log_channel << "'");
  if (first->instances.empty()) G6D_THROW(options.log_path << ": the first frame has no instances");
  return frames;
}

}  // namespace g6d::soak
