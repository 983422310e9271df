#pragma once
/// @file test_meshes.h
/// Small meshes, the LM-O camera and mask/rotation helpers shared by the renderer and geometry tests.

#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "mesh/mesh.h"

namespace g6d::test {

/// The LM-O camera (camera.json): 640x480.
inline Camera LmoCamera() { return Camera{572.4114, 573.57043, 325.2611, 242.04899, 640, 480}; }

/// Rotation of `angle_rad` about `axis` (need not be unit length).
inline Eigen::Matrix3d AxisAngle(double angle_rad, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
}

/// IoU of two 0/255 masks; 1 when both are empty.
inline double MaskIoU(const cv::Mat& a, const cv::Mat& b) {
  const double intersection = cv::countNonZero(a & b);
  const double union_count = cv::countNonZero(a | b);
  return union_count > 0 ? intersection / union_count : 1.0;
}

// Axis-aligned cube centred at the origin, counter-clockwise faces seen from outside.
inline Mesh MakeCube(double half_size_m) {
  Mesh mesh;
  const float h = static_cast<float>(half_size_m);
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.emplace_back((i & 1) ? h : -h, (i & 2) ? h : -h, (i & 4) ? h : -h);
  }
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh.faces.emplace_back(q[0], q[1], q[2]);
    mesh.faces.emplace_back(q[0], q[2], q[3]);
  }
  return mesh;
}

// UV sphere centred at the origin with outward counter-clockwise faces and vertex normals.
inline Mesh MakeUvSphere(double radius_m, int stacks, int slices) {
  Mesh mesh;
  mesh.vertices.emplace_back(0.0f, 0.0f, 1.0f);
  for (int i = 1; i < stacks; ++i) {
    const double theta = M_PI * i / stacks;
    for (int j = 0; j < slices; ++j) {
      const double phi = 2.0 * M_PI * j / slices;
      mesh.vertices.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                 std::cos(theta));
    }
  }
  const int south = static_cast<int>(mesh.vertices.size());
  mesh.vertices.emplace_back(0.0f, 0.0f, -1.0f);
  auto ring = [&](int i, int j) { return 1 + (i - 1) * slices + (j % slices); };
  for (int j = 0; j < slices; ++j) mesh.faces.emplace_back(0, ring(1, j), ring(1, j + 1));
  for (int i = 1; i + 1 < stacks; ++i) {
    for (int j = 0; j < slices; ++j) {
      mesh.faces.emplace_back(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
      mesh.faces.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
    }
  }
  for (int j = 0; j < slices; ++j) {
    mesh.faces.emplace_back(south, ring(stacks - 1, j + 1), ring(stacks - 1, j));
  }
  for (auto& v : mesh.vertices) {
    mesh.normals.push_back(v.normalized());
    v = v.normalized() * static_cast<float>(radius_m);
  }
  return mesh;
}

/// An ASCII PLY box of half sizes `half_mm` (millimetres) centred at the origin, each side
/// split into cells x cells quads of random vertex colours, faces counter-clockwise seen
/// from outside.
inline void WriteColouredBoxPly(const std::string& path, const Eigen::Vector3d& half_mm, int cells,
                                uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> colour(15, 240);
  std::vector<std::string> vertex_lines, face_lines;
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign : {1, -1}) {
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      for (int i = 0; i < cells; ++i) {
        for (int j = 0; j < cells; ++j) {
          const int red = colour(rng), green = colour(rng), blue = colour(rng);
          const int base = static_cast<int>(vertex_lines.size());
          const int corner_i[4] = {0, 1, 1, 0}, corner_j[4] = {0, 0, 1, 1};
          for (int k = 0; k < 4; ++k) {
            Eigen::Vector3d point;
            point[axis] = sign * half_mm[axis];
            point[a] = half_mm[a] * (-1.0 + 2.0 * (i + corner_i[k]) / cells);
            point[b] = half_mm[b] * (-1.0 + 2.0 * (j + corner_j[k]) / cells);
            vertex_lines.push_back(std::to_string(point.x()) + " " + std::to_string(point.y()) +
                                   " " + std::to_string(point.z()) + " " + std::to_string(red) +
                                   " " + std::to_string(green) + " " + std::to_string(blue));
          }
          // (a, b, axis) is right-handed, so a -> b is counter-clockwise seen from +axis.
          const std::string v0 = std::to_string(base), v1 = std::to_string(base + 1),
                            v2 = std::to_string(base + 2), v3 = std::to_string(base + 3);
          if (sign > 0) {
            face_lines.push_back("3 " + v0 + " " + v1 + " " + v2);
            face_lines.push_back("3 " + v0 + " " + v2 + " " + v3);
          } else {
            face_lines.push_back("3 " + v0 + " " + v2 + " " + v1);
            face_lines.push_back("3 " + v0 + " " + v3 + " " + v2);
          }
        }
      }
    }
  }
  std::ofstream out(path);
  out << "ply\nformat ascii 1.0\nelement vertex " << vertex_lines.size()
      << "\nproperty float x\nproperty float y\nproperty float z\n"
         "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face "
      << face_lines.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const std::string& line : vertex_lines) out << line << "\n";
  for (const std::string& line : face_lines) out << line << "\n";
}

}  // namespace g6d::test
