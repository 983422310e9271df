#pragma once
/// @file fuzz_limits.h
/// Decoding limits of the frame fuzz targets.

#include <cstdint>

#include "wire/frame_codec.h"

namespace g6d::fuzz {

/// Smaller than the service defaults (8192 x 8192, 512 MiB raw), so that one input cannot
/// take seconds or hit the fuzzer's memory limit by declaring a big but allowed plane. The
/// limit checks themselves are the same code for any value.
inline DecodeLimits FuzzLimits() {
  DecodeLimits limits;
  limits.max_width = 1024;
  limits.max_height = 1024;
  limits.max_raw_bytes = int64_t{16} << 20;
  return limits;
}

}  // namespace g6d::fuzz
