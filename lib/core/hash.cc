#include "core/hash.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/error.h"

namespace g6d {

uint64_t HashFile(const std::string& path) {
  // A directory opens as a stream on Linux and reads as empty: refuse it explicitly.
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    G6D_THROW("cannot hash '" << path << "': it is a directory");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) G6D_THROW("cannot open '" << path << "' for hashing");
  uint64_t hash = kFnvOffsetBasis;
  std::vector<char> buffer(1 << 16);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    hash = Fnv1a64(buffer.data(), static_cast<size_t>(in.gcount()), hash);
  }
  if (in.bad()) G6D_THROW("read error while hashing '" << path << "'");
  return hash;
}

std::string HexString(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(value));
  return text;
}

}  // namespace g6d
