#pragma once
/// @file mesh.h
/// Triangle meshes in metres, object frame. Loaded with assimp from PLY (vertex colours)
/// or OBJ/MTL (texture), with explicit source units.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace g6d {

/// Length unit of the numbers stored in a mesh file.
enum class Units { kMillimetres, kMetres };

/// Parses "mm" or "m"; throws g6d::Error naming the bad value otherwise.
Units ParseUnits(const std::string& text);
/// "mm" or "m".
const char* UnitsName(Units units);
/// Metres per file unit (0.001 for mm).
double MetresPerUnit(Units units);

/// An indexed triangle mesh. Vertices in metres in the object frame.
/// Optional per-vertex arrays are either empty or the same length as `vertices`.
struct Mesh {
  std::vector<Eigen::Vector3f> vertices;  ///< positions, metres
  std::vector<Eigen::Vector3i> faces;     ///< counter-clockwise vertex indices
  std::vector<Eigen::Vector3f> normals;   ///< unit vertex normals (optional)
  std::vector<Eigen::Vector3f> colors;    ///< vertex RGB in [0, 1] (optional)
  std::vector<Eigen::Vector2f> uvs;       ///< texture coordinates, v up as in OBJ (optional)
  cv::Mat texture;                        ///< CV_8UC3 RGB texture image (optional)

  bool HasColors() const { return !colors.empty(); }
  bool HasTexture() const { return !uvs.empty() && !texture.empty(); }
};

/// Loads a mesh, merging all assimp sub-meshes, scaling to metres.
/// Throws g6d::Error naming the file and the problem when it is missing, unreadable,
/// empty, or holds non-triangle faces (points, lines) only.
Mesh LoadMesh(const std::string& path, Units units);

/// Largest distance between any two vertices, metres (BOP's definition of the diameter).
double ComputeDiameter(const Mesh& mesh);

/// Axis-aligned bounding box of the vertices, metres.
Eigen::AlignedBox3d ComputeBoundingBox(const Mesh& mesh);

/// Total surface area, square metres.
double ComputeSurfaceArea(const Mesh& mesh);

/// `count` points uniformly distributed over the surface (area-weighted), deterministic
/// for a given seed. If `normals` is not null it receives the face normal of each point.
std::vector<Eigen::Vector3f> SampleSurface(const Mesh& mesh, int count, uint64_t seed,
                                           std::vector<Eigen::Vector3f>* normals = nullptr);

/// A geometry-only copy (vertices, faces) with at most about `target_faces` faces, for
/// online rasterization. Returns a copy unchanged when the mesh is already small enough.
Mesh Decimate(const Mesh& mesh, int target_faces);

/// Recomputes area-weighted unit vertex normals from the faces.
void ComputeVertexNormals(Mesh* mesh);

}  // namespace g6d
