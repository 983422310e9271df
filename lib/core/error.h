#pragma once
/// @file error.h
/// Errors at public boundaries (bad arguments, bad files) are thrown as g6d::Error with a
/// message saying what and where. Broken internal invariants abort via G6D_CHECK.

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>

namespace g6d {

/// Exception for bad input at a public boundary (file, field, expected vs got).
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

namespace internal {
[[noreturn]] inline void CheckFailed(const char* condition, const char* file, int line,
                                     const std::string& message) {
  std::fprintf(stderr, "%s:%d: check failed: %s %s\n", file, line, condition, message.c_str());
  std::abort();
}
}  // namespace internal

}  // namespace g6d

/// Aborts with file:line when an internal invariant does not hold.
#define G6D_CHECK(condition)                                                   \
  do {                                                                         \
    if (!(condition)) ::g6d::internal::CheckFailed(#condition, __FILE__, __LINE__, ""); \
  } while (false)

/// Throws g6d::Error built from a stream expression: G6D_THROW("file " << path << " is empty").
#define G6D_THROW(stream_expression)          \
  do {                                        \
    std::ostringstream g6d_throw_stream;      \
    g6d_throw_stream << stream_expression;    \
    throw ::g6d::Error(g6d_throw_stream.str()); \
  } while (false)
