#pragma once
/// @file mesh.h
/// Triangle meshes in metres, object frame. Loaded from PLY (vertex colours, texture) with
/// our own reader (ply_reader.h), or with assimp from OBJ/MTL (texture), STL, glTF and
/// the other formats assimp reads, with explicit source units.

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
  cv::Mat texture;  ///< CV_8UC3 RGB texture image, row 0 at the top (v = 1) (optional)

  /// True when every vertex has an RGB colour.
  bool HasColors() const { return !colors.empty(); }
  /// True when every vertex has texture coordinates into `texture`.
  bool HasTexture() const { return !uvs.empty() && !texture.empty(); }
};

/// True when the surface is closed and consistently oriented: with vertices welded by
/// position, every directed edge (a, b) of a face appears exactly once and its reverse
/// (b, a) exactly once. For such a mesh seen from outside, back-face culling cannot
/// change a rendering (the nearest surface along any ray is front-facing).
bool IsClosedAndOriented(const Mesh& mesh);

/// Loads a mesh, merging all assimp sub-meshes (with their node transforms), scaling to
/// metres. Polygons are triangulated; points and lines are dropped. A PLY file (recognized
/// by its `ply` magic line) is read by ReadPly() with its vertices in file order: vertex
/// colours kept (alpha dropped), a `comment TextureFile` image read with the vertex (or
/// face-corner) texture coordinates. An OBJ/MTL diffuse texture is read (path relative to
/// the OBJ's folder) with its UVs. When parts use different textures, or some parts are untextured,
/// one atlas texture is built (textures stacked vertically, a solid patch of the material
/// colour per untextured part) and the UVs are remapped into it. Normals come from the file
/// when every part has them, else they are computed (area-weighted).
/// Throws g6d::Error naming the file, the problem and what to do when it is missing, empty,
/// not parseable (for PLY: a body that does not match its header), holds no meshes, holds
/// non-triangle faces (points, lines) only, has non-finite vertices or out-of-range indices,
/// has no area (every triangle degenerate), references a texture that cannot be read, or
/// when what assimp read disagrees with what the file declares about itself (a binary STL's
/// triangle count, a glTF's position bounds and triangle counts: ReadMeshFileHeader()).
Mesh LoadMesh(const std::string& path, Units units);

/// Largest distance between any two vertices, metres (BOP's definition of the diameter).
/// Exact: compares the convex hull vertices; 0 for fewer than two vertices.
double ComputeDiameter(const Mesh& mesh);

/// Axis-aligned bounding box of the vertices, metres (empty box for no vertices).
Eigen::AlignedBox3d ComputeBoundingBox(const Mesh& mesh);

/// Total surface area, square metres. Throws g6d::Error on out-of-range face indices.
double ComputeSurfaceArea(const Mesh& mesh);

/// One area-weighted surface sample: its face and barycentric weights (w0 + w1 + w2 = 1),
/// so callers can interpolate any per-vertex attribute (colour, UV, normal) at it.
struct SurfaceSample {
  int face = 0;                                         ///< index into Mesh::faces
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();    ///< barycentric weights of its vertices
};

/// `count` faces and barycentric weights, uniform over the surface (area-weighted, Osada et
/// al. 2002 sec. 4.2), deterministic for a given seed on every platform: the sampler behind
/// SampleSurface(). Throws g6d::Error as SampleSurface() does.
std::vector<SurfaceSample> SampleSurfaceFaces(const Mesh& mesh, int count, uint64_t seed);

/// `count` points uniformly distributed over the surface (area-weighted), deterministic
/// for a given seed on every platform. If `normals` is not null it receives the unit face
/// normal of each point. Throws g6d::Error when count < 0 or (for count > 0) the mesh has
/// no face with positive area.
std::vector<Eigen::Vector3f> SampleSurface(const Mesh& mesh, int count, uint64_t seed,
                                           std::vector<Eigen::Vector3f>* normals = nullptr);

/// A geometry-only copy (vertices, faces, vertex normals) with about `target_faces` faces
/// (not more, unless no further edge can collapse), for online rasterization: quadric error
/// decimation after merging vertices that share a position (texture seams). When the mesh
/// already has at most `target_faces` faces its vertices and faces are copied unchanged.
/// Throws g6d::Error if target_faces < 1.
Mesh Decimate(const Mesh& mesh, int target_faces);

/// Recomputes area-weighted unit vertex normals from the faces (+z for vertices on no
/// face with positive area). Throws g6d::Error on out-of-range face indices.
void ComputeVertexNormals(Mesh* mesh);

}  // namespace g6d
