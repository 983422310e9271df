#pragma once
/// @file cache_format.h
/// The byte layout of template cache files (internal to lib/templates; cache.h describes the
/// format): the header's fields and the bounds on what a file may declare, a little-endian
/// Writer and a bounded little-endian Reader (every read checked against the bytes left,
/// every count against its bound, before anything is allocated).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.h"

namespace g6d {
namespace cache_format {

// ---- Layout constants -------------------------------------------------------------------

inline constexpr char kMagic[8] = {'G', '6', 'D', 'C', 'A', 'C', 'H', 'E'};
inline constexpr size_t kHeaderSize = 64;
// Header field offsets.
inline constexpr size_t kVersionOffset = 8;
inline constexpr size_t kHeaderSizeOffset = 12;
inline constexpr size_t kBodySizeOffset = 16;
inline constexpr size_t kCompressedSizeOffset = 24;
inline constexpr size_t kBodyChecksumOffset = 32;
inline constexpr size_t kHeaderChecksumOffset = 56;  // FNV-1a 64 of bytes [0, 56)

// Bounds on everything a file can declare; checked before any allocation.
// 256 MiB uncompressed: a 324-template bank is 5-20 MB. The reader allocates the declared
// size before decompressing, so this bounds what a small hostile file can cost.
inline constexpr uint64_t kMaxBodyBytes = uint64_t{256} << 20;
inline constexpr uint32_t kMaxStringBytes = 4096;
inline constexpr uint32_t kMaxSymmetries = 4096;
inline constexpr uint32_t kMaxVertices = 10000000;
inline constexpr uint32_t kMaxPpfPoints = 60000;  // PpfModelOptions::max_points at most (uint16 indices)
inline constexpr uint32_t kMaxFaces = 20000000;
inline constexpr uint32_t kMaxTemplates = 100000;
inline constexpr uint32_t kMaxKeypointsPerTemplate = 100000;
// Masks are run-length coded, so a few bytes can declare a big one: a file may declare
// at most this many bytes of masks and thumbnails over all templates (as much as the
// largest body; a 324-template bank with S = 256 needs 22 MB).
inline constexpr uint64_t kMaxImageBytes = kMaxBodyBytes;

// ---- Little-endian writer -----------------------------------------------------------------

class Writer {
 public:
  void U8(uint8_t v) { bytes_.push_back(static_cast<char>(v)); }
  void U32(uint32_t v) {
    for (int i = 0; i < 4; ++i) U8(static_cast<uint8_t>(v >> (8 * i)));
  }
  void U64(uint64_t v) {
    for (int i = 0; i < 8; ++i) U8(static_cast<uint8_t>(v >> (8 * i)));
  }
  void I32(int32_t v) { U32(static_cast<uint32_t>(v)); }
  void F32(float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    U32(bits);
  }
  void F64(double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    U64(bits);
  }
  void Bytes(const void* data, size_t size) { bytes_.append(static_cast<const char*>(data), size); }
  /// Floats as four byte planes (all least significant bytes first, then the next, ...):
  /// sign/exponent and high-mantissa planes then compress well, unlike interleaved floats.
  void ShuffledF32(const float* values, size_t n) {
    std::vector<uint32_t> bits(n);
    if (n > 0) std::memcpy(bits.data(), values, n * 4);
    for (int plane = 0; plane < 4; ++plane)
      for (size_t i = 0; i < n; ++i) U8(static_cast<uint8_t>(bits[i] >> (8 * plane)));
  }
  void String(const std::string& s) {
    if (s.size() > kMaxStringBytes) {
      G6D_THROW("WriteTemplateCache: string of " << s.size() << " bytes exceeds the limit of "
                                                 << kMaxStringBytes);
    }
    U32(static_cast<uint32_t>(s.size()));
    Bytes(s.data(), s.size());
  }
  void Count(size_t n, uint32_t max, const char* what) {
    if (n > max) G6D_THROW("WriteTemplateCache: " << what << " count " << n << " exceeds " << max);
    U32(static_cast<uint32_t>(n));
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

// ---- Bounded little-endian reader ----------------------------------------------------------

class Reader {
 public:
  Reader(const uint8_t* data, size_t size, const std::string& name)
      : data_(data), size_(size), name_(name) {}

  size_t Remaining() const { return size_ - position_; }

  void Need(size_t n, const char* what) const {
    if (n > Remaining()) {
      G6D_THROW(name_ << ": truncated: body ends while reading " << what << " (need " << n
                      << " bytes, " << Remaining() << " left)");
    }
  }
  uint8_t U8(const char* what) {
    Need(1, what);
    return data_[position_++];
  }
  uint32_t U32(const char* what) {
    Need(4, what);
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(data_[position_ + i]) << (8 * i);
    position_ += 4;
    return v;
  }
  uint64_t U64(const char* what) {
    Need(8, what);
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(data_[position_ + i]) << (8 * i);
    position_ += 8;
    return v;
  }
  int32_t I32(const char* what) { return static_cast<int32_t>(U32(what)); }
  float F32(const char* what) {
    const uint32_t bits = U32(what);
    float v;
    std::memcpy(&v, &bits, 4);
    return v;
  }
  double F64(const char* what) {
    const uint64_t bits = U64(what);
    double v;
    std::memcpy(&v, &bits, 8);
    return v;
  }
  /// A finite double.
  double Finite(const char* what) {
    const double v = F64(what);
    if (!std::isfinite(v)) Fail(what, "is not finite");
    return v;
  }
  float FiniteF32(const char* what) {
    const float v = F32(what);
    if (!std::isfinite(v)) Fail(what, "is not finite");
    return v;
  }
  void Bytes(void* out, size_t n, const char* what) {
    Need(n, what);
    std::memcpy(out, data_ + position_, n);
    position_ += n;
  }
  /// Inverse of Writer::ShuffledF32; every value must be finite.
  void ShuffledFiniteF32(float* values, size_t n, const char* what) {
    Need(4 * n, what);
    std::vector<uint32_t> bits(n, 0);
    for (int plane = 0; plane < 4; ++plane)
      for (size_t i = 0; i < n; ++i)
        bits[i] |= static_cast<uint32_t>(data_[position_++]) << (8 * plane);
    if (n > 0) std::memcpy(values, bits.data(), n * 4);
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(values[i])) Fail(what, "is not finite");
    }
  }
  /// A count of items of `item_bytes` each, bounded by `max` and by the bytes left, so
  /// nothing is allocated for a count the file cannot back.
  uint32_t Count(uint32_t max, size_t item_bytes, const char* what) {
    const uint32_t n = U32(what);
    if (n > max) {
      G6D_THROW(name_ << ": corrupted: " << what << " count " << n << " exceeds the limit " << max);
    }
    if (static_cast<uint64_t>(n) * item_bytes > Remaining()) {
      G6D_THROW(name_ << ": truncated: " << what << " count " << n << " needs "
                      << static_cast<uint64_t>(n) * item_bytes << " bytes, only " << Remaining()
                      << " left");
    }
    return n;
  }
  std::string String(const char* what) {
    const uint32_t n = Count(kMaxStringBytes, 1, what);
    std::string s(n, '\0');
    Bytes(s.data(), n, what);
    return s;
  }
  [[noreturn]] void Fail(const char* what, const std::string& problem) const {
    G6D_THROW(name_ << ": corrupted: " << what << " " << problem);
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t position_ = 0;
  const std::string& name_;
};

inline uint32_t LoadU32(const uint8_t* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(p[i]) << (8 * i);
  return v;
}
inline uint64_t LoadU64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(p[i]) << (8 * i);
  return v;
}
inline void StoreU32(uint32_t v, uint8_t* p) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void StoreU64(uint64_t v, uint8_t* p) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

}  // namespace cache_format
}  // namespace g6d
