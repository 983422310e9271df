#include "mesh/mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <sstream>
#include <tuple>
#include <utility>

#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
// Only geometry headers of Open3D (never Open3D.h): see DESIGN.md, Dependencies.
#include <open3d/geometry/Qhull.h>
#include <open3d/geometry/TriangleMesh.h>

#include "core/error.h"
#include "mesh/mesh_header.h"
#include "mesh/ply_reader.h"

namespace g6d {

Units ParseUnits(const std::string& text) {
  if (text == "mm") return Units::kMillimetres;
  if (text == "m") return Units::kMetres;
  G6D_THROW("units must be \"mm\" or \"m\" (got \"" << text << "\")");
}

const char* UnitsName(Units units) {
  switch (units) {
    case Units::kMillimetres:
      return "mm";
    case Units::kMetres:
      return "m";
  }
  return "?";
}

double MetresPerUnit(Units units) {
  switch (units) {
    case Units::kMillimetres:
      return 0.001;
    case Units::kMetres:
      return 1.0;
  }
  G6D_THROW("MetresPerUnit: unknown units value " << static_cast<int>(units));
}

namespace {

// Albedo given to parts without any colour information when other parts have some, so
// that every vertex gets a colour. Matches the renderer's default grey.
constexpr float kDefaultAlbedo = 0.7f;
// Side of the solid-colour patch that stands for an untextured part in a texture atlas.
constexpr int kSolidPatchSidePx = 8;
// Rows replicated above and below each atlas entry, so that bilinear lookups at an entry's
// top or bottom edge do not blend in the neighbouring entry.
constexpr int kAtlasPaddingPx = 2;
// Below this vertex count the diameter is computed by brute force over all pairs
// (cheaper than building a convex hull).
constexpr size_t kDiameterBruteForceMaxVertices = 2000;

// Throws when a face refers to a vertex that does not exist; `context` names the caller.
void CheckFaceIndices(const Mesh& mesh, const char* context) {
  const int num_vertices = static_cast<int>(mesh.vertices.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int index = mesh.faces[f][k];
      if (index < 0 || index >= num_vertices) {
        G6D_THROW(context << ": face " << f << " refers to vertex " << index << " but the mesh has "
                          << num_vertices << " vertices");
      }
    }
  }
}

// Twice the area vector of a face (cross product of two edges), in double precision.
Eigen::Vector3d FaceCross(const Mesh& mesh, const Eigen::Vector3i& face) {
  const Eigen::Vector3d a = mesh.vertices[face[0]].cast<double>();
  const Eigen::Vector3d b = mesh.vertices[face[1]].cast<double>();
  const Eigen::Vector3d c = mesh.vertices[face[2]].cast<double>();
  return (b - a).cross(c - a);
}

// Uniform double in [0, 1) from the top 53 bits of one engine draw. Written out (instead of
// std::uniform_real_distribution, whose algorithm is implementation-defined) so that a seed
// gives the same samples with any standard library.
double UniformUnit(std::mt19937_64* engine) {
  return static_cast<double>((*engine)() >> 11) * 0x1.0p-53;
}

// ---------------------------------------------------------------------------------------
// Loading.

// How one assimp sub-mesh is coloured.
struct PartAppearance {
  int texture_index = -1;  // into the list of distinct texture images, -1 when untextured
  bool has_vertex_colors = false;
  Eigen::Vector3f material_color = Eigen::Vector3f::Constant(kDefaultAlbedo);
  bool has_material_color = false;
};

// A triangle sub-mesh of the scene with the transform of the node that places it.
struct ScenePart {
  const aiMesh* mesh = nullptr;
  aiMatrix4x4 transform;
  PartAppearance appearance;
};

void CollectParts(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent_transform,
                  std::vector<ScenePart>* parts) {
  const aiMatrix4x4 transform = parent_transform * node.mTransformation;
  for (unsigned i = 0; i < node.mNumMeshes; ++i) {
    const unsigned mesh_index = node.mMeshes[i];
    if (mesh_index >= scene.mNumMeshes) continue;  // ValidateDataStructure rejects this
    ScenePart part;
    part.mesh = scene.mMeshes[mesh_index];
    part.transform = transform;
    parts->push_back(part);
  }
  for (unsigned i = 0; i < node.mNumChildren; ++i) {
    CollectParts(scene, *node.mChildren[i], transform, parts);
  }
}

// Converts an 8-bit image with 1, 3 (BGR) or 4 (BGRA) channels to RGB CV_8UC3.
cv::Mat ToRgb(const cv::Mat& image) {
  cv::Mat rgb;
  switch (image.channels()) {
    case 1:
      cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 4:
      cv::cvtColor(image, rgb, cv::COLOR_BGRA2RGB);
      break;
    default:
      cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
      break;
  }
  return rgb;
}

cv::Mat LoadTextureFile(const std::string& texture_path, const std::string& model_path);

// Reads the diffuse texture `texture_path` of a material of `model_path` as RGB: embedded
// in the scene (glTF, FBX) or an image file relative to the model's folder.
cv::Mat LoadTextureImage(const aiScene& scene, const std::string& texture_path,
                         const std::string& model_path) {
  if (const aiTexture* embedded = scene.GetEmbeddedTexture(texture_path.c_str())) {
    cv::Mat image;
    if (embedded->mHeight == 0) {  // compressed bytes (png, jpg) of mWidth bytes
      const cv::Mat bytes(1, static_cast<int>(embedded->mWidth), CV_8UC1,
                          const_cast<aiTexel*>(embedded->pcData));
      image = cv::imdecode(bytes, cv::IMREAD_COLOR);
    } else {  // raw texels, stored b, g, r, a
      image = cv::Mat(static_cast<int>(embedded->mHeight), static_cast<int>(embedded->mWidth),
                      CV_8UC4, const_cast<aiTexel*>(embedded->pcData))
                  .clone();
    }
    if (image.empty()) {
      G6D_THROW("LoadMesh: '" << model_path << "': embedded texture '" << texture_path
                              << "' cannot be decoded");
    }
    return ToRgb(image);
  }

  return LoadTextureFile(texture_path, model_path);
}

// Reads the texture image file `texture_path` (as written in the model) of `model_path`
// as RGB: relative to the model's folder, or just its file name beside the model.
cv::Mat LoadTextureFile(const std::string& texture_path, const std::string& model_path) {
  namespace fs = std::filesystem;
  std::string relative = texture_path;
  std::replace(relative.begin(), relative.end(), '\\', '/');  // files exported on Windows
  const fs::path folder = fs::path(model_path).parent_path();
  // The path as written, then just its file name beside the model (exporters often write
  // absolute paths of the machine the model was made on).
  std::vector<fs::path> candidates = {fs::path(relative).is_absolute() ? fs::path(relative)
                                                                       : folder / relative};
  if (candidates[0] != folder / fs::path(relative).filename()) {
    candidates.push_back(folder / fs::path(relative).filename());
  }
  for (const fs::path& candidate : candidates) {
    std::error_code error;
    if (!fs::is_regular_file(candidate, error)) continue;
    const cv::Mat image = cv::imread(candidate.string(), cv::IMREAD_COLOR);
    if (image.empty()) {
      G6D_THROW("LoadMesh: '" << model_path << "': texture image '" << candidate.string()
                              << "' cannot be decoded");
    }
    return ToRgb(image);
  }
  std::ostringstream looked_at;
  for (const fs::path& candidate : candidates) looked_at << " '" << candidate.string() << "'";
  G6D_THROW("LoadMesh: '" << model_path << "': texture image '" << texture_path
                          << "' not found (looked for" << looked_at.str() << ")");
}

// Builds one RGB texture from several images and solid colours by stacking them
// vertically at a common width, each with replicated padding rows; returns the atlas and,
// per entry, the first row and the height of its unpadded image.
cv::Mat BuildAtlas(const std::vector<cv::Mat>& images, std::vector<int>* first_rows,
                   std::vector<int>* heights) {
  int width = kSolidPatchSidePx;
  for (const cv::Mat& image : images) width = std::max(width, image.cols);
  std::vector<cv::Mat> resized;
  first_rows->clear();
  heights->clear();
  int total_height = 0;
  for (const cv::Mat& image : images) {
    cv::Mat scaled = image;
    if (image.cols != width) {
      const int height =
          std::max(1, static_cast<int>(std::lround(image.rows * double(width) / image.cols)));
      cv::resize(image, scaled, cv::Size(width, height), 0, 0, cv::INTER_LINEAR);
    }
    cv::Mat padded;
    cv::copyMakeBorder(scaled, padded, kAtlasPaddingPx, kAtlasPaddingPx, 0, 0,
                       cv::BORDER_REPLICATE);
    first_rows->push_back(total_height + kAtlasPaddingPx);
    heights->push_back(scaled.rows);
    total_height += padded.rows;
    resized.push_back(padded);
  }
  cv::Mat atlas;
  cv::vconcat(resized, atlas);
  return atlas;
}

Eigen::Vector3f ClampColor(const aiColor4D& color) {
  return Eigen::Vector3f(color.r, color.g, color.b).cwiseMax(0.0f).cwiseMin(1.0f);
}

// What to do about a mesh without triangles.
constexpr const char* kNoTrianglesHint =
    "export the object's surface (faces), not a point cloud or a wireframe";

// Keeps the file's normals when every vertex has a usable one (normalized), else computes
// area-weighted normals from the faces.
void FinishNormals(bool file_has_normals, Mesh* mesh) {
  bool normals_usable = file_has_normals && mesh->normals.size() == mesh->vertices.size();
  for (Eigen::Vector3f& normal : mesh->normals) {
    if (!normals_usable) break;
    const float length = normal.norm();
    if (!std::isfinite(length) || length < 1e-12f) {
      normals_usable = false;
      break;
    }
    normal /= length;
  }
  if (!normals_usable) ComputeVertexNormals(mesh);
}

// Throws when `position_m` (of vertex `index`, read as `as_read` in file units) is not finite.
void CheckFiniteVertex(const std::string& path, size_t index, const Eigen::Vector3d& position_m,
                       const Eigen::Vector3d& as_read) {
  if (position_m.allFinite()) return;
  G6D_THROW("LoadMesh: '" << path << "': vertex " << index << " is not finite (" << as_read.x()
                          << ", " << as_read.y() << ", " << as_read.z()
                          << "); remove or repair such vertices (e.g. MeshLab: Remove Duplicate "
                             "and Unreferenced Vertices after deleting them) and export again");
}

// PLY files: our own reader (ply_reader.h says why not assimp's). Appearance as assimp's
// path gives it: vertex colours (alpha dropped), a `comment TextureFile` texture with the
// vertex (or face corner) texture coordinates, file normals when every vertex has one.
Mesh LoadPlyMesh(const std::string& path, Units units) {
  PlyMesh ply = ReadPly(path);
  if (ply.triangles.empty()) {
    G6D_THROW("LoadMesh: '" << path << "': has no triangles (only "
                            << (ply.num_points_or_lines > 0 ? ply.num_points_or_lines
                                                            : static_cast<int64_t>(
                                                                  ply.positions.size()))
                            << " points or lines); " << kNoTrianglesHint);
  }
  Mesh mesh;
  const double metres_per_unit = MetresPerUnit(units);
  mesh.vertices.reserve(ply.positions.size());
  for (size_t v = 0; v < ply.positions.size(); ++v) {
    const Eigen::Vector3d position_m = ply.positions[v] * metres_per_unit;
    CheckFiniteVertex(path, v, position_m, ply.positions[v]);
    mesh.vertices.push_back(position_m.cast<float>());
  }
  mesh.faces = std::move(ply.triangles);
  for (const Eigen::Vector3f& color : ply.colors) {
    mesh.colors.push_back(color.cwiseMax(0.0f).cwiseMin(1.0f));
  }
  // As with assimp, a texture needs both the image and texture coordinates.
  if (!ply.texture_file.empty() && !ply.uvs.empty()) {
    mesh.texture = LoadTextureFile(ply.texture_file, path);
    mesh.uvs = std::move(ply.uvs);
  }
  const bool file_has_normals = !ply.normals.empty();
  mesh.normals = std::move(ply.normals);
  FinishNormals(file_has_normals, &mesh);
  return mesh;
}

// Throws when what assimp read disagrees with what the file's header declares about itself
// (triangle count, bounds of the positions before node transforms): a reader that
// succeeds must not hide a misread.
void CheckAgainstFileHeader(const std::string& path, const aiScene& scene) {
  const MeshFileHeader header = ReadMeshFileHeader(path);
  if (!header.has_triangle_count && !header.has_bounds) return;
  int64_t triangles = 0;
  Eigen::AlignedBox3d bounds;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh& part = *scene.mMeshes[m];
    for (unsigned f = 0; f < part.mNumFaces; ++f) triangles += part.mFaces[f].mNumIndices == 3;
    for (unsigned v = 0; v < part.mNumVertices; ++v) {
      bounds.extend(Eigen::Vector3d(part.mVertices[v].x, part.mVertices[v].y, part.mVertices[v].z));
    }
  }
  const char* kHint =
      "the reader misread the file: convert it to PLY or OBJ (e.g. with MeshLab or Blender) "
      "and try again";
  if (header.has_triangle_count && triangles != header.triangle_count) {
    G6D_THROW("LoadMesh: '" << path << "': read " << triangles << " triangles but the file ("
                            << header.source << ") declares " << header.triangle_count << "; "
                            << kHint);
  }
  if (header.has_bounds && !bounds.isEmpty()) {
    // Exporters round the declared bounds (glTF min/max are often written with 6-7
    // significant digits): allow a small fraction of the box's size.
    const double tolerance =
        1e-4 * std::max(header.bounds.sizes().maxCoeff(), bounds.sizes().maxCoeff()) + 1e-9;
    const double difference = std::max((bounds.min() - header.bounds.min()).cwiseAbs().maxCoeff(),
                                       (bounds.max() - header.bounds.max()).cwiseAbs().maxCoeff());
    if (!(difference <= tolerance)) {
      const auto corner = [](const Eigen::Vector3d& p) {
        std::ostringstream text;
        text << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
        return text.str();
      };
      G6D_THROW("LoadMesh: '" << path << "': read positions spanning min " << corner(bounds.min())
                              << " max " << corner(bounds.max()) << " but the file ("
                              << header.source << ") declares min "
                              << corner(header.bounds.min()) << " max "
                              << corner(header.bounds.max()) << " (file units); " << kHint);
    }
  }
}

// Every other format: assimp.
Mesh LoadAssimpMesh(const std::string& path, Units units) {
  Assimp::Importer importer;
  // Read without post-processing first: validation would reject a mesh without faces
  // (a point cloud) with a message that hides what is wrong with the file.
  const aiScene* scene = importer.ReadFile(path, 0);
  if (scene == nullptr) {
    G6D_THROW("LoadMesh: '" << path << "': cannot be parsed (assimp: " << importer.GetErrorString()
                            << "); use a PLY, OBJ, STL or glTF mesh file");
  }
  if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0 || scene->mNumMeshes == 0) {
    G6D_THROW("LoadMesh: '" << path << "': holds no meshes (not a mesh file?)");
  }
  size_t num_polygons = 0;
  size_t num_points_or_lines = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh& part = *scene->mMeshes[m];
    for (unsigned f = 0; f < part.mNumFaces; ++f) {
      (part.mFaces[f].mNumIndices >= 3 ? num_polygons : num_points_or_lines) += 1;
    }
    if (part.mNumFaces == 0) num_points_or_lines += part.mNumVertices;  // a point cloud
  }
  if (num_polygons == 0) {
    G6D_THROW("LoadMesh: '" << path << "': has no triangles (only " << num_points_or_lines
                            << " points or lines); " << kNoTrianglesHint);
  }
  CheckAgainstFileHeader(path, *scene);
  // ValidateDataStructure rejects out-of-range indices before any other step reads them;
  // SortByPType splits points and lines off into their own sub-meshes, which are skipped.
  // Normals are computed here, not by assimp, so that they are area-weighted.
  scene = importer.ApplyPostProcessing(aiProcess_ValidateDataStructure | aiProcess_Triangulate |
                                       aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
  if (scene == nullptr) {
    G6D_THROW("LoadMesh: '" << path << "': invalid mesh data (assimp: " << importer.GetErrorString()
                            << "); the file is corrupt or uses features assimp cannot read: "
                               "re-export it (PLY or OBJ)");
  }

  std::vector<ScenePart> parts;
  if (scene->mRootNode != nullptr) CollectParts(*scene, *scene->mRootNode, aiMatrix4x4(), &parts);
  if (parts.empty()) {  // no node hierarchy: take the meshes as they are
    for (unsigned i = 0; i < scene->mNumMeshes; ++i) parts.push_back({scene->mMeshes[i], {}, {}});
  }
  // Keep triangle parts only.
  parts.erase(std::remove_if(parts.begin(), parts.end(),
                             [](const ScenePart& part) {
                               return (part.mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) ==
                                          0 ||
                                      part.mesh->mNumFaces == 0;
                             }),
              parts.end());
  if (parts.empty()) {
    G6D_THROW("LoadMesh: '" << path << "': has no triangles; " << kNoTrianglesHint);
  }

  // Appearance of each part: texture, vertex colours, material colour.
  std::map<std::string, int> texture_index_by_path;
  std::vector<cv::Mat> texture_images;
  for (ScenePart& part : parts) {
    PartAppearance& appearance = part.appearance;
    appearance.has_vertex_colors = part.mesh->HasVertexColors(0);
    if (part.mesh->mMaterialIndex >= scene->mNumMaterials) continue;
    const aiMaterial& material = *scene->mMaterials[part.mesh->mMaterialIndex];
    aiColor4D diffuse;
    if (material.Get(AI_MATKEY_COLOR_DIFFUSE, diffuse) == AI_SUCCESS) {
      appearance.material_color = ClampColor(diffuse);
      appearance.has_material_color = true;
    }
    if (!part.mesh->HasTextureCoords(0)) continue;
    aiString texture_path;
    if (material.GetTexture(aiTextureType_DIFFUSE, 0, &texture_path) != AI_SUCCESS &&
        material.GetTexture(aiTextureType_BASE_COLOR, 0, &texture_path) != AI_SUCCESS) {
      continue;
    }
    const std::string key = texture_path.C_Str();
    auto found = texture_index_by_path.find(key);
    if (found == texture_index_by_path.end()) {
      texture_images.push_back(LoadTextureImage(*scene, key, path));
      found = texture_index_by_path.emplace(key, static_cast<int>(texture_images.size()) - 1).first;
    }
    appearance.texture_index = found->second;
  }
  const bool any_texture = !texture_images.empty();
  const bool any_vertex_colors = std::any_of(parts.begin(), parts.end(), [](const ScenePart& p) {
    return p.appearance.has_vertex_colors;
  });
  // Without textures or vertex colours, material colours are kept only when they differ
  // between parts (a multi-coloured CAD model); one colour for everything says nothing.
  bool material_colors_differ = false;
  for (const ScenePart& part : parts) {
    material_colors_differ |=
        part.appearance.has_material_color &&
        !part.appearance.material_color.isApprox(parts.front().appearance.material_color, 1e-6f);
  }
  const bool output_colors = any_vertex_colors || (!any_texture && material_colors_differ);

  // Texture layout: a single texture used by every part is kept as is (UVs untouched, so
  // repeating UVs still work); otherwise an atlas of the textures plus one solid patch per
  // untextured part, with UVs remapped into it.
  const bool single_texture =
      texture_images.size() == 1 && std::all_of(parts.begin(), parts.end(), [](const ScenePart& p) {
        return p.appearance.texture_index == 0;
      });
  std::vector<int> atlas_entry_of_part(parts.size(), -1);
  std::vector<int> atlas_first_rows, atlas_heights;
  Mesh mesh;
  if (any_texture && single_texture) {
    mesh.texture = texture_images.front();
  } else if (any_texture) {
    std::vector<cv::Mat> entries = texture_images;
    for (size_t p = 0; p < parts.size(); ++p) {
      const PartAppearance& appearance = parts[p].appearance;
      if (appearance.texture_index >= 0) {
        atlas_entry_of_part[p] = appearance.texture_index;
        continue;
      }
      Eigen::Vector3f color = appearance.material_color;
      if (appearance.has_vertex_colors && parts[p].mesh->mNumVertices > 0) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (unsigned v = 0; v < parts[p].mesh->mNumVertices; ++v) {
          sum += ClampColor(parts[p].mesh->mColors[0][v]).cast<double>();
        }
        color = (sum / parts[p].mesh->mNumVertices).cast<float>();
      }
      entries.emplace_back(
          kSolidPatchSidePx, kSolidPatchSidePx, CV_8UC3,
          cv::Scalar(std::lround(color.x() * 255.0f), std::lround(color.y() * 255.0f),
                     std::lround(color.z() * 255.0f)));
      atlas_entry_of_part[p] = static_cast<int>(entries.size()) - 1;
    }
    mesh.texture = BuildAtlas(entries, &atlas_first_rows, &atlas_heights);
  }

  // Merge the parts.
  const double metres_per_unit = MetresPerUnit(units);
  bool all_normals = true;
  for (size_t p = 0; p < parts.size(); ++p) {
    const aiMesh& part = *parts[p].mesh;
    const PartAppearance& appearance = parts[p].appearance;
    const aiMatrix4x4& transform = parts[p].transform;
    aiMatrix3x3 normal_transform(transform);
    normal_transform.Inverse().Transpose();
    const int first_vertex = static_cast<int>(mesh.vertices.size());
    all_normals &= part.HasNormals();
    for (unsigned v = 0; v < part.mNumVertices; ++v) {
      const aiVector3D position = transform * part.mVertices[v];
      const Eigen::Vector3d position_m =
          Eigen::Vector3d(position.x, position.y, position.z) * metres_per_unit;
      CheckFiniteVertex(
          path, mesh.vertices.size(), position_m,
          Eigen::Vector3d(part.mVertices[v].x, part.mVertices[v].y, part.mVertices[v].z));
      mesh.vertices.push_back(position_m.cast<float>());
      if (part.HasNormals()) {
        const aiVector3D normal = normal_transform * part.mNormals[v];
        mesh.normals.emplace_back(normal.x, normal.y, normal.z);
      }
      if (output_colors) {
        mesh.colors.push_back(appearance.has_vertex_colors ? ClampColor(part.mColors[0][v])
                                                           : appearance.material_color);
      }
      if (any_texture) {
        Eigen::Vector2f uv(0.5f, 0.5f);
        if (appearance.texture_index >= 0) {
          uv = Eigen::Vector2f(part.mTextureCoords[0][v].x, part.mTextureCoords[0][v].y);
        }
        if (!single_texture) {
          // Place v (up, 0 at the bottom row) inside the entry's rows of the atlas. Repeating
          // UVs outside [0, 1] are wrapped per vertex, which is exact unless a face
          // straddles a wrap.
          const int entry = atlas_entry_of_part[p];
          const auto wrap = [](double t) { return t < 0.0 || t > 1.0 ? t - std::floor(t) : t; };
          const double u_in_entry = wrap(uv.x());
          const double v_in_entry = wrap(uv.y());
          const double row = atlas_first_rows[entry] + (1.0 - v_in_entry) * atlas_heights[entry];
          uv = Eigen::Vector2f(static_cast<float>(u_in_entry),
                               static_cast<float>(1.0 - row / mesh.texture.rows));
        }
        mesh.uvs.push_back(uv);
      }
    }
    for (unsigned f = 0; f < part.mNumFaces; ++f) {
      const aiFace& face = part.mFaces[f];
      if (face.mNumIndices != 3) continue;  // a stray point or line in a triangle part
      Eigen::Vector3i indices;
      for (int k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= part.mNumVertices) {
          G6D_THROW("LoadMesh: '" << path << "': face " << f << " refers to vertex "
                                  << face.mIndices[k] << " but its mesh has " << part.mNumVertices
                                  << " vertices; the file is corrupt: re-export it");
        }
        indices[k] = first_vertex + static_cast<int>(face.mIndices[k]);
      }
      mesh.faces.push_back(indices);
    }
  }
  if (mesh.faces.empty()) {
    G6D_THROW("LoadMesh: '" << path << "': has no triangles; " << kNoTrianglesHint);
  }
  // File normals are kept when every part has them and all are usable; otherwise computed.
  FinishNormals(all_normals, &mesh);
  return mesh;
}

}  // namespace

Mesh LoadMesh(const std::string& path, Units units) {
  namespace fs = std::filesystem;
  std::error_code fs_error;
  if (!fs::exists(path, fs_error)) G6D_THROW("LoadMesh: '" << path << "': file does not exist");
  if (!fs::is_regular_file(path, fs_error)) {
    G6D_THROW("LoadMesh: '" << path << "': not a regular file");
  }
  if (fs::file_size(path, fs_error) == 0) G6D_THROW("LoadMesh: '" << path << "': file is empty");

  Mesh mesh = IsPlyFile(path) ? LoadPlyMesh(path, units) : LoadAssimpMesh(path, units);
  // Every face is a valid index triple here; a surface without area cannot be rendered or
  // sampled.
  const double area_m2 = ComputeSurfaceArea(mesh);
  if (!(area_m2 > 0.0)) {
    G6D_THROW("LoadMesh: '" << path << "': has no area: all " << mesh.faces.size()
                            << " triangles are degenerate (repeated or collinear corners: a flattened or "
                               "collapsed export?); export the object's surface again");
  }
  return mesh;
}

// ---------------------------------------------------------------------------------------
// Measures.

double ComputeDiameter(const Mesh& mesh) {
  if (mesh.vertices.size() < 2) return 0.0;
  std::vector<Eigen::Vector3d> points;
  points.reserve(mesh.vertices.size());
  for (const Eigen::Vector3f& vertex : mesh.vertices) points.push_back(vertex.cast<double>());

  // The two farthest vertices are vertices of the convex hull, so only hull vertices need
  // to be compared. Qhull fails on flat or degenerate input; all vertices are used then.
  if (points.size() > kDiameterBruteForceMaxVertices) {
    try {
      const auto hull = open3d::geometry::Qhull::ComputeConvexHull(points, false);
      const std::vector<size_t>& hull_indices = std::get<1>(hull);
      if (hull_indices.size() >= 2) {
        std::vector<Eigen::Vector3d> hull_points;
        hull_points.reserve(hull_indices.size());
        for (size_t index : hull_indices) hull_points.push_back(points[index]);
        points.swap(hull_points);
      }
    } catch (const std::exception&) {
      // Keep all vertices.
    }
  }

  // Exact search over all pairs with pruning: with r_i the distance of point i from the
  // box centre, |p_i - p_j| <= r_i + r_j, so after sorting by r descending a pair (and
  // every later one) can be skipped once r_i + r_j cannot beat the best distance so far.
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& point : points) box.extend(point);
  const Eigen::Vector3d centre = box.center();
  std::vector<std::pair<double, Eigen::Vector3d>> by_radius;
  by_radius.reserve(points.size());
  for (const Eigen::Vector3d& point : points)
    by_radius.emplace_back((point - centre).norm(), point);
  std::sort(by_radius.begin(), by_radius.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  double best_squared = 0.0;
  double best = 0.0;
  for (size_t i = 0; i < by_radius.size(); ++i) {
    const double radius_i = by_radius[i].first;
    if (2.0 * radius_i <= best) break;  // r_j <= r_i for all j > i
    const Eigen::Vector3d& point_i = by_radius[i].second;
    for (size_t j = i + 1; j < by_radius.size(); ++j) {
      if (radius_i + by_radius[j].first <= best) break;
      const double squared = (point_i - by_radius[j].second).squaredNorm();
      if (squared > best_squared) {
        best_squared = squared;
        best = std::sqrt(squared);
      }
    }
  }
  return best;
}

Eigen::AlignedBox3d ComputeBoundingBox(const Mesh& mesh) {
  Eigen::AlignedBox3d box;  // empty
  for (const Eigen::Vector3f& vertex : mesh.vertices) box.extend(vertex.cast<double>());
  return box;
}

double ComputeSurfaceArea(const Mesh& mesh) {
  CheckFaceIndices(mesh, "ComputeSurfaceArea");
  double twice_area = 0.0;
  for (const Eigen::Vector3i& face : mesh.faces) twice_area += FaceCross(mesh, face).norm();
  return 0.5 * twice_area;
}

std::vector<SurfaceSample> SampleSurfaceFaces(const Mesh& mesh, int count, uint64_t seed) {
  if (count < 0) G6D_THROW("SampleSurface: count must be >= 0 (got " << count << ")");
  CheckFaceIndices(mesh, "SampleSurface");
  // Cumulative face areas: a face is picked with probability proportional to its area.
  std::vector<double> cumulative_area(mesh.faces.size());
  double total = 0.0;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    total += FaceCross(mesh, mesh.faces[f]).norm();
    cumulative_area[f] = total;
  }
  if (count > 0 && !(total > 0.0)) {
    G6D_THROW("SampleSurface: the mesh has no faces with positive area (" << mesh.faces.size()
                                                                          << " faces)");
  }
  std::mt19937_64 engine(seed);
  std::vector<SurfaceSample> samples(static_cast<size_t>(count));
  for (SurfaceSample& sample : samples) {
    const double pick = UniformUnit(&engine) * total;
    // upper_bound never lands on a zero-area face: its cumulative value equals the previous.
    sample.face = static_cast<int>(
        std::min<size_t>(std::upper_bound(cumulative_area.begin(), cumulative_area.end(), pick) -
                             cumulative_area.begin(),
                         mesh.faces.size() - 1));
    // Uniform point in a triangle (Osada et al. 2002, "Shape distributions", sec. 4.2).
    const double root_r1 = std::sqrt(UniformUnit(&engine));
    const double r2 = UniformUnit(&engine);
    sample.weights = Eigen::Vector3d(1.0 - root_r1, root_r1 * (1.0 - r2), root_r1 * r2);
  }
  return samples;
}

std::vector<Eigen::Vector3f> SampleSurface(const Mesh& mesh, int count, uint64_t seed,
                                           std::vector<Eigen::Vector3f>* normals) {
  const std::vector<SurfaceSample> samples = SampleSurfaceFaces(mesh, count, seed);
  std::vector<Eigen::Vector3f> points;
  points.reserve(samples.size());
  if (normals != nullptr) {
    normals->clear();
    normals->reserve(samples.size());
  }
  for (const SurfaceSample& sample : samples) {
    const Eigen::Vector3i& face = mesh.faces[static_cast<size_t>(sample.face)];
    const Eigen::Vector3d point = sample.weights[0] * mesh.vertices[face[0]].cast<double>() +
                                  sample.weights[1] * mesh.vertices[face[1]].cast<double>() +
                                  sample.weights[2] * mesh.vertices[face[2]].cast<double>();
    points.push_back(point.cast<float>());
    if (normals != nullptr) normals->push_back(FaceCross(mesh, face).normalized().cast<float>());
  }
  return points;
}

void ComputeVertexNormals(Mesh* mesh) {
  G6D_CHECK(mesh != nullptr);
  CheckFaceIndices(*mesh, "ComputeVertexNormals");
  // Summing unnormalized face normals (cross products) weights each face by its area.
  std::vector<Eigen::Vector3d> sums(mesh->vertices.size(), Eigen::Vector3d::Zero());
  for (const Eigen::Vector3i& face : mesh->faces) {
    const Eigen::Vector3d cross = FaceCross(*mesh, face);
    for (int k = 0; k < 3; ++k) sums[face[k]] += cross;
  }
  mesh->normals.resize(mesh->vertices.size());
  for (size_t v = 0; v < sums.size(); ++v) {
    const double length = sums[v].norm();
    // Vertices on no face with area get +z, so that every normal stays unit length.
    mesh->normals[v] =
        length > 0.0 ? (sums[v] / length).cast<float>() : Eigen::Vector3f::UnitZ().eval();
  }
}

Mesh Decimate(const Mesh& mesh, int target_faces) {
  if (target_faces < 1)
    G6D_THROW("Decimate: target_faces must be >= 1 (got " << target_faces << ")");
  CheckFaceIndices(mesh, "Decimate");
  Mesh result;
  if (static_cast<int>(mesh.faces.size()) <= target_faces) {
    result.vertices = mesh.vertices;
    result.faces = mesh.faces;
    result.normals = mesh.normals;
    if (result.normals.size() != result.vertices.size()) ComputeVertexNormals(&result);
    return result;
  }

  open3d::geometry::TriangleMesh input;
  input.vertices_.reserve(mesh.vertices.size());
  for (const Eigen::Vector3f& vertex : mesh.vertices)
    input.vertices_.push_back(vertex.cast<double>());
  input.triangles_ = mesh.faces;
  // Seams of textured meshes split vertices that share a position; merging them first lets
  // the decimation see one closed surface instead of patches with boundaries.
  input.RemoveDuplicatedVertices();
  input.RemoveDegenerateTriangles();
  // Quadric error metric decimation (Garland and Heckbert 1997); no error cap, so the face
  // target decides; boundary weight 1 as in Open3D's default.
  const std::shared_ptr<open3d::geometry::TriangleMesh> simplified =
      input.SimplifyQuadricDecimation(target_faces, std::numeric_limits<double>::infinity(), 1.0);
  simplified->RemoveDegenerateTriangles();
  simplified->RemoveUnreferencedVertices();

  result.vertices.reserve(simplified->vertices_.size());
  for (const Eigen::Vector3d& vertex : simplified->vertices_) {
    result.vertices.push_back(vertex.cast<float>());
  }
  result.faces = simplified->triangles_;
  ComputeVertexNormals(&result);
  return result;
}

bool IsClosedAndOriented(const Mesh& mesh) {
  if (mesh.faces.empty()) return false;
  // Weld vertices with identical positions (split by UV seams or colours in the file).
  std::map<std::array<float, 3>, int> welded;
  std::vector<int> id(mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const std::array<float, 3> key = {mesh.vertices[i].x(), mesh.vertices[i].y(), mesh.vertices[i].z()};
    id[i] = welded.emplace(key, static_cast<int>(welded.size())).first->second;
  }
  std::map<std::pair<int, int>, int> directed;
  for (const Eigen::Vector3i& face : mesh.faces) {
    const int a = id[static_cast<size_t>(face[0])], b = id[static_cast<size_t>(face[1])], c = id[static_cast<size_t>(face[2])];
    if (a == b || b == c || a == c) continue;  // degenerate after welding: no area, no edges
    for (const auto& edge : {std::make_pair(a, b), std::make_pair(b, c), std::make_pair(c, a)}) {
      if (++directed[edge] > 1) return false;
    }
  }
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != 1) return false;
  }
  return true;
}

}  // namespace g6d
