#pragma once
/// @file cache.h
/// Template cache files: one self-contained file per object.
///
/// Layout: a fixed 64-byte header (magic "G6DCACHE", format version, header checksum,
/// uncompressed and compressed body sizes, FNV-1a 64 checksum of the compressed body),
/// then a zstd frame (with its own content checksum) holding the body: object id, mesh
/// hash, all build options, camera, diameter, box, symmetries, online mesh, templates.
/// Every count read from a file is bounded before anything is allocated; template masks
/// and thumbnails must be crop.size_px and thumbnail_size_px squares (or empty), and all of
/// them together at most 2 GiB, since a run-length mask of any size takes a few bytes.

#include <cstdint>
#include <string>

#include "templates/template_bank.h"

namespace g6d {

/// Current cache format version; files of any other version are refused.
/// 1: first format. 2: the mesh's geometric symmetries and coloured appearance samples.
/// 3: the point-pair-feature model (oriented surface points) and its build options.
inline constexpr uint32_t kCacheFormatVersion = 3;
/// What the current version added, for the message that refuses an older file.
inline constexpr const char* kCacheFormatChange =
    "version 3 stores the point-pair-feature model that finds texture-less objects";

/// Writes `bank` to `path` (atomically: temp file + rename). Throws g6d::Error on I/O errors
/// and on what the reader would refuse (a pose that is not rigid, a mask or thumbnail that
/// is not the options' crop.size_px / thumbnail_size_px square nor empty, a count over a limit).
void WriteTemplateCache(const TemplateBank& bank, const std::string& path, int zstd_level = 9);

/// Reads a cache. Throws g6d::Error saying which problem it found: missing file,
/// not a cache (bad magic), wrong version, truncated, checksum mismatch (corrupted),
/// or a field out of range. Never returns a partially filled bank. The bank's derived
/// meshes are filled (DeriveOnlineMeshes); the in-memory parsers below leave them empty.
TemplateBank ReadTemplateCache(const std::string& path);

/// Like ReadTemplateCache, and also refuses a stale cache: throws when the hash of the
/// mesh file at `mesh_path` differs from the one stored in the cache.
TemplateBank ReadTemplateCacheChecked(const std::string& path, const std::string& mesh_path);

/// Reads a cache from memory (for fuzzing and tests); same checks as ReadTemplateCache.
TemplateBank ParseTemplateCache(const std::string& bytes, const std::string& name);

/// Parses the decompressed body of a cache (what follows the header once unpacked), for
/// fuzzing and tests: the same bounds and field checks as ReadTemplateCache(), no
/// checksums. `name` starts every error message. Throws g6d::Error as ReadTemplateCache().
TemplateBank ParseTemplateCacheBody(const std::string& body, const std::string& name);

}  // namespace g6d
