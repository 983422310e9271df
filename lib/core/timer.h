#pragma once
/// @file timer.h
/// Wall-clock timing for stage reports.

#include <atomic>
#include <chrono>

namespace g6d {

/// Monotonic stopwatch; ElapsedMs() since construction or the last Restart().
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void Restart() { start_ = std::chrono::steady_clock::now(); }
  double ElapsedMs() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// Adds the milliseconds of its lifetime to *total_ms when destroyed.
class ScopedTimer {
 public:
  explicit ScopedTimer(double* total_ms) : total_ms_(total_ms) {}
  ~ScopedTimer() { *total_ms_ += watch_.ElapsedMs(); }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double* total_ms_;
  Stopwatch watch_;
};

/// A solve's time limit and stop request, checked between units of work (a unit that has
/// started always finishes: the limit is kept to within one unit, about a millisecond for
/// the solver's per-hypothesis steps). Default-constructed, it never expires.
class Deadline {
 public:
  Deadline() = default;
  /// budget_ms <= 0: no time limit; stop: when it becomes true the deadline has expired
  /// (may be null). The clock starts now.
  Deadline(double budget_ms, const std::atomic<bool>* stop) : budget_ms_(budget_ms), stop_(stop) {}
  /// True once the budget is used up or a stop was requested.
  bool Expired() const {
    return (stop_ != nullptr && stop_->load(std::memory_order_relaxed)) ||
           (budget_ms_ > 0.0 && watch_.ElapsedMs() >= budget_ms_);
  }
  /// True once `fraction` of the budget is used up or a stop was requested: a stage that
  /// should leave the rest of the budget to later stages ends at its share.
  bool ExpiredAt(double fraction) const {
    return (stop_ != nullptr && stop_->load(std::memory_order_relaxed)) ||
           (budget_ms_ > 0.0 && watch_.ElapsedMs() >= fraction * budget_ms_);
  }
  /// True when it expired because of the stop request (not the budget).
  bool Stopped() const { return stop_ != nullptr && stop_->load(std::memory_order_relaxed); }
  double ElapsedMs() const { return watch_.ElapsedMs(); }

 private:
  Stopwatch watch_;
  double budget_ms_ = 0.0;
  const std::atomic<bool>* stop_ = nullptr;
};

}  // namespace g6d
