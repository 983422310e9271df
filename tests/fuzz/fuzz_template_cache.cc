// libFuzzer harness: template cache files (lib/templates/cache.h). The input goes to the
// whole-file parser and, as a decompressed body, to the body parser: a file has a header
// checksum, an FNV body checksum and a zstd checksum, which random mutation almost never
// gets past, so the body parser is fed directly too. Only g6d::Error is caught; any other
// exception, a crash, a sanitizer report or running out of memory is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "templates/cache.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    g6d::ParseTemplateCache(bytes, "fuzz cache");
  } catch (const g6d::Error&) {
  }
  try {
    g6d::ParseTemplateCacheBody(bytes, "fuzz body");
  } catch (const g6d::Error&) {
  }
  return 0;
}
