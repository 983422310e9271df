#pragma once
/// @file hash.h
/// 64-bit FNV-1a, used for mesh content hashes and cache checksums. Not cryptographic:
/// it detects stale and corrupted files, not tampering.

#include <cstddef>
#include <cstdint>
#include <string>

namespace g6d {

inline constexpr uint64_t kFnvOffsetBasis = 14695981039346656037ULL;

/// Continues an FNV-1a 64 hash over `size` bytes (start with kFnvOffsetBasis).
inline uint64_t Fnv1a64(const void* data, size_t size, uint64_t hash = kFnvOffsetBasis) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 1099511628211ULL;
  }
  return hash;
}

/// SplitMix64's finalizer: spreads the bits of a seed or key, so that neighbouring keys
/// (consecutive instance or frame ids) start unrelated random streams.
inline uint64_t SplitMix64(uint64_t value) {
  value += 0x9e3779b97f4a7c15ULL;
  value = (value ^ (value >> 30)) * 0xbf58476d1ce4e5b9ULL;
  value = (value ^ (value >> 27)) * 0x94d049bb133111ebULL;
  return value ^ (value >> 31);
}

/// Hash of a whole file's bytes; throws g6d::Error if it cannot be read.
uint64_t HashFile(const std::string& path);

/// 16 lowercase hex digits.
std::string HexString(uint64_t value);

}  // namespace g6d
