#include "mesh/mesh_header.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <nlohmann/json.hpp>

namespace g6d {
namespace {

// glTF 2.0 constants (the specification's numbers).
constexpr uint32_t kGlbMagic = 0x46546C67;      // "glTF"
constexpr uint32_t kGlbJsonChunk = 0x4E4F534A;  // "JSON"
constexpr int kModeTriangles = 4;
constexpr int kModeTriangleStrip = 5;
constexpr int kModeTriangleFan = 6;
// Binary STL: an 80-byte header, a uint32 triangle count, 50 bytes per triangle.
constexpr size_t kStlHeaderBytes = 84;
constexpr size_t kStlTriangleBytes = 50;

uint32_t LittleEndianU32(const std::string& bytes, size_t offset) {
  uint32_t value = 0;
  for (int i = 3; i >= 0; --i) {
    value = (value << 8) | static_cast<unsigned char>(bytes[offset + static_cast<size_t>(i)]);
  }
  return value;
}

void ReadGltf(const nlohmann::json& gltf, MeshFileHeader* header) {
  if (!gltf.is_object() || !gltf.contains("meshes") || !gltf.contains("accessors")) return;
  const nlohmann::json& accessors = gltf["accessors"];
  const auto accessor = [&](const nlohmann::json& index) -> const nlohmann::json* {
    if (!index.is_number_unsigned() || index.get<size_t>() >= accessors.size()) return nullptr;
    return &accessors[index.get<size_t>()];
  };
  bool all_bounds = true;
  bool all_counts = true;
  int64_t triangles = 0;
  Eigen::AlignedBox3d bounds;
  for (const nlohmann::json& mesh : gltf["meshes"]) {
    if (!mesh.contains("primitives")) continue;
    for (const nlohmann::json& primitive : mesh["primitives"]) {
      if (!primitive.contains("attributes") || !primitive["attributes"].contains("POSITION")) {
        continue;
      }
      const nlohmann::json* positions = accessor(primitive["attributes"]["POSITION"]);
      if (positions == nullptr) return;
      if (positions->contains("min") && positions->contains("max") &&
          (*positions)["min"].size() == 3 && (*positions)["max"].size() == 3) {
        for (const char* key : {"min", "max"}) {
          const nlohmann::json& corner = (*positions)[key];
          if (!corner[0].is_number() || !corner[1].is_number() || !corner[2].is_number()) return;
          bounds.extend(Eigen::Vector3d(corner[0].get<double>(), corner[1].get<double>(),
                                        corner[2].get<double>()));
        }
      } else {
        all_bounds = false;
      }
      const int mode = primitive.value("mode", kModeTriangles);
      const nlohmann::json* counted =
          primitive.contains("indices") ? accessor(primitive["indices"]) : positions;
      if (counted == nullptr || !counted->contains("count") ||
          !(*counted)["count"].is_number_unsigned()) {
        all_counts = false;
        continue;
      }
      const int64_t count = (*counted)["count"].get<int64_t>();
      if (mode == kModeTriangles) {
        triangles += count / 3;
      } else if (mode == kModeTriangleStrip || mode == kModeTriangleFan) {
        triangles += count >= 3 ? count - 2 : 0;
      }
    }
  }
  header->source = "glTF accessors";
  header->has_bounds = all_bounds && !bounds.isEmpty();
  header->bounds = bounds;
  header->has_triangle_count = all_counts;
  header->triangle_count = triangles;
}

}  // namespace

MeshFileHeader ReadMeshFileHeader(const std::string& path) {
  MeshFileHeader header;
  std::ifstream in(path, std::ios::binary);
  if (!in) return header;
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  if (bytes.size() >= 20 && LittleEndianU32(bytes, 0) == kGlbMagic) {
    const uint32_t json_length = LittleEndianU32(bytes, 12);
    if (LittleEndianU32(bytes, 16) != kGlbJsonChunk || json_length > bytes.size() - 20) {
      return header;
    }
    const nlohmann::json gltf = nlohmann::json::parse(bytes.begin() + 20,
                                                      bytes.begin() + 20 + json_length, nullptr,
                                                      /*allow_exceptions=*/false);
    if (!gltf.is_discarded()) ReadGltf(gltf, &header);
    return header;
  }
  const size_t first = bytes.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && bytes[first] == '{') {  // .gltf: JSON
    const nlohmann::json gltf = nlohmann::json::parse(bytes, nullptr, false);
    if (!gltf.is_discarded() && gltf.contains("asset")) ReadGltf(gltf, &header);
    return header;
  }
  // A binary STL is recognized by its size, as readers do: an ASCII STL starts with
  // "solid" too, but its size almost never matches its first bytes read as a count.
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".stl" && bytes.size() >= kStlHeaderBytes) {
    const uint64_t count = LittleEndianU32(bytes, 80);
    if (kStlHeaderBytes + count * kStlTriangleBytes == bytes.size()) {
      header.source = "binary STL header";
      header.has_triangle_count = true;
      header.triangle_count = static_cast<int64_t>(count);
    }
  }
  return header;
}

}  // namespace g6d
