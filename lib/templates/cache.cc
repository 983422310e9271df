#include "templates/cache.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <thread>
#include <vector>

#include <zstd.h>

#include "core/error.h"
#include "core/hash.h"
#include "templates/cache_body.h"
#include "templates/cache_format.h"

namespace g6d {
namespace {

using cache_format::DecodeBody;
using cache_format::EncodeBody;
using cache_format::kBodyChecksumOffset;
using cache_format::kBodySizeOffset;
using cache_format::kCompressedSizeOffset;
using cache_format::kHeaderChecksumOffset;
using cache_format::kHeaderSize;
using cache_format::kHeaderSizeOffset;
using cache_format::kMagic;
using cache_format::kMaxBodyBytes;
using cache_format::kVersionOffset;
using cache_format::LoadU32;
using cache_format::LoadU64;
using cache_format::StoreU32;
using cache_format::StoreU64;

struct ZstdCCtxDeleter {
  void operator()(ZSTD_CCtx* context) const { ZSTD_freeCCtx(context); }
};

std::string Compress(const std::string& body, int level) {
  std::unique_ptr<ZSTD_CCtx, ZstdCCtxDeleter> context(ZSTD_createCCtx());
  if (!context) G6D_THROW("WriteTemplateCache: cannot create a zstd context");
  auto check = [](size_t code, const char* what) {
    if (ZSTD_isError(code))
      G6D_THROW("WriteTemplateCache: zstd " << what << ": " << ZSTD_getErrorName(code));
  };
  check(ZSTD_CCtx_setParameter(context.get(), ZSTD_c_compressionLevel, level), "level");
  check(ZSTD_CCtx_setParameter(context.get(), ZSTD_c_checksumFlag, 1), "checksum flag");
  std::string compressed(ZSTD_compressBound(body.size()), '\0');
  const size_t size =
      ZSTD_compress2(context.get(), compressed.data(), compressed.size(), body.data(), body.size());
  check(size, "compress");
  compressed.resize(size);
  return compressed;
}

std::string EncodeFile(const TemplateBank& bank, int zstd_level) {
  const std::string body = EncodeBody(bank);
  if (body.size() > kMaxBodyBytes) {
    G6D_THROW("WriteTemplateCache: '" << bank.object_id << "' encodes to " << body.size()
                                      << " bytes, over the format's limit of " << kMaxBodyBytes
                                      << " bytes (256 MiB): use fewer templates or keypoints");
  }
  const std::string compressed = Compress(body, zstd_level);
  std::array<uint8_t, kHeaderSize> header{};
  std::memcpy(header.data(), kMagic, sizeof(kMagic));
  StoreU32(kCacheFormatVersion, header.data() + kVersionOffset);
  StoreU32(static_cast<uint32_t>(kHeaderSize), header.data() + kHeaderSizeOffset);
  StoreU64(body.size(), header.data() + kBodySizeOffset);
  StoreU64(compressed.size(), header.data() + kCompressedSizeOffset);
  StoreU64(Fnv1a64(compressed.data(), compressed.size()), header.data() + kBodyChecksumOffset);
  StoreU64(Fnv1a64(header.data(), kHeaderChecksumOffset), header.data() + kHeaderChecksumOffset);
  std::string file(reinterpret_cast<const char*>(header.data()), header.size());
  file += compressed;
  return file;
}

}  // namespace

void WriteTemplateCache(const TemplateBank& bank, const std::string& path, int zstd_level) {
  if (zstd_level < 1 || zstd_level > ZSTD_maxCLevel()) {
    G6D_THROW("WriteTemplateCache: zstd_level must be in 1.." << ZSTD_maxCLevel() << " (got "
                                                              << zstd_level << ")");
  }
  const std::string file = EncodeFile(bank, zstd_level);
  // Write next to the target, fsync, then rename: readers never see a half-written cache,
  // not even after a crash. The name is unique per process and thread.
  const std::string temp_path =
      path + ".tmp." + std::to_string(::getpid()) + "." +
      std::to_string(std::hash<std::thread::id>()(std::this_thread::get_id()) % 1000000);
  const int fd = ::open(temp_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) G6D_THROW("cannot create '" << temp_path << "': " << std::strerror(errno));
  size_t written = 0;
  while (written < file.size()) {
    const ssize_t n = ::write(fd, file.data() + written, file.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    written += static_cast<size_t>(n);
  }
  const int write_error = written == file.size() ? 0 : errno;
  const bool synced = write_error == 0 && ::fsync(fd) == 0;
  const int sync_error = errno;
  const bool closed = ::close(fd) == 0;
  if (write_error != 0 || !synced || !closed) {
    std::remove(temp_path.c_str());
    G6D_THROW("cannot write '" << temp_path << "': "
                               << std::strerror(write_error != 0 ? write_error : sync_error));
  }
  if (std::rename(temp_path.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(temp_path.c_str());
    G6D_THROW("cannot rename '" << temp_path << "' to '" << path << "': " << std::strerror(error));
  }
}

namespace {

struct HeaderInfo {
  uint64_t body_size = 0;
  uint64_t compressed_size = 0;
  uint64_t body_checksum = 0;
};

// Validates the first min(file_size, 64) bytes of a file of `file_size` bytes.
HeaderInfo CheckHeader(const uint8_t* data, size_t available, uint64_t file_size,
                       const std::string& name) {
  const size_t magic_bytes = std::min(available, sizeof(kMagic));
  if (std::memcmp(data, kMagic, magic_bytes) != 0) {
    G6D_THROW(name << ": not a g6d cache (bad magic)");
  }
  if (file_size < kHeaderSize) {
    G6D_THROW(name << ": truncated: " << file_size << " bytes, shorter than the " << kHeaderSize
                   << "-byte header");
  }
  const uint32_t version = LoadU32(data + kVersionOffset);
  if (version != kCacheFormatVersion) {
    G6D_THROW(name << ": unsupported cache format version " << version << " (expected "
                   << kCacheFormatVersion << "; " << kCacheFormatChange
                   << "); rebuild it with g6d-build-templates");
  }
  if (Fnv1a64(data, kHeaderChecksumOffset) != LoadU64(data + kHeaderChecksumOffset)) {
    G6D_THROW(name << ": corrupted: checksum mismatch (header)");
  }
  if (LoadU32(data + kHeaderSizeOffset) != kHeaderSize) {
    G6D_THROW(name << ": corrupted: header size " << LoadU32(data + kHeaderSizeOffset)
                   << " (expected " << kHeaderSize << ")");
  }
  HeaderInfo info;
  info.body_size = LoadU64(data + kBodySizeOffset);
  info.compressed_size = LoadU64(data + kCompressedSizeOffset);
  info.body_checksum = LoadU64(data + kBodyChecksumOffset);
  const uint64_t available_body = file_size - kHeaderSize;
  if (info.compressed_size > available_body) {
    G6D_THROW(name << ": truncated: header declares " << info.compressed_size
                   << " compressed body bytes, file has " << available_body);
  }
  if (info.compressed_size < available_body) {
    G6D_THROW(name << ": corrupted: " << (available_body - info.compressed_size)
                   << " unexpected bytes after the body");
  }
  if (info.body_size > kMaxBodyBytes) {
    G6D_THROW(name << ": corrupted: body size " << info.body_size << " exceeds the limit of "
                   << kMaxBodyBytes << " bytes (256 MiB)");
  }
  return info;
}

TemplateBank DecodeCompressedBody(const HeaderInfo& info, const uint8_t* compressed,
                                  const std::string& name) {
  if (Fnv1a64(compressed, info.compressed_size) != info.body_checksum) {
    G6D_THROW(name << ": corrupted: checksum mismatch");
  }
  const unsigned long long frame_size = ZSTD_getFrameContentSize(compressed, info.compressed_size);
  if (frame_size != info.body_size) {
    G6D_THROW(name << ": corrupted: zstd frame content size does not match the header's "
                   << info.body_size << " bytes");
  }
  std::vector<uint8_t> body(info.body_size);
  const size_t got = ZSTD_decompress(body.data(), body.size(), compressed, info.compressed_size);
  if (ZSTD_isError(got)) {
    G6D_THROW(name << ": corrupted: zstd: " << ZSTD_getErrorName(got));
  }
  if (got != info.body_size) {
    G6D_THROW(name << ": corrupted: body decompressed to " << got << " bytes, expected "
                   << info.body_size);
  }
  return DecodeBody(body.data(), body.size(), name);
}

}  // namespace

TemplateBank ParseTemplateCache(const std::string& bytes, const std::string& name) {
  const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
  const HeaderInfo info =
      CheckHeader(data, std::min(bytes.size(), kHeaderSize), bytes.size(), name);
  return DecodeCompressedBody(info, data + kHeaderSize, name);
}

TemplateBank ParseTemplateCacheBody(const std::string& body, const std::string& name) {
  return DecodeBody(reinterpret_cast<const uint8_t*>(body.data()), body.size(), name);
}

TemplateBank ReadTemplateCache(const std::string& path) {
  const std::string name = "template cache '" + path + "'";
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) G6D_THROW("cannot open " << name << ": " << std::strerror(errno));
  const std::streamoff end = in.tellg();
  if (end < 0) G6D_THROW("cannot read " << name);
  const uint64_t file_size = static_cast<uint64_t>(end);
  in.seekg(0);
  // Header first, so a huge or foreign file is refused before its bulk is read.
  std::array<uint8_t, kHeaderSize> header{};
  const size_t header_bytes = static_cast<size_t>(std::min<uint64_t>(file_size, kHeaderSize));
  in.read(reinterpret_cast<char*>(header.data()), static_cast<std::streamsize>(header_bytes));
  if (!in) G6D_THROW("cannot read " << name);
  const HeaderInfo info = CheckHeader(header.data(), header_bytes, file_size, name);
  std::vector<uint8_t> compressed(info.compressed_size);
  in.read(reinterpret_cast<char*>(compressed.data()),
          static_cast<std::streamsize>(compressed.size()));
  if (!in) G6D_THROW(name << ": truncated: the body could not be read completely");
  TemplateBank bank = DecodeCompressedBody(info, compressed.data(), name);
  DeriveOnlineMeshes(&bank);
  DerivePpfTable(&bank.ppf);
  return bank;
}

TemplateBank ReadTemplateCacheChecked(const std::string& path, const std::string& mesh_path) {
  TemplateBank bank = ReadTemplateCache(path);
  const uint64_t mesh_hash = HashFile(mesh_path);
  if (mesh_hash != bank.mesh_hash) {
    G6D_THROW("template cache '" << path << "': stale: mesh hash " << HexString(mesh_hash)
                                 << " of '" << mesh_path << "' differs from "
                                 << HexString(bank.mesh_hash)
                                 << " stored in the cache; rebuild it with g6d-build-templates");
  }
  return bank;
}

}  // namespace g6d
