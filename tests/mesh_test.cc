#include "mesh/mesh.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "mesh_files.h"
#include "test_meshes.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

constexpr const char* kLmoModelsDir = "lmo/models";
constexpr const char* kYcbvFoamBrick = "ycbv_real/models/061_foam_brick/textured.obj";
constexpr const char* kYcbvModelsInfo = "ycbv_real/models/models_info.json";
const int kLmoObjectIds[] = {1, 5, 6, 8, 9, 10, 11, 12};

std::string LmoModelPath(int object_id) {
  char name[32];
  std::snprintf(name, sizeof(name), "obj_%06d.ply", object_id);
  return test::SharedDataPath(std::string(kLmoModelsDir) + "/" + name);
}

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

void WriteFile(const std::string& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary);
  out << contents;
}

// Axis-aligned cube of side `side_m` centred at the origin, faces counter-clockwise seen
// from outside.
Mesh MakeCube(float side_m = 1.0f) {
  Mesh mesh;
  const float h = 0.5f * side_m;
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.emplace_back((i & 1) ? h : -h, (i & 2) ? h : -h, (i & 4) ? h : -h);
  }
  mesh.faces = {{0, 2, 1}, {1, 2, 3},   // z = -h
                {4, 5, 6}, {5, 7, 6},   // z = +h
                {0, 1, 4}, {1, 5, 4},   // y = -h
                {2, 6, 3}, {3, 6, 7},   // y = +h
                {0, 4, 2}, {2, 4, 6},   // x = -h
                {1, 3, 5}, {3, 7, 5}};  // x = +h
  return mesh;
}

// Box with sides (sx, sy, sz) centred at the origin (the cube scaled per axis).
Mesh MakeBox(const Eigen::Vector3f& sides_m) {
  Mesh mesh = MakeCube(1.0f);
  for (Eigen::Vector3f& vertex : mesh.vertices) vertex = vertex.cwiseProduct(sides_m);
  return mesh;
}

// The message of the g6d::Error thrown by LoadMesh, or "" when it does not throw.
std::string LoadError(const std::string& path, Units units = Units::kMetres) {
  try {
    LoadMesh(path, units);
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

// Exact diameter by comparing every pair.
double BruteForceDiameter(const std::vector<Eigen::Vector3f>& points) {
  double best = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    for (size_t j = i + 1; j < points.size(); ++j) {
      best = std::max(best, (points[i].cast<double>() - points[j].cast<double>()).norm());
    }
  }
  return best;
}

// ---------------------------------------------------------------------------------------
// Units.

TEST(ParseUnits, AcceptsMillimetresAndMetres) {
  EXPECT_EQ(ParseUnits("mm"), Units::kMillimetres);
  EXPECT_EQ(ParseUnits("m"), Units::kMetres);
  EXPECT_STREQ(UnitsName(Units::kMillimetres), "mm");
  EXPECT_STREQ(UnitsName(Units::kMetres), "m");
  EXPECT_DOUBLE_EQ(MetresPerUnit(Units::kMillimetres), 0.001);
  EXPECT_DOUBLE_EQ(MetresPerUnit(Units::kMetres), 1.0);
}

TEST(ParseUnits, RejectsOtherTextNamingIt) {
  for (const char* text : {"", "cm", "MM", "metres", " m"}) {
    try {
      ParseUnits(text);
      ADD_FAILURE() << "no error for '" << text << "'";
    } catch (const Error& error) {
      EXPECT_THAT(error.what(), HasSubstr("\"" + std::string(text) + "\""));
    }
  }
}

// ---------------------------------------------------------------------------------------
// Measures on meshes built in code.

TEST(ComputeBoundingBox, UnitCube) {
  const Eigen::AlignedBox3d box = ComputeBoundingBox(MakeCube());
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d::Constant(-0.5)));
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d::Constant(0.5)));
  EXPECT_TRUE(ComputeBoundingBox(Mesh()).isEmpty());
}

TEST(ComputeSurfaceArea, UnitCubeAndBox) {
  EXPECT_NEAR(ComputeSurfaceArea(MakeCube()), 6.0, 1e-9);
  EXPECT_NEAR(ComputeSurfaceArea(MakeBox({1.0f, 2.0f, 3.0f})), 2.0 * (2 + 3 + 6), 1e-6);
}

TEST(ComputeSurfaceArea, RejectsOutOfRangeFace) {
  Mesh mesh = MakeCube();
  mesh.faces.push_back({0, 1, 8});
  EXPECT_THROW(ComputeSurfaceArea(mesh), Error);
}

TEST(ComputeDiameter, CubeIsSpaceDiagonal) {
  EXPECT_NEAR(ComputeDiameter(MakeCube()), std::sqrt(3.0), 1e-6);
  EXPECT_EQ(ComputeDiameter(Mesh()), 0.0);
}

TEST(ComputeDiameter, HullMatchesBruteForceOnRandomPoints) {
  // Enough points to take the convex hull path; an ellipsoid cloud plus interior points.
  std::mt19937_64 engine(7);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  Mesh mesh;
  for (int i = 0; i < 4000; ++i) {
    Eigen::Vector3f direction(normal(engine), normal(engine), normal(engine));
    const float shell = (i % 2 == 0) ? 1.0f : 0.5f;
    mesh.vertices.push_back(direction.normalized().cwiseProduct(Eigen::Vector3f(0.3f, 0.2f, 0.1f)) *
                            shell);
  }
  EXPECT_NEAR(ComputeDiameter(mesh), BruteForceDiameter(mesh.vertices), 1e-7);
}

TEST(ComputeDiameter, FlatPointSetFallsBack) {
  // Coplanar points make the convex hull degenerate; the result must still be exact.
  std::mt19937_64 engine(11);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  Mesh mesh;
  for (int i = 0; i < 3000; ++i) mesh.vertices.emplace_back(uniform(engine), uniform(engine), 0.0f);
  EXPECT_NEAR(ComputeDiameter(mesh), BruteForceDiameter(mesh.vertices), 1e-7);
}

TEST(ComputeVertexNormals, CubeCornersPointOutward) {
  Mesh mesh = MakeCube();
  ComputeVertexNormals(&mesh);
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    EXPECT_NEAR(mesh.normals[v].norm(), 1.0f, 1e-6f);
    EXPECT_GT(mesh.normals[v].dot(mesh.vertices[v].normalized()), 0.5f) << "vertex " << v;
  }
}

TEST(SampleSurface, DeterministicForSeed) {
  const Mesh mesh = MakeBox({0.1f, 0.2f, 0.3f});
  const std::vector<Eigen::Vector3f> first = SampleSurface(mesh, 500, 42);
  const std::vector<Eigen::Vector3f> second = SampleSurface(mesh, 500, 42);
  const std::vector<Eigen::Vector3f> other = SampleSurface(mesh, 500, 43);
  ASSERT_EQ(first.size(), 500u);
  EXPECT_EQ(first, second);
  EXPECT_NE(first, other);
  EXPECT_TRUE(SampleSurface(mesh, 0, 42).empty());
  EXPECT_THROW(SampleSurface(mesh, -1, 42), Error);
}

TEST(SampleSurface, PointsLieOnCubeFacesWithFaceNormals) {
  const Mesh mesh = MakeCube();
  std::vector<Eigen::Vector3f> normals;
  const std::vector<Eigen::Vector3f> points = SampleSurface(mesh, 2000, 3, &normals);
  ASSERT_EQ(normals.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& point = points[i];
    EXPECT_LE(point.cwiseAbs().maxCoeff(), 0.5f + 1e-6f) << "point " << i;
    // On the face whose normal was returned: that coordinate is at +-0.5 along the normal.
    int axis = 0;
    normals[i].cwiseAbs().maxCoeff(&axis);
    EXPECT_NEAR(std::abs(normals[i][axis]), 1.0f, 1e-6f);
    EXPECT_NEAR(point[axis], 0.5f * normals[i][axis], 1e-6f) << "point " << i;
  }
}

TEST(SampleSurface, AreaWeighted) {
  // Box faces: the x faces have area 2*3, y faces 1*3, z faces 1*2 (total 22).
  const Mesh mesh = MakeBox({1.0f, 2.0f, 3.0f});
  const int count = 20000;
  std::vector<Eigen::Vector3f> normals;
  SampleSurface(mesh, count, 5, &normals);
  Eigen::Vector3d fraction = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& normal : normals) {
    int axis = 0;
    normal.cwiseAbs().maxCoeff(&axis);
    fraction[axis] += 1.0 / count;
  }
  EXPECT_NEAR(fraction.x(), 12.0 / 22.0, 0.02);
  EXPECT_NEAR(fraction.y(), 6.0 / 22.0, 0.02);
  EXPECT_NEAR(fraction.z(), 4.0 / 22.0, 0.02);
}

TEST(SampleSurface, RejectsMeshWithoutArea) {
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  mesh.faces = {{0, 1, 2}};
  EXPECT_THROW(SampleSurface(mesh, 10, 1), Error);
}

TEST(Decimate, SmallMeshCopiedUnchanged) {
  const Mesh cube = MakeCube();
  const Mesh result = Decimate(cube, 100);
  EXPECT_EQ(result.vertices, cube.vertices);
  EXPECT_EQ(result.faces, cube.faces);
  EXPECT_EQ(result.normals.size(), result.vertices.size());
  EXPECT_THROW(Decimate(cube, 0), Error);
}

// ---------------------------------------------------------------------------------------
// Loading files written by the tests.

class LoadMeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = test::TempDir(std::string("mesh_") + info->name());
  }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }

  std::string dir_;
};

constexpr const char* kCubeObj =
    "v -1 -1 -1\nv 1 -1 -1\nv -1 1 -1\nv 1 1 -1\nv -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\n"
    "f 1 3 2\nf 2 3 4\nf 5 6 7\nf 6 8 7\nf 1 2 5\nf 2 6 5\nf 3 7 4\nf 4 7 8\n"
    "f 1 5 3\nf 3 5 7\nf 2 4 6\nf 4 8 6\n";

TEST_F(LoadMeshFiles, MissingFileNamesIt) {
  const std::string path = Path("does_not_exist.ply");
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("does not exist"));
}

TEST_F(LoadMeshFiles, EmptyFileNamesIt) {
  const std::string path = Path("empty.ply");
  WriteFile(path, "");
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("empty"));
}

TEST_F(LoadMeshFiles, GarbageBytesNameTheFile) {
  for (const char* name : {"garbage.ply", "garbage.obj", "garbage.bin"}) {
    const std::string path = Path(name);
    std::string bytes;
    std::mt19937_64 engine(17);
    for (int i = 0; i < 4096; ++i) bytes.push_back(static_cast<char>(engine() & 0xff));
    WriteFile(path, bytes);
    const std::string message = LoadError(path);
    EXPECT_THAT(message, HasSubstr(path)) << name;
  }
}

TEST_F(LoadMeshFiles, PlyWithPointsOnlyHasNoTriangles) {
  const std::string path = Path("points.ply");
  WriteFile(path,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n");
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("no triangles (only 3 points"));
  EXPECT_THAT(message, HasSubstr("export the object's surface"));
}

TEST_F(LoadMeshFiles, ObjWithLinesOnlyHasNoTriangles) {
  const std::string path = Path("lines.obj");
  WriteFile(path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n");
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("no triangles"));
}

TEST_F(LoadMeshFiles, NanVertexNamesIt) {
  const std::string path = Path("nan.ply");
  WriteFile(path,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n");
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("vertex 1 is not finite"));
  EXPECT_THAT(message, HasSubstr("export again"));
}

TEST_F(LoadMeshFiles, OutOfRangeIndexNamesTheFile) {
  const std::string path = Path("bad_index.ply");
  WriteFile(path,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("face 0 refers to vertex 7 but the file has 3 vertices"));
  EXPECT_THAT(message, HasSubstr("re-export"));
}

TEST_F(LoadMeshFiles, MeshWithoutAreaNamesIt) {
  // Collinear corners (PLY, our reader) and a repeated corner (OBJ, assimp).
  const std::string ply = Path("flat.ply");
  WriteFile(ply,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n");
  const std::string obj = Path("flat.obj");
  WriteFile(obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\nf 3 3 3\n");
  for (const std::string& path : {ply, obj}) {
    const std::string message = LoadError(path);
    EXPECT_THAT(message, HasSubstr(path));
    EXPECT_THAT(message, HasSubstr("has no area"));
    EXPECT_THAT(message, HasSubstr("degenerate"));
    EXPECT_THAT(message, HasSubstr("export the object's surface again"));
  }
}

TEST_F(LoadMeshFiles, ObjWithoutNormalsGetsOutwardNormalsAndScales) {
  const std::string path = Path("cube.obj");
  WriteFile(path, kCubeObj);
  const Mesh mesh = LoadMesh(path, Units::kMillimetres);
  ASSERT_EQ(mesh.vertices.size(), 8u);
  ASSERT_EQ(mesh.faces.size(), 12u);
  EXPECT_NEAR(ComputeBoundingBox(mesh).sizes().x(), 0.002, 1e-9);
  EXPECT_NEAR(ComputeSurfaceArea(mesh), 24e-6, 24e-12);
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    EXPECT_NEAR(mesh.normals[v].norm(), 1.0f, 1e-6f);
    EXPECT_GT(mesh.normals[v].dot(mesh.vertices[v].normalized()), 0.5f);
  }
  EXPECT_FALSE(mesh.HasColors());
  EXPECT_FALSE(mesh.HasTexture());
  const Mesh in_metres = LoadMesh(path, Units::kMetres);
  EXPECT_NEAR(ComputeBoundingBox(in_metres).sizes().x(), 2.0, 1e-9);
}

TEST_F(LoadMeshFiles, QuadsAreTriangulatedAndObjectsMerged) {
  const std::string path = Path("two_quads.obj");
  WriteFile(path,
            "o first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
            "o second\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 5 6 7 8\n");
  const Mesh mesh = LoadMesh(path, Units::kMetres);
  EXPECT_EQ(mesh.faces.size(), 4u);
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_NEAR(ComputeSurfaceArea(mesh), 2.0, 1e-9);
  EXPECT_NEAR(ComputeBoundingBox(mesh).sizes().z(), 1.0, 1e-9);
}

TEST_F(LoadMeshFiles, PlyColoursDropAlpha) {
  const std::string path = Path("rgba.ply");
  WriteFile(path,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
            "property uchar alpha\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0 255 0 0 10\n1 0 0 0 255 0 20\n0 1 0 0 0 255 30\n3 0 1 2\n");
  const Mesh mesh = LoadMesh(path, Units::kMetres);
  ASSERT_TRUE(mesh.HasColors());
  ASSERT_EQ(mesh.colors.size(), 3u);
  std::map<float, Eigen::Vector3f> color_by_x_plus_2y;  // identify vertices by position
  for (size_t v = 0; v < 3; ++v) {
    color_by_x_plus_2y[mesh.vertices[v].x() + 2.0f * mesh.vertices[v].y()] = mesh.colors[v];
  }
  EXPECT_TRUE(color_by_x_plus_2y[0.0f].isApprox(Eigen::Vector3f(1, 0, 0)));
  EXPECT_TRUE(color_by_x_plus_2y[1.0f].isApprox(Eigen::Vector3f(0, 1, 0)));
  EXPECT_TRUE(color_by_x_plus_2y[2.0f].isApprox(Eigen::Vector3f(0, 0, 1)));
}

TEST_F(LoadMeshFiles, MissingTextureNamesItAndTheModel) {
  const std::string path = Path("textured.obj");
  WriteFile(Path("textured.mtl"), "newmtl skin\nmap_Kd nowhere.png\n");
  WriteFile(path,
            "mtllib textured.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
            "usemtl skin\nf 1/1 2/2 3/3\n");
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("nowhere.png"));
}

TEST_F(LoadMeshFiles, TexturedAndPlainPartsShareOneAtlas) {
  // A textured triangle (image: top half red, bottom half green) and a blue (material
  // colour) triangle: both must read their colour from the one texture at their UVs
  // (v up, row 0 at the top), also at the edges of the image (v = 0 and v = 1).
  cv::Mat image_bgr(4, 6, CV_8UC3, cv::Scalar(0, 255, 0));
  image_bgr.rowRange(0, 2).setTo(cv::Scalar(0, 0, 255));
  ASSERT_TRUE(cv::imwrite(Path("red_green.png"), image_bgr));
  WriteFile(Path("parts.mtl"),
            "newmtl textured\nKd 1 1 1\nmap_Kd red_green.png\nnewmtl blue\nKd 0 0 1\n");
  const std::string path = Path("parts.obj");
  // The textured triangle's vertex at y = 1 has v = 1 (top, red); the others v = 0 (green).
  WriteFile(path,
            "mtllib parts.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\n"
            "vt 0 0\nvt 1 0\nvt 0.5 1\n"
            "usemtl textured\nf 1/1 2/2 3/3\nusemtl blue\nf 4 5 6\n");
  const Mesh mesh = LoadMesh(path, Units::kMetres);
  ASSERT_TRUE(mesh.HasTexture());
  ASSERT_EQ(mesh.texture.type(), CV_8UC3);
  ASSERT_EQ(mesh.uvs.size(), mesh.vertices.size());
  const cv::Vec3b red(255, 0, 0), green(0, 255, 0), blue(0, 0, 255);
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector2f& uv = mesh.uvs[v];
    const int column =
        std::min(mesh.texture.cols - 1, static_cast<int>(uv.x() * mesh.texture.cols));
    const int row =
        std::min(mesh.texture.rows - 1, static_cast<int>((1.0f - uv.y()) * mesh.texture.rows));
    const cv::Vec3b rgb = mesh.texture.at<cv::Vec3b>(row, column);
    const bool textured_part = mesh.vertices[v].z() < 0.5f;
    const cv::Vec3b expected = !textured_part ? blue : mesh.vertices[v].y() > 0.5f ? red : green;
    EXPECT_EQ(rgb, expected) << "vertex " << v;
  }
}

// ---------------------------------------------------------------------------------------
// The mesh-file corpus (mesh_files.h): every format gives the same triangles.

// One file of the corpus: how to write it and what it carries besides geometry.
struct CorpusCase {
  std::string name;  // file name
  std::function<void(const std::string& path, const test::CorpusBox& box)> write;
  bool colors = false;         // vertex colours come through
  bool texture = false;        // the texture image and UVs come through
  bool newline_first = false;  // the box whose binary PLY data starts with 0x0a
};

std::vector<CorpusCase> CorpusCases() {
  using test::PlyWriteOptions;
  using Encoding = PlyWriteOptions::Encoding;
  using Colors = PlyWriteOptions::Colors;
  const auto ply = [](PlyWriteOptions options) {
    return [options](const std::string& path, const test::CorpusBox& box) {
      test::WriteCorpusPly(path, box, options);
    };
  };
  const auto obj = [](test::ObjWriteOptions options) {
    return [options](const std::string& path, const test::CorpusBox& box) {
      test::WriteCorpusObj(path, box, options);
    };
  };
  PlyWriteOptions ascii, little, big;
  little.encoding = Encoding::kBinaryLittleEndian;
  big.encoding = Encoding::kBinaryBigEndian;
  for (PlyWriteOptions* options : {&ascii, &little, &big}) options->colors = Colors::kUchar;
  PlyWriteOptions int_counts = little, ascii_int_counts = ascii;
  int_counts.count_type = ascii_int_counts.count_type = "int";
  PlyWriteOptions quads = ascii, binary_quads = big;
  quads.quads = binary_quads.quads = true;
  PlyWriteOptions float_colors = little, ascii_float_colors = ascii;
  float_colors.colors = ascii_float_colors.colors = Colors::kFloat;
  PlyWriteOptions plain = little;
  plain.colors = Colors::kNone;
  PlyWriteOptions textured = little;  // as BOP's YCB-V PLY: normals, colours, texture
  textured.normals = true;
  textured.texture_file = "texture.png";
  PlyWriteOptions ascii_textured = ascii;
  ascii_textured.colors = Colors::kNone;
  ascii_textured.quads = true;
  ascii_textured.texture_file = "texture.png";
  test::ObjWriteOptions obj_mtl, obj_textured, obj_quads;
  obj_mtl.mtl_file = "plain.mtl";
  obj_textured.mtl_file = "textured.mtl";
  obj_textured.texture_file = "texture.png";
  obj_quads.quads = true;
  return {
      {"ascii.ply", ply(ascii), true, false, false},
      {"little.ply", ply(little), true, false, false},
      {"big.ply", ply(big), true, false, false},
      {"newline_first.ply", ply(little), true, false, true},
      {"newline_first_ascii.ply", ply(ascii), true, false, true},
      {"newline_first_plain.ply", ply(plain), false, false, true},
      {"int_counts.ply", ply(int_counts), true, false, false},
      {"ascii_int_counts.ply", ply(ascii_int_counts), true, false, false},
      {"quads.ply", ply(quads), true, false, false},
      {"binary_quads.ply", ply(binary_quads), true, false, false},
      {"float_colors.ply", ply(float_colors), true, false, false},
      {"ascii_float_colors.ply", ply(ascii_float_colors), true, false, false},
      {"plain.ply", ply(plain), false, false, false},
      {"textured.ply", ply(textured), true, true, false},
      {"ascii_textured_quads.ply", ply(ascii_textured), false, true, false},
      {"plain.obj", obj({}), false, false, false},
      {"quads.obj", obj(obj_quads), false, false, false},
      {"material.obj", obj(obj_mtl), false, false, false},
      {"textured.obj", obj(obj_textured), false, true, false},
      {"binary.stl",
       [](const std::string& path, const test::CorpusBox& box) {
         test::WriteCorpusStl(path, box, true);
       },
       false, false, false},
      {"ascii.stl",
       [](const std::string& path, const test::CorpusBox& box) {
         test::WriteCorpusStl(path, box, false);
       },
       false, false, false},
      {"binary.glb",
       [](const std::string& path, const test::CorpusBox& box) {
         test::WriteCorpusGlb(path, box);
       },
       false, false, false},
  };
}

// Expects `mesh` (loaded in millimetres) to hold the box's triangles, corner by corner, with
// its colours and texture when `expected` says they come through, and nothing else.
void ExpectCorpusBox(const Mesh& mesh, const test::CorpusBox& box, const CorpusCase& expected) {
  const std::string& name = expected.name;
  const std::vector<Eigen::Vector3i> triangles = box.Triangles();
  ASSERT_EQ(mesh.faces.size(), triangles.size()) << name;
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size()) << name;
  ASSERT_EQ(mesh.HasColors(), expected.colors) << name;
  ASSERT_EQ(mesh.HasTexture(), expected.texture) << name;
  if (expected.texture) {
    EXPECT_EQ(mesh.texture.cols, 96) << name;
    EXPECT_EQ(mesh.texture.rows, 64) << name;
    ASSERT_EQ(mesh.uvs.size(), mesh.vertices.size()) << name;
  }
  // Text formats round-trip floats with 9 digits, but assimp parses them in single
  // precision: allow a few float steps of a 50 mm coordinate.
  constexpr float kPositionToleranceM = 1e-8f;
  for (size_t f = 0; f < triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int loaded = mesh.faces[f][k];
      const int reference = triangles[f][k];
      const Eigen::Vector3f reference_m = (box.positions[reference].cast<double>() * 1e-3).cast<float>();
      EXPECT_LT((mesh.vertices[loaded] - reference_m).cwiseAbs().maxCoeff(), kPositionToleranceM)
          << name << " face " << f << " corner " << k;
      if (expected.colors) {
        EXPECT_LT((mesh.colors[loaded] - box.Color01(reference)).cwiseAbs().maxCoeff(), 1e-6f)
            << name << " face " << f << " corner " << k;
      }
      if (expected.texture) {
        EXPECT_LT((mesh.uvs[loaded] - box.uvs[reference]).cwiseAbs().maxCoeff(), 1e-6f)
            << name << " face " << f << " corner " << k;
      }
      EXPECT_NEAR(mesh.normals[loaded].norm(), 1.0f, 1e-5f) << name;
    }
  }
  Eigen::AlignedBox3d reference_box;
  for (const Eigen::Vector3f& p : box.positions) reference_box.extend(p.cast<double>() * 1e-3);
  const Eigen::AlignedBox3d loaded_box = ComputeBoundingBox(mesh);
  EXPECT_LT((loaded_box.min() - reference_box.min()).cwiseAbs().maxCoeff(), 1e-8) << name;
  EXPECT_LT((loaded_box.max() - reference_box.max()).cwiseAbs().maxCoeff(), 1e-8) << name;
  EXPECT_NEAR(ComputeDiameter(mesh), reference_box.sizes().norm(), 1e-7) << name;
  EXPECT_NEAR(ComputeSurfaceArea(mesh), 2.0 * (0.08 * 0.06 + 0.08 * 0.04 + 0.06 * 0.04), 1e-8)
      << name;
  EXPECT_TRUE(IsClosedAndOriented(mesh)) << name;
}

TEST_F(LoadMeshFiles, CorpusGivesTheSameTrianglesInEveryFormat) {
  ASSERT_TRUE(cv::imwrite(Path("texture.png"), test::CorpusTexture()));
  for (const CorpusCase& corpus_case : CorpusCases()) {
    const test::CorpusBox box = test::MakeCorpusBox(corpus_case.newline_first);
    const std::string path = Path(corpus_case.name);
    corpus_case.write(path, box);
    Mesh mesh;
    try {
      mesh = LoadMesh(path, Units::kMillimetres);
    } catch (const Error& error) {
      ADD_FAILURE() << corpus_case.name << ": " << error.what();
      continue;
    }
    ExpectCorpusBox(mesh, box, corpus_case);
  }
}

// The bytes right after the PLY header's `end_header` line.
std::string PlyBody(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t end = bytes.find("end_header\n");
  return end == std::string::npos ? std::string() : bytes.substr(end + 11);
}

TEST_F(LoadMeshFiles, NewlineFirstBinaryPlyMatchesItsAsciiTwin) {
  // Debian's assimp 5.2 skipped the 0x0a that starts this file's data and read every value
  // one byte off ("aiMesh::mFaces[0].mNumIndices is 0").
  const test::CorpusBox box = test::MakeCorpusBox(/*newline_first=*/true);
  test::PlyWriteOptions options;
  options.colors = test::PlyWriteOptions::Colors::kUchar;
  test::WriteCorpusPly(Path("twin.ply"), box, options);
  options.encoding = test::PlyWriteOptions::Encoding::kBinaryLittleEndian;
  test::WriteCorpusPly(Path("binary.ply"), box, options);
  ASSERT_EQ(PlyBody(Path("binary.ply")).at(0), '\n');
  const Mesh ascii = LoadMesh(Path("twin.ply"), Units::kMillimetres);
  const Mesh binary = LoadMesh(Path("binary.ply"), Units::kMillimetres);
  EXPECT_EQ(binary.vertices, ascii.vertices);
  EXPECT_EQ(binary.faces, ascii.faces);
  EXPECT_EQ(binary.colors, ascii.colors);
  EXPECT_EQ(binary.normals, ascii.normals);
  EXPECT_EQ(ComputeDiameter(binary), ComputeDiameter(ascii));
  EXPECT_TRUE(ComputeBoundingBox(binary).isApprox(ComputeBoundingBox(ascii), 0.0));
}

TEST_F(LoadMeshFiles, BrokenBinaryPlyNamesWhatIsWrong) {
  test::PlyWriteOptions options;
  options.encoding = test::PlyWriteOptions::Encoding::kBinaryLittleEndian;
  test::WriteCorpusPly(Path("whole.ply"), test::MakeCorpusBox(), options);
  std::ifstream in(Path("whole.ply"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  WriteFile(Path("truncated.ply"), bytes.substr(0, bytes.size() - 10));
  std::string message = LoadError(Path("truncated.ply"));
  EXPECT_THAT(message, HasSubstr(Path("truncated.ply")));
  EXPECT_THAT(message, HasSubstr("the data ends in face 11 of 12"));
  EXPECT_THAT(message, HasSubstr("re-export"));

  // One byte too many: what a reader that skips a byte it should not (or a header that
  // does not match the data) leaves over.
  WriteFile(Path("extra.ply"), bytes + "\x01");
  message = LoadError(Path("extra.ply"));
  EXPECT_THAT(message, HasSubstr(Path("extra.ply")));
  EXPECT_THAT(message, HasSubstr("1 bytes follow the last element (face 12)"));
}

TEST_F(LoadMeshFiles, ReaderDisagreeingWithTheFileHeaderIsRefused) {
  // A glTF whose POSITION accessor declares other bounds than its data holds: what a
  // misread looks like to the check.
  const std::string path = Path("lying.glb");
  test::WriteCorpusGlb(path, test::MakeCorpusBox(), /*declared_max_scale=*/2.0f);
  const std::string message = LoadError(path);
  EXPECT_THAT(message, HasSubstr(path));
  EXPECT_THAT(message, HasSubstr("but the file (glTF accessors) declares"));
  EXPECT_THAT(message, HasSubstr("convert it to PLY or OBJ"));
}

// ---------------------------------------------------------------------------------------
// BOP models from the shared data.

TEST(ComputeDiameter, MatchesBopLmoModelsInfo) {
  G6D_REQUIRE_SHARED_DATA("lmo/models/models_info.json");
  const nlohmann::json info = ReadJson(test::SharedDataPath("lmo/models/models_info.json"));
  for (int object_id : kLmoObjectIds) {
    const Mesh mesh = LoadMesh(LmoModelPath(object_id), Units::kMillimetres);
    const double diameter_mm = 1000.0 * ComputeDiameter(mesh);
    const double expected_mm = info.at(std::to_string(object_id)).at("diameter").get<double>();
    std::printf("obj %2d  diameter %.3f mm  BOP %.3f mm  (%+.3f%%)\n", object_id, diameter_mm,
                expected_mm, 100.0 * (diameter_mm - expected_mm) / expected_mm);
    EXPECT_NEAR(diameter_mm, expected_mm, 0.01 * expected_mm) << "object " << object_id;
  }
}

TEST(ComputeBoundingBox, MatchesBopLmoModelsInfo) {
  G6D_REQUIRE_SHARED_DATA("lmo/models/models_info.json");
  const nlohmann::json info = ReadJson(test::SharedDataPath("lmo/models/models_info.json"));
  for (int object_id : kLmoObjectIds) {
    const Mesh mesh = LoadMesh(LmoModelPath(object_id), Units::kMillimetres);
    const Eigen::AlignedBox3d box = ComputeBoundingBox(mesh);
    const nlohmann::json& entry = info.at(std::to_string(object_id));
    const char* axes[] = {"x", "y", "z"};
    for (int axis = 0; axis < 3; ++axis) {
      const double min_mm = entry.at(std::string("min_") + axes[axis]).get<double>();
      const double size_mm = entry.at(std::string("size_") + axes[axis]).get<double>();
      EXPECT_NEAR(1000.0 * box.min()[axis], min_mm, 0.01)
          << "object " << object_id << " " << axes[axis];
      EXPECT_NEAR(1000.0 * box.sizes()[axis], size_mm, 0.01)
          << "object " << object_id << " " << axes[axis];
    }
  }
}

TEST(LoadMesh, LmoPlyKeepsVertexColoursAndNormals) {
  G6D_REQUIRE_SHARED_DATA("lmo/models/obj_000001.ply");
  const Mesh mesh = LoadMesh(LmoModelPath(1), Units::kMillimetres);
  EXPECT_EQ(mesh.vertices.size(), 5841u);  // as in the PLY header
  EXPECT_EQ(mesh.faces.size(), 11678u);
  ASSERT_TRUE(mesh.HasColors());
  ASSERT_EQ(mesh.colors.size(), mesh.vertices.size());
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  // First vertex of the file: -23.0565 17.4191 -6.756, colour 148 57 57 (alpha dropped).
  EXPECT_TRUE(
      mesh.vertices[0].isApprox(Eigen::Vector3f(-0.0230565f, 0.0174191f, -0.006756f), 1e-5f));
  EXPECT_TRUE(mesh.colors[0].isApprox(Eigen::Vector3f(148, 57, 57) / 255.0f, 1e-5f));
  for (const Eigen::Vector3f& normal : mesh.normals) EXPECT_NEAR(normal.norm(), 1.0f, 1e-4f);
  EXPECT_FALSE(mesh.HasTexture());
}

TEST(LoadMesh, TexturedBinaryPlyKeepsTextureColoursAndNormals) {
  // BOP-style YCB-V model as binary PLY: normals, uchar RGBA, texture_u/v, TextureFile.
  constexpr const char* kModel = "synth_dev/models/obj_000302.ply";
  G6D_REQUIRE_SHARED_DATA(kModel);
  const Mesh mesh = LoadMesh(test::SharedDataPath(kModel), Units::kMillimetres);
  EXPECT_EQ(mesh.vertices.size(), 8411u);  // as in the PLY header
  EXPECT_EQ(mesh.faces.size(), 16384u);
  ASSERT_TRUE(mesh.HasColors());
  ASSERT_TRUE(mesh.HasTexture());
  ASSERT_EQ(mesh.uvs.size(), mesh.vertices.size());
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  const cv::Mat png =
      cv::imread(test::SharedDataPath("synth_dev/models/obj_000302.png"), cv::IMREAD_COLOR);
  EXPECT_EQ(mesh.texture.size(), png.size());
  for (const Eigen::Vector3f& normal : mesh.normals) EXPECT_NEAR(normal.norm(), 1.0f, 1e-4f);
  // The dataset's models_info.json (BOP: millimetres).
  const nlohmann::json info =
      ReadJson(test::SharedDataPath("synth_dev/models/models_info.json")).at("302");
  EXPECT_NEAR(1000.0 * ComputeDiameter(mesh), info.at("diameter").get<double>(), 0.01);
  const Eigen::AlignedBox3d box = ComputeBoundingBox(mesh);
  const char* axes[] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(1000.0 * box.min()[axis], info.at(std::string("min_") + axes[axis]).get<double>(),
                0.01);
    EXPECT_NEAR(1000.0 * box.sizes()[axis],
                info.at(std::string("size_") + axes[axis]).get<double>(), 0.01);
  }
}

TEST(LoadMesh, YcbvObjKeepsTextureUvsInMetres) {
  G6D_REQUIRE_SHARED_DATA(kYcbvFoamBrick);
  const Mesh mesh = LoadMesh(test::SharedDataPath(kYcbvFoamBrick), Units::kMetres);
  ASSERT_TRUE(mesh.HasTexture());
  EXPECT_EQ(mesh.texture.type(), CV_8UC3);
  const cv::Mat png = cv::imread(
      test::SharedDataPath("ycbv_real/models/061_foam_brick/texture_map.png"), cv::IMREAD_COLOR);
  EXPECT_EQ(mesh.texture.size(), png.size());
  EXPECT_EQ(mesh.faces.size(), 16384u);
  ASSERT_EQ(mesh.uvs.size(), mesh.vertices.size());
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  for (const Eigen::Vector2f& uv : mesh.uvs) {
    EXPECT_TRUE(uv.x() >= 0.0f && uv.x() <= 1.0f && uv.y() >= 0.0f && uv.y() <= 1.0f);
  }
  const Eigen::AlignedBox3d box = ComputeBoundingBox(mesh);
  EXPECT_GT(box.sizes().maxCoeff(), 0.05);  // metres: about 8 cm
  EXPECT_LT(box.sizes().maxCoeff(), 0.10);
}

TEST(ComputeDiameter, MatchesBopYcbvFoamBrick) {
  G6D_REQUIRE_SHARED_DATA(kYcbvFoamBrick);
  const Mesh mesh = LoadMesh(test::SharedDataPath(kYcbvFoamBrick), Units::kMetres);
  const nlohmann::json info = ReadJson(test::SharedDataPath(kYcbvModelsInfo));
  const double expected_mm = info.at("21").at("diameter").get<double>();
  const double diameter_mm = 1000.0 * ComputeDiameter(mesh);
  std::printf("ycbv 21 (061_foam_brick)  diameter %.3f mm  BOP %.3f mm  (%+.3f%%)\n", diameter_mm,
              expected_mm, 100.0 * (diameter_mm - expected_mm) / expected_mm);
  EXPECT_NEAR(diameter_mm, expected_mm, 0.01 * expected_mm);
}

// Checks that decimating `mesh` to `target_faces` keeps its shape.
void ExpectFaithfulDecimation(const Mesh& mesh, int target_faces, const std::string& name) {
  const Mesh decimated = Decimate(mesh, target_faces);
  const int faces = static_cast<int>(decimated.faces.size());
  EXPECT_LE(faces, target_faces) << name;
  EXPECT_GE(faces, 0.9 * target_faces) << name;
  EXPECT_TRUE(decimated.colors.empty() && decimated.uvs.empty() && decimated.texture.empty());
  EXPECT_EQ(decimated.normals.size(), decimated.vertices.size()) << name;
  const Eigen::AlignedBox3d box = ComputeBoundingBox(mesh);
  const Eigen::AlignedBox3d decimated_box = ComputeBoundingBox(decimated);
  const double tolerance_m = 0.02 * box.sizes().maxCoeff();
  EXPECT_LT((decimated_box.min() - box.min()).cwiseAbs().maxCoeff(), tolerance_m) << name;
  EXPECT_LT((decimated_box.max() - box.max()).cwiseAbs().maxCoeff(), tolerance_m) << name;
  const double area_m2 = ComputeSurfaceArea(mesh);
  EXPECT_NEAR(ComputeSurfaceArea(decimated), area_m2, 0.05 * area_m2) << name;
}

TEST(Decimate, LmoModelsKeepBoxAndArea) {
  G6D_REQUIRE_SHARED_DATA("lmo/models/obj_000001.ply");
  for (int object_id : kLmoObjectIds) {
    const Mesh mesh = LoadMesh(LmoModelPath(object_id), Units::kMillimetres);
    ExpectFaithfulDecimation(mesh, 2000, "lmo object " + std::to_string(object_id));
  }
}

TEST(Decimate, TexturedObjWithSeamsKeepsBoxAndArea) {
  G6D_REQUIRE_SHARED_DATA(kYcbvFoamBrick);
  const Mesh mesh = LoadMesh(test::SharedDataPath(kYcbvFoamBrick), Units::kMetres);
  ExpectFaithfulDecimation(mesh, 1000, "061_foam_brick");
}

}  // namespace
}  // namespace g6d

namespace g6d {
namespace {

TEST(IsClosedAndOriented, CubeOpenCubeAndFlippedFace) {
  const Mesh cube = test::MakeCube(0.05);
  EXPECT_TRUE(IsClosedAndOriented(cube));
  Mesh open = cube;
  open.faces.pop_back();
  EXPECT_FALSE(IsClosedAndOriented(open));
  Mesh flipped = cube;
  std::swap(flipped.faces[0][1], flipped.faces[0][2]);
  EXPECT_FALSE(IsClosedAndOriented(flipped));
  // Split vertices (as with UV seams) are welded by position: still closed.
  Mesh split = cube;
  for (Eigen::Vector3i& face : split.faces) {
    for (int k = 0; k < 3; ++k) {
      split.vertices.push_back(split.vertices[static_cast<size_t>(face[k])]);
      face[k] = static_cast<int>(split.vertices.size()) - 1;
    }
  }
  EXPECT_TRUE(IsClosedAndOriented(split));
  EXPECT_FALSE(IsClosedAndOriented(Mesh()));
}

}  // namespace
}  // namespace g6d
