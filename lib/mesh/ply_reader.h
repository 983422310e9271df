#pragma once
/// @file ply_reader.h
/// A reader for Stanford PLY meshes (ASCII, binary little- and big-endian): the vertex and
/// face properties a textured or vertex-coloured CAD mesh uses. LoadMesh() reads every PLY
/// file with it instead of assimp: Debian's assimp 5.2 skips one byte after `end_header`
/// when the first data byte is 0x0a (a newline) and then misreads the whole binary body.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace g6d {

/// Encoding of a PLY file's body.
enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

/// The contents of a PLY file in the file's own units, vertices in file order.
/// Optional per-vertex arrays are either empty or the same length as `positions`.
struct PlyMesh {
  PlyFormat format = PlyFormat::kAscii;
  int64_t header_vertices = 0;  ///< `element vertex N` of the header
  int64_t header_faces = 0;     ///< `element face N` of the header (0 without faces)

  std::vector<Eigen::Vector3d> positions;  ///< x, y, z (file units, may be non-finite)
  std::vector<Eigen::Vector3f> normals;    ///< nx, ny, nz as written (optional)
  /// red, green, blue in [0, 1] (optional): integer types divided by their maximum (255
  /// for uchar), float types as written; alpha is dropped.
  std::vector<Eigen::Vector3f> colors;
  /// Texture coordinates, v up (optional): vertex properties u/v, s/t, texture_u/texture_v
  /// or texture_s/texture_t, or a face list `texcoord` (per corner; a vertex used with
  /// different coordinates is then split, so `positions` can be longer than the header).
  std::vector<Eigen::Vector2f> uvs;

  /// Triangles (indices into `positions`): faces with more than 3 corners are split into
  /// a fan from their reflex corner if they have one, else from their first corner (exact
  /// for every quad and every convex polygon).
  std::vector<Eigen::Vector3i> triangles;
  int64_t num_polygons = 0;         ///< faces with 3 or more corners
  int64_t num_points_or_lines = 0;  ///< faces with 1 or 2 corners (dropped)
  /// The texture image named by a `comment TextureFile <name>` header line, as written
  /// ("" when none).
  std::string texture_file;
};

/// Reads a PLY file. Throws g6d::Error naming the file and the problem (with what to do)
/// when it cannot be opened, its header is malformed (no `ply` magic, unknown format or
/// type, no vertex x/y/z), its body ends early or holds bytes past the last element
/// (counts or types in the header that do not match the data), a number is unreadable,
/// or a face refers to a vertex that does not exist.
PlyMesh ReadPly(const std::string& path);

/// True when the file starts with the PLY magic line (`ply` and a line end).
bool IsPlyFile(const std::string& path);

}  // namespace g6d
