#include "mesh/mesh_header.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "mesh_files.h"
#include "test_util.h"

namespace g6d {
namespace {

TEST(ReadMeshFileHeader, BinaryStlTriangleCount) {
  const std::string dir = test::TempDir("mesh_header_stl");
  test::WriteCorpusStl(dir + "/binary.stl", test::MakeCorpusBox(), /*binary=*/true);
  const MeshFileHeader binary = ReadMeshFileHeader(dir + "/binary.stl");
  EXPECT_TRUE(binary.has_triangle_count);
  EXPECT_EQ(binary.triangle_count, 12);
  EXPECT_FALSE(binary.has_bounds);
  EXPECT_EQ(binary.source, "binary STL header");

  // ASCII STL declares nothing; nor does a binary STL whose size disagrees with its count
  // (the reader decides what it is).
  test::WriteCorpusStl(dir + "/ascii.stl", test::MakeCorpusBox(), /*binary=*/false);
  EXPECT_FALSE(ReadMeshFileHeader(dir + "/ascii.stl").has_triangle_count);
  std::ofstream(dir + "/short.stl", std::ios::binary) << std::string(100, '\0');
  EXPECT_FALSE(ReadMeshFileHeader(dir + "/short.stl").has_triangle_count);
}

TEST(ReadMeshFileHeader, GlbAccessorBoundsAndCount) {
  const std::string dir = test::TempDir("mesh_header_glb");
  const test::CorpusBox box = test::MakeCorpusBox();
  test::WriteCorpusGlb(dir + "/box.glb", box);
  const MeshFileHeader header = ReadMeshFileHeader(dir + "/box.glb");
  ASSERT_TRUE(header.has_bounds);
  EXPECT_TRUE(header.bounds.min().isApprox(Eigen::Vector3d(-35, -37, -8)));
  EXPECT_TRUE(header.bounds.max().isApprox(Eigen::Vector3d(45, 23, 32)));
  EXPECT_TRUE(header.has_triangle_count);
  EXPECT_EQ(header.triangle_count, 12);
  EXPECT_EQ(header.source, "glTF accessors");
}

TEST(ReadMeshFileHeader, OtherFilesDeclareNothing) {
  const std::string dir = test::TempDir("mesh_header_other");
  test::WriteCorpusObj(dir + "/box.obj", test::MakeCorpusBox(), {});
  std::ofstream(dir + "/broken.glb", std::ios::binary) << "glTF\x02";
  for (const std::string& name : {"box.obj", "broken.glb", "absent.stl"}) {
    const MeshFileHeader header = ReadMeshFileHeader(dir + "/" + name);
    EXPECT_FALSE(header.has_triangle_count) << name;
    EXPECT_FALSE(header.has_bounds) << name;
  }
}

}  // namespace
}  // namespace g6d
