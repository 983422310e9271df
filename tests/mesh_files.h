#pragma once
/// @file mesh_files.h
/// A mesh-file corpus the tests write themselves: one coloured, textured box (CorpusBox)
/// written as PLY (ASCII, binary little/big endian, quads, uchar/int list counts, colours
/// as uchar or float, texture coordinates), OBJ (with and without MTL and texture), STL
/// (binary and ASCII) and binary glTF. Every file holds the same geometry, so a loader
/// must give the same triangles from each.

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace g6d::test {

/// A box in millimetres with a vertex per side corner (24 vertices, 6 quads, 12
/// triangles), quads counter-clockwise seen from outside, each side a cell of a 3 x 2 UV
/// grid, vertex colours random (seeded). Triangles of quad q are (q0, q1, q2), (q0, q2, q3).
struct CorpusBox {
  std::vector<Eigen::Vector3f> positions;  ///< millimetres
  std::vector<Eigen::Vector3i> colors;     ///< 0..255 per channel
  std::vector<Eigen::Vector2f> uvs;        ///< v up
  std::vector<Eigen::Vector4i> quads;

  std::vector<Eigen::Vector3i> Triangles() const {
    std::vector<Eigen::Vector3i> triangles;
    for (const Eigen::Vector4i& q : quads) {
      triangles.emplace_back(q[0], q[1], q[2]);
      triangles.emplace_back(q[0], q[2], q[3]);
    }
    return triangles;
  }
  /// Colour of vertex v in [0, 1].
  Eigen::Vector3f Color01(int v) const { return colors[v].cast<float>() / 255.0f; }
};

/// The corpus box: half sizes (40, 30, 20) mm about (5, -7, 12) mm. With
/// `newline_first`, the box's minimum x (vertex 0's x) gets 0x0a as its float's low byte:
/// a binary little-endian PLY of it then starts its data with a newline byte, which
/// Debian's assimp 5.2 skips (misreading every value after it).
inline CorpusBox MakeCorpusBox(bool newline_first = false, uint64_t seed = 34) {
  const Eigen::Vector3f half(40.0f, 30.0f, 20.0f), centre(5.0f, -7.0f, 12.0f);
  Eigen::Vector3f low = centre - half, high = centre + half;
  if (newline_first) {
    uint32_t bits = 0;
    std::memcpy(&bits, &low.x(), 4);
    bits = (bits & ~0xffu) | 0x0au;
    std::memcpy(&low.x(), &bits, 4);
  }
  CorpusBox box;
  std::mt19937_64 engine(seed);
  // Each side: the axis it faces, its sign; corners in counter-clockwise order seen from
  // outside. Side 0 is x = low.x, so that vertex 0 lies on it.
  for (int side = 0; side < 6; ++side) {
    const int axis = side / 2;
    const int sign = side % 2 == 0 ? -1 : 1;
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;  // (a, b, axis) right-handed
    const float corner_a[4] = {0, 1, 1, 0}, corner_b[4] = {0, 0, 1, 1};
    const int first = static_cast<int>(box.positions.size());
    for (int k = 0; k < 4; ++k) {
      // Counter-clockwise seen from +axis is a -> b; from -axis reverse it.
      const int corner = sign > 0 ? k : (4 - k) % 4;
      Eigen::Vector3f point;
      point[axis] = sign > 0 ? high[axis] : low[axis];
      point[a] = corner_a[corner] > 0 ? high[a] : low[a];
      point[b] = corner_b[corner] > 0 ? high[b] : low[b];
      box.positions.push_back(point);
      box.colors.emplace_back(static_cast<int>(engine() % 256), static_cast<int>(engine() % 256),
                              static_cast<int>(engine() % 256));
      box.uvs.emplace_back((side % 3 + 0.1f + 0.8f * corner_a[corner]) / 3.0f,
                           (side / 3 + 0.1f + 0.8f * corner_b[corner]) / 2.0f);
    }
    box.quads.emplace_back(first, first + 1, first + 2, first + 3);
  }
  return box;
}

/// A 3 x 2 cell texture image (BGR, as cv::imwrite takes it) for the box's UV grid.
inline cv::Mat CorpusTexture() {
  cv::Mat image(64, 96, CV_8UC3);
  for (int row = 0; row < image.rows; ++row) {
    for (int column = 0; column < image.cols; ++column) {
      image.at<cv::Vec3b>(row, column) =
          cv::Vec3b(static_cast<uchar>(column * 2), static_cast<uchar>(row * 3),
                    static_cast<uchar>(((row / 32) * 3 + column / 32) * 40));
    }
  }
  return image;
}

/// How to write the corpus box as PLY.
struct PlyWriteOptions {
  enum class Encoding { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
  enum class Colors { kNone, kUchar, kFloat };
  Encoding encoding = Encoding::kAscii;
  bool quads = false;                   ///< faces as quads, else triangles
  std::string count_type = "uchar";     ///< type of the face lists' lengths: uchar or int
  Colors colors = Colors::kNone;        ///< vertex colours (with an alpha of 255 / 1)
  bool normals = false;                 ///< per-vertex nx, ny, nz (the side's normal)
  std::string texture_file;             ///< "" or the TextureFile comment (then texture_u/v)
};

namespace internal {

template <typename T>
void AppendValue(T value, bool big_endian, std::string* out) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  uint16_t probe = 1;
  const bool host_little = *reinterpret_cast<unsigned char*>(&probe) == 1;
  if (big_endian == host_little) std::reverse(bytes, bytes + sizeof(T));
  out->append(bytes, sizeof(T));
}

inline std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", value);
  return text;
}

inline void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// Outward unit normal of the box side that vertex v belongs to.
inline Eigen::Vector3f SideNormal(const CorpusBox& box, int v) {
  const Eigen::Vector4i& q = box.quads[static_cast<size_t>(v / 4)];
  return (box.positions[q[1]] - box.positions[q[0]])
      .cross(box.positions[q[2]] - box.positions[q[0]])
      .normalized();
}

}  // namespace internal

/// Writes the box as PLY.
inline void WriteCorpusPly(const std::string& path, const CorpusBox& box,
                           const PlyWriteOptions& options) {
  using Encoding = PlyWriteOptions::Encoding;
  using Colors = PlyWriteOptions::Colors;
  const bool ascii = options.encoding == Encoding::kAscii;
  const bool big = options.encoding == Encoding::kBinaryBigEndian;
  std::vector<std::vector<int>> faces;
  if (options.quads) {
    for (const Eigen::Vector4i& q : box.quads) faces.push_back({q[0], q[1], q[2], q[3]});
  } else {
    for (const Eigen::Vector3i& t : box.Triangles()) faces.push_back({t[0], t[1], t[2]});
  }
  std::string out = "ply\nformat ";
  out += ascii ? "ascii" : big ? "binary_big_endian" : "binary_little_endian";
  out += " 1.0\ncomment written by the g6d tests\n";
  if (!options.texture_file.empty()) out += "comment TextureFile " + options.texture_file + "\n";
  out += "element vertex " + std::to_string(box.positions.size()) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  if (options.normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  const char* color_type = options.colors == Colors::kFloat ? "float" : "uchar";
  if (options.colors != Colors::kNone) {
    for (const char* channel : {"red", "green", "blue", "alpha"}) {
      out += std::string("property ") + color_type + " " + channel + "\n";
    }
  }
  if (!options.texture_file.empty()) out += "property float texture_u\nproperty float texture_v\n";
  out += "element face " + std::to_string(faces.size()) + "\n";
  out += "property list " + options.count_type + " int vertex_indices\nend_header\n";

  for (size_t v = 0; v < box.positions.size(); ++v) {
    std::vector<float> floats(box.positions[v].data(), box.positions[v].data() + 3);
    if (options.normals) {
      const Eigen::Vector3f normal = internal::SideNormal(box, static_cast<int>(v));
      floats.insert(floats.end(), normal.data(), normal.data() + 3);
    }
    for (size_t i = 0; i < floats.size(); ++i) {
      if (ascii) {
        out += internal::Number(floats[i]) + (i + 1 < floats.size() ? " " : "");
      } else {
        internal::AppendValue(floats[i], big, &out);
      }
    }
    if (options.colors != Colors::kNone) {
      for (int c = 0; c < 4; ++c) {
        const int value = c < 3 ? box.colors[v][c] : 255;
        if (options.colors == Colors::kFloat) {
          const float channel = static_cast<float>(value) / 255.0f;
          if (ascii) {
            out += " " + internal::Number(channel);
          } else {
            internal::AppendValue(channel, big, &out);
          }
        } else if (ascii) {
          out += " " + std::to_string(value);
        } else {
          internal::AppendValue(static_cast<uint8_t>(value), big, &out);
        }
      }
    }
    if (!options.texture_file.empty()) {
      for (int c = 0; c < 2; ++c) {
        if (ascii) {
          out += " " + internal::Number(box.uvs[v][c]);
        } else {
          internal::AppendValue(box.uvs[v][c], big, &out);
        }
      }
    }
    if (ascii) out += "\n";
  }
  for (const std::vector<int>& face : faces) {
    if (ascii) {
      out += std::to_string(face.size());
      for (int index : face) out += " " + std::to_string(index);
      out += "\n";
      continue;
    }
    if (options.count_type == "int") {
      internal::AppendValue(static_cast<int32_t>(face.size()), big, &out);
    } else {
      internal::AppendValue(static_cast<uint8_t>(face.size()), big, &out);
    }
    for (int index : face) internal::AppendValue(static_cast<int32_t>(index), big, &out);
  }
  internal::WriteBytes(path, out);
}

/// How to write the corpus box as OBJ.
struct ObjWriteOptions {
  std::string mtl_file;      ///< "" for no `mtllib`, else its name beside the OBJ (a Kd colour)
  std::string texture_file;  ///< with an MTL: "" or its `map_Kd` image (then `vt` per vertex)
  bool quads = false;        ///< faces as quads, else triangles
};

/// Writes the box as OBJ (and its MTL, when asked; the texture image is the caller's).
inline void WriteCorpusObj(const std::string& path, const CorpusBox& box,
                           const ObjWriteOptions& options) {
  std::string out = "# written by the g6d tests\n";
  const bool textured = !options.mtl_file.empty() && !options.texture_file.empty();
  if (!options.mtl_file.empty()) {
    out += "mtllib " + options.mtl_file + "\n";
    std::string mtl = "newmtl skin\nKd 0.8 0.6 0.4\n";
    if (textured) mtl += "map_Kd " + options.texture_file + "\n";
    const std::string folder = path.substr(0, path.find_last_of('/') + 1);
    internal::WriteBytes(folder + options.mtl_file, mtl);
  }
  for (const Eigen::Vector3f& p : box.positions) {
    out += "v " + internal::Number(p.x()) + " " + internal::Number(p.y()) + " " +
           internal::Number(p.z()) + "\n";
  }
  if (textured) {
    for (const Eigen::Vector2f& uv : box.uvs) {
      out += "vt " + internal::Number(uv.x()) + " " + internal::Number(uv.y()) + "\n";
    }
  }
  if (!options.mtl_file.empty()) out += "usemtl skin\n";
  const auto corner = [&](int index) {
    const std::string i = std::to_string(index + 1);
    return textured ? i + "/" + i : i;
  };
  if (options.quads) {
    for (const Eigen::Vector4i& q : box.quads) {
      out += "f " + corner(q[0]) + " " + corner(q[1]) + " " + corner(q[2]) + " " + corner(q[3]) +
             "\n";
    }
  } else {
    for (const Eigen::Vector3i& t : box.Triangles()) {
      out += "f " + corner(t[0]) + " " + corner(t[1]) + " " + corner(t[2]) + "\n";
    }
  }
  internal::WriteBytes(path, out);
}

/// Writes the box's triangles as STL (binary or ASCII), face normals included.
inline void WriteCorpusStl(const std::string& path, const CorpusBox& box, bool binary) {
  const std::vector<Eigen::Vector3i> triangles = box.Triangles();
  std::string out;
  if (binary) {
    out.assign(80, ' ');
    out.replace(0, 22, "g6d test binary STL   ");  // must not start with "solid"
    internal::AppendValue(static_cast<uint32_t>(triangles.size()), false, &out);
  } else {
    out = "solid corpus\n";
  }
  for (const Eigen::Vector3i& t : triangles) {
    const Eigen::Vector3f normal = internal::SideNormal(box, t[0]);
    if (binary) {
      for (int c = 0; c < 3; ++c) internal::AppendValue(normal[c], false, &out);
      for (int k = 0; k < 3; ++k) {
        for (int c = 0; c < 3; ++c) internal::AppendValue(box.positions[t[k]][c], false, &out);
      }
      internal::AppendValue(static_cast<uint16_t>(0), false, &out);
      continue;
    }
    out += "facet normal " + internal::Number(normal.x()) + " " + internal::Number(normal.y()) +
           " " + internal::Number(normal.z()) + "\n outer loop\n";
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& p = box.positions[t[k]];
      out += "  vertex " + internal::Number(p.x()) + " " + internal::Number(p.y()) + " " +
             internal::Number(p.z()) + "\n";
    }
    out += " endloop\nendfacet\n";
  }
  if (!binary) out += "endsolid corpus\n";
  internal::WriteBytes(path, out);
}

/// Writes the box as binary glTF 2.0 (.glb): positions, uint32 indices, one node. The
/// POSITION accessor declares the box's bounds, or `declared_max_scale` times its maximum
/// corner (a file whose header disagrees with its data) when that is not 1.
inline void WriteCorpusGlb(const std::string& path, const CorpusBox& box,
                           float declared_max_scale = 1.0f) {
  const std::vector<Eigen::Vector3i> triangles = box.Triangles();
  std::string binary;
  Eigen::Vector3f low = box.positions[0], high = box.positions[0];
  for (const Eigen::Vector3f& p : box.positions) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
    for (int c = 0; c < 3; ++c) internal::AppendValue(p[c], false, &binary);
  }
  const size_t positions_bytes = binary.size();
  for (const Eigen::Vector3i& t : triangles) {
    for (int k = 0; k < 3; ++k) internal::AppendValue(static_cast<uint32_t>(t[k]), false, &binary);
  }
  high *= declared_max_scale;
  const auto vector = [](const Eigen::Vector3f& v) {
    return "[" + internal::Number(v.x()) + "," + internal::Number(v.y()) + "," +
           internal::Number(v.z()) + "]";
  };
  std::string json =
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":4}]}],)"
      R"("buffers":[{"byteLength":)" +
      std::to_string(binary.size()) +
      R"(}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":)" +
      std::to_string(positions_bytes) +
      R"(,"target":34962},{"buffer":0,"byteOffset":)" + std::to_string(positions_bytes) +
      R"(,"byteLength":)" + std::to_string(binary.size() - positions_bytes) +
      R"(,"target":34963}],"accessors":[{"bufferView":0,"componentType":5126,"count":)" +
      std::to_string(box.positions.size()) + R"(,"type":"VEC3","min":)" + vector(low) +
      R"(,"max":)" + vector(high) +
      R"(},{"bufferView":1,"componentType":5125,"count":)" +
      std::to_string(3 * triangles.size()) + R"(,"type":"SCALAR"}]})";
  while (json.size() % 4 != 0) json += ' ';
  while (binary.size() % 4 != 0) binary += '\0';
  std::string out = "glTF";
  internal::AppendValue(static_cast<uint32_t>(2), false, &out);
  internal::AppendValue(static_cast<uint32_t>(12 + 8 + json.size() + 8 + binary.size()), false,
                        &out);
  internal::AppendValue(static_cast<uint32_t>(json.size()), false, &out);
  out += "JSON";
  out += json;
  internal::AppendValue(static_cast<uint32_t>(binary.size()), false, &out);
  out.append("BIN\0", 4);
  out += binary;
  internal::WriteBytes(path, out);
}

}  // namespace g6d::test
