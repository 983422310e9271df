#pragma once
/// @file timer.h
/// Wall-clock timing for stage reports.

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

}  // namespace g6d
