#pragma once
/// @file service_util.h
/// Small helpers shared by the service's translation units (internal to service/).

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace g6d {
namespace service_util {

using Clock = std::chrono::steady_clock;

/// Seconds from `from` to `to`.
inline double SecondsBetween(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

/// Wall-clock time now, microseconds since the epoch (LCM's utime).
inline int64_t NowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// "a, b, c", or "none" for no ids (for messages naming the loaded objects).
inline std::string JoinIds(const std::vector<std::string>& ids) {
  std::string joined;
  for (const std::string& id : ids) joined += (joined.empty() ? "" : ", ") + id;
  return joined.empty() ? "none" : joined;
}

}  // namespace service_util
}  // namespace g6d
