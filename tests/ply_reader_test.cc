#include "mesh/ply_reader.h"

#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "mesh_files.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

class PlyFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = test::TempDir(std::string("ply_") + info->name());
  }
  // Writes `contents` to a file of the test's folder and returns its path.
  std::string Write(const std::string& name, const std::string& contents) const {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << contents;
    return path;
  }
  std::string dir_;
};

// The message of the g6d::Error ReadPly throws, or "" when it does not throw.
std::string ReadError(const std::string& path) {
  try {
    ReadPly(path);
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

constexpr const char* kTriangleHeader =
    "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";

TEST_F(PlyFiles, NewlineFirstBinaryKeepsEveryValue) {
  const test::CorpusBox box = test::MakeCorpusBox(/*newline_first=*/true);
  test::PlyWriteOptions options;
  options.encoding = test::PlyWriteOptions::Encoding::kBinaryLittleEndian;
  options.colors = test::PlyWriteOptions::Colors::kUchar;
  const std::string path = dir_ + "/newline_first.ply";
  test::WriteCorpusPly(path, box, options);
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(bytes.at(bytes.find("end_header\n") + 11), '\n');

  const PlyMesh ply = ReadPly(path);
  EXPECT_EQ(ply.format, PlyFormat::kBinaryLittleEndian);
  EXPECT_EQ(ply.header_vertices, 24);
  EXPECT_EQ(ply.header_faces, 12);
  ASSERT_EQ(ply.positions.size(), box.positions.size());
  for (size_t v = 0; v < box.positions.size(); ++v) {
    EXPECT_EQ(ply.positions[v], box.positions[v].cast<double>()) << "vertex " << v;
    EXPECT_EQ(ply.colors[v], box.Color01(static_cast<int>(v))) << "vertex " << v;
  }
  EXPECT_EQ(ply.triangles, box.Triangles());
  EXPECT_EQ(ply.num_polygons, 12);
  EXPECT_TRUE(ply.normals.empty());
  EXPECT_TRUE(ply.uvs.empty());
  EXPECT_TRUE(ply.texture_file.empty());
}

TEST_F(PlyFiles, CrLfHeaderSizedTypesAndUnknownElements) {
  // CR LF line ends, sized type names, an unknown vertex list and an unknown element
  // before the faces, a face property after the indices: all read past.
  const std::string path =
      Write("crlf.ply",
            "ply\r\nformat ascii 1.0\r\ncomment TextureFile my texture.png \r\n"
            "element vertex 3\r\nproperty float32 x\r\nproperty float32 y\r\nproperty float64 z\r\n"
            "property list uint8 int32 tags\r\nproperty uint16 red\r\nproperty uint16 green\r\n"
            "property uint16 blue\r\nelement edge 1\r\nproperty int vertex1\r\n"
            "property int vertex2\r\nelement face 1\r\nproperty list int32 uint32 vertex_index\r\n"
            "property uchar flags\r\nend_header\r\n"
            "0 0 0 2 7 7 65535 0 0\r\n1 0 0 0 0 65535 0\r\n0 1 0.5 1 9 0 0 65535\r\n"
            "0 1\r\n3 0 1 2 9\r\n");
  const PlyMesh ply = ReadPly(path);
  ASSERT_EQ(ply.positions.size(), 3u);
  EXPECT_EQ(ply.positions[2], Eigen::Vector3d(0, 1, 0.5));
  ASSERT_EQ(ply.colors.size(), 3u);
  EXPECT_EQ(ply.colors[1], Eigen::Vector3f(0, 1, 0));
  ASSERT_EQ(ply.triangles.size(), 1u);
  EXPECT_EQ(ply.triangles[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(ply.texture_file, "my texture.png");
}

TEST_F(PlyFiles, FaceTexcoordsSplitSeamVertices) {
  // Two triangles sharing the edge 1-2 with different texture coordinates on it (MeshLab's
  // per-corner `texcoord`): the shared vertices are split, one per coordinate.
  const std::string path = Write(
      "wedges.ply",
      "ply\nformat ascii 1.0\ncomment TextureFile t.png\nelement vertex 4\nproperty float x\n"
      "property float y\nproperty float z\nelement face 2\n"
      "property list uchar int vertex_indices\nproperty list uchar float texcoord\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n1 1 0\n"
      "3 0 1 2 6 0 0 0.5 0 0 0.5\n3 2 1 3 6 0.6 0.5 0.9 0.1 0.9 0.5\n");
  const PlyMesh ply = ReadPly(path);
  ASSERT_EQ(ply.positions.size(), 6u);
  ASSERT_EQ(ply.uvs.size(), 6u);
  ASSERT_EQ(ply.triangles.size(), 2u);
  const std::vector<Eigen::Vector2f> expected_uvs = {{0, 0}, {0.5f, 0}, {0, 0.5f},
                                                     {0.6f, 0.5f}, {0.9f, 0.1f}, {0.9f, 0.5f}};
  const std::vector<Eigen::Vector3d> expected_positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},
                                                           {0, 1, 0}, {1, 0, 0}, {1, 1, 0}};
  for (int t = 0; t < 2; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int index = ply.triangles[t][k];
      EXPECT_EQ(ply.uvs[index], expected_uvs[3 * t + k]) << t << " " << k;
      EXPECT_EQ(ply.positions[index], expected_positions[3 * t + k]) << t << " " << k;
    }
  }
}

TEST_F(PlyFiles, ConcaveQuadIsSplitInsideIt) {
  // An arrowhead (2, -1), (1, 0), (2, 1), (0, 0): its second corner is reflex, and a fan
  // from its first corner would cover area outside it.
  const std::string path = Write(
      "dart.ply",
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n2 -1 0\n1 0 0\n2 1 0\n"
      "4 1 2 3 0\n");
  const PlyMesh ply = ReadPly(path);
  ASSERT_EQ(ply.triangles.size(), 2u);
  double area = 0.0;
  for (const Eigen::Vector3i& t : ply.triangles) {
    const Eigen::Vector3d cross = (ply.positions[t[1]] - ply.positions[t[0]])
                                      .cross(ply.positions[t[2]] - ply.positions[t[0]]);
    EXPECT_GT(cross.z(), 0.0) << "a triangle flipped: it lies outside the quad";
    area += 0.5 * cross.norm();
  }
  EXPECT_NEAR(area, 1.0, 1e-12);  // shoelace
}

TEST_F(PlyFiles, PointsAndLinesAreCountedNotTriangulated) {
  const std::string path = Write(
      "mixed.ply",
      std::string("ply\nformat ascii 1.0\n") +
          "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 3\nproperty list uchar int vertex_indices\nend_header\n"
          "0 0 0\n1 0 0\n0 1 0\n1 0\n2 0 1\n3 0 1 2\n");
  const PlyMesh ply = ReadPly(path);
  EXPECT_EQ(ply.num_points_or_lines, 2);
  EXPECT_EQ(ply.num_polygons, 1);
  EXPECT_EQ(ply.triangles.size(), 1u);
}

TEST_F(PlyFiles, ErrorsNameTheFileAndTheProblem) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"solid x\n", "does not start with the 'ply' magic line"},
      {"ply\nformat ascii 1.0\nelement vertex 0\n", "no 'end_header' line"},
      {"ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format"},
      {"ply\nelement vertex 0\nproperty float x\nend_header\n", "no 'format' line"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
       "unknown type 'quad'"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "end_header\n0 0\n",
       "no x, y and z properties"},
      {"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\n"
       "end_header\n",
       "has no vertex element"},
      {std::string("ply\nformat ascii 1.0\n") + kTriangleHeader + "0 0 0\n1 0 0\n0 1 zero\n",
       "line 12: 'zero' is not a number (vertex 2, property 'z')"},
      {std::string("ply\nformat ascii 1.0\n") + kTriangleHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n",
       "the data ends in face 0 of 1 (property 'vertex_indices')"},
      {std::string("ply\nformat ascii 1.0\n") + kTriangleHeader +
           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n",
       "bytes follow the last element (face 1)"},
      {std::string("ply\nformat ascii 1.0\n") + kTriangleHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
       "face 0 refers to vertex -1 but the file has 3 vertices"},
      {"ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n0 0 0\n",
       "declares 1000000000 vertices"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = Write("bad_" + std::to_string(i) + ".ply", cases[i].first);
    const std::string message = ReadError(path);
    EXPECT_THAT(message, HasSubstr(path)) << "case " << i;
    EXPECT_THAT(message, HasSubstr(cases[i].second)) << "case " << i;
  }
  EXPECT_THAT(ReadError(dir_ + "/absent.ply"), HasSubstr("cannot be opened"));
}

TEST_F(PlyFiles, IsPlyFileReadsTheMagicLine) {
  EXPECT_TRUE(IsPlyFile(Write("a.ply", "ply\nformat ascii 1.0\n")));
  EXPECT_TRUE(IsPlyFile(Write("b.mesh", "ply\r\nformat ascii 1.0\r\n")));
  EXPECT_FALSE(IsPlyFile(Write("c.ply", "solid x\n")));
  EXPECT_FALSE(IsPlyFile(Write("d.ply", "plyx\n")));
  EXPECT_FALSE(IsPlyFile(Write("e.ply", "")));
  EXPECT_FALSE(IsPlyFile(dir_ + "/absent.ply"));
}

}  // namespace
}  // namespace g6d
