#pragma once
/// @file mesh_header.h
/// What a mesh file says about its own content in its header (a binary STL's triangle
/// count, a glTF's accessor bounds and counts), so that a reader that succeeds but misread
/// the file (values shifted by a byte, a wrong stride) is caught instead of trusted.

#include <cstdint>
#include <string>

#include <Eigen/Geometry>

namespace g6d {

/// Counts and bounds a mesh file declares about itself. A field is meaningful only when
/// its `has_` flag is set: most formats (OBJ, ASCII STL) declare nothing.
struct MeshFileHeader {
  std::string source;  ///< where the values come from, for messages ("binary STL header")

  bool has_triangle_count = false;
  int64_t triangle_count = 0;  ///< triangles the file declares

  bool has_bounds = false;
  /// Union of the declared position bounds of every mesh, in file units and in each
  /// mesh's own frame (before node transforms).
  Eigen::AlignedBox3d bounds;
};

/// Reads the self-description of a binary STL (80-byte header, then the triangle count,
/// when the file size agrees with it) or a glTF 2.0 file (.gltf JSON or .glb: the POSITION
/// accessors' min/max and the triangle counts of triangle primitives). Returns a header
/// with nothing set for any other file, or one it cannot parse (the mesh reader then
/// reports the problem). Never throws for bad contents.
MeshFileHeader ReadMeshFileHeader(const std::string& path);

}  // namespace g6d
