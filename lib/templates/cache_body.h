#pragma once
/// @file cache_body.h
/// The body of a template cache file (internal to lib/templates; cache.h describes the
/// format): a TemplateBank's fields in their stored order (object id, mesh hash, build
/// options, camera, diameter, box, symmetries, appearance, point-pair-feature model, online
/// mesh, templates), uncompressed.

#include <cstddef>
#include <cstdint>
#include <string>

#include "templates/template_bank.h"

namespace g6d {
namespace cache_format {

/// The body of `bank`'s cache file. Throws g6d::Error for a bank the format cannot hold
/// (a string, count or pose out of its bounds).
std::string EncodeBody(const TemplateBank& bank);

/// The bank stored in `size` bytes of body at `data`; `name` (the file) starts every error
/// message. Throws g6d::Error for a corrupted or truncated body. The derived tables
/// (DeriveOnlineMeshes, DerivePpfTable) are the caller's to fill.
TemplateBank DecodeBody(const uint8_t* data, size_t size, const std::string& name);

}  // namespace cache_format
}  // namespace g6d
