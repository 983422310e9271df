#include "templates/ppf_model.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <unordered_map>

#include "core/error.h"

namespace g6d {

namespace {

constexpr float kPi = 3.14159265358979f;

// Voxel key of a point (21 bits per axis, offset so that negative cells fit).
uint64_t VoxelKey(const Eigen::Vector3f& p, float inverse_step) {
  auto cell = [&](float v) { return static_cast<uint64_t>(static_cast<int64_t>(std::floor(v * inverse_step)) + (1 << 20)) & 0x1FFFFF; };
  return (cell(p.x()) << 42) | (cell(p.y()) << 21) | cell(p.z());
}

float SafeAngle(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  // atan2 of |a x b| and a.b: accurate near 0 and pi, unlike acos.
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace

std::string PpfModelOptions::Check() const {
  std::ostringstream out;
  if (!(step_fraction >= 0.01 && step_fraction <= 0.5)) {
    out << "ppf.step_fraction must be in [0.01, 0.5] (got " << step_fraction << ")";
  } else if (!(angle_step_deg >= 2.0 && angle_step_deg <= 45.0)) {
    out << "ppf.angle_step_deg must be in [2, 45] (got " << angle_step_deg << ")";
  } else if (!(normal_cluster_deg > 0.0 && normal_cluster_deg <= 180.0)) {
    out << "ppf.normal_cluster_deg must be in (0, 180] (got " << normal_cluster_deg << ")";
  } else if (surface_samples < 100 || surface_samples > 10000000) {
    out << "ppf.surface_samples must be in 100..10000000 (got " << surface_samples << ")";
  } else if (max_points < 10 || max_points > 60000) {
    out << "ppf.max_points must be in 10..60000 (got " << max_points << ")";
  }
  return out.str();
}

int16_t PpfAngleUnits(float radians) {
  const float turns = radians / (2.0f * kPi);
  const float wrapped = turns - std::floor(turns + 0.5f);  // [-0.5, 0.5)
  return static_cast<int16_t>(std::lround(wrapped * 65536.0f) & 0xFFFF);
}

Eigen::Isometry3f PpfReferenceFrame(const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
  // The rotation that takes n onto +x, about the axis n x x (any axis when n = -x).
  const Eigen::Vector3f x = Eigen::Vector3f::UnitX();
  Eigen::Matrix3f rotation;
  const float c = n.dot(x);
  const Eigen::Vector3f axis = n.cross(x);
  const float s = axis.norm();
  if (s < 1e-6f) {
    rotation = c > 0 ? Eigen::Matrix3f::Identity() : Eigen::Matrix3f(Eigen::AngleAxisf(kPi, Eigen::Vector3f::UnitY()));
  } else {
    rotation = Eigen::AngleAxisf(std::atan2(s, c), axis / s).toRotationMatrix();
  }
  Eigen::Isometry3f reference_from_object = Eigen::Isometry3f::Identity();
  reference_from_object.linear() = rotation;
  reference_from_object.translation() = -(rotation * p);
  return reference_from_object;
}

float PpfAlpha(const Eigen::Vector3f& q_in_reference) {
  // Turning by alpha about +x takes (y, z) to (y c - z s, y s + z c); z' = 0, y' > 0 at
  // alpha = atan2(-z, y).
  return std::atan2(-q_in_reference.z(), q_in_reference.y());
}

Eigen::Vector4f PpfFeature(const Eigen::Vector3f& p1, const Eigen::Vector3f& n1, const Eigen::Vector3f& p2,
                           const Eigen::Vector3f& n2) {
  const Eigen::Vector3f d = p2 - p1;
  return Eigen::Vector4f(d.norm(), SafeAngle(n1, d), SafeAngle(n2, d), SafeAngle(n1, n2));
}

void VoxelReduceOriented(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& normals,
                         double step_m, double normal_cluster_deg, std::vector<Eigen::Vector3f>* reduced_points,
                         std::vector<Eigen::Vector3f>* reduced_normals) {
  reduced_points->clear();
  reduced_normals->clear();
  const float inverse_step = static_cast<float>(1.0 / step_m);
  const float cos_cluster = static_cast<float>(std::cos(normal_cluster_deg * M_PI / 180.0));
  // Per voxel, its clusters in the order their first point came; voxels in first-seen order
  // too, so the result depends only on the input order.
  struct Cluster {
    Eigen::Vector3f point_sum = Eigen::Vector3f::Zero();
    Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
    Eigen::Vector3f first_normal = Eigen::Vector3f::Zero();
    int count = 0;
    int next = -1;  // next cluster of the same voxel
  };
  std::vector<Cluster> clusters;
  std::unordered_map<uint64_t, int> first_cluster;
  first_cluster.reserve(points.size() / 4 + 16);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& n = normals[i];
    auto [it, inserted] = first_cluster.try_emplace(VoxelKey(points[i], inverse_step), static_cast<int>(clusters.size()));
    int index = it->second;
    int last = -1;
    if (!inserted) {
      while (index >= 0 && clusters[static_cast<size_t>(index)].first_normal.dot(n) < cos_cluster) {
        last = index;
        index = clusters[static_cast<size_t>(index)].next;
      }
    }
    if (inserted || index < 0) {
      index = static_cast<int>(clusters.size());
      clusters.emplace_back();
      clusters.back().first_normal = n;
      if (last >= 0) clusters[static_cast<size_t>(last)].next = index;
    }
    Cluster& cluster = clusters[static_cast<size_t>(index)];
    cluster.point_sum += points[i];
    cluster.normal_sum += n;
    ++cluster.count;
  }
  reduced_points->reserve(clusters.size());
  reduced_normals->reserve(clusters.size());
  for (const Cluster& cluster : clusters) {
    const float length = cluster.normal_sum.norm();
    if (!(length > 1e-6f)) continue;
    reduced_points->push_back(cluster.point_sum / static_cast<float>(cluster.count));
    reduced_normals->push_back(cluster.normal_sum / length);
  }
}

PpfModel BuildPpfModel(const Mesh& mesh, double diameter_m, const PpfModelOptions& options) {
  if (std::string problem = options.Check(); !problem.empty()) G6D_THROW("BuildPpfModel: " << problem);
  if (!(diameter_m > 0.0)) G6D_THROW("BuildPpfModel: diameter must be positive (got " << diameter_m << ")");
  // Area-weighted samples with their face's outward normal (counter-clockwise winding).
  std::vector<double> cumulative_area;
  std::vector<Eigen::Vector3f> face_normals;
  cumulative_area.reserve(mesh.faces.size());
  double total_area = 0.0;
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Eigen::Vector3f a = mesh.vertices[static_cast<size_t>(f[0])], b = mesh.vertices[static_cast<size_t>(f[1])],
                          c = mesh.vertices[static_cast<size_t>(f[2])];
    const Eigen::Vector3f cross = (b - a).cross(c - a);
    const double area = 0.5 * cross.norm();
    total_area += std::isfinite(area) ? area : 0.0;
    cumulative_area.push_back(total_area);
    face_normals.push_back(cross.norm() > 0 ? Eigen::Vector3f(cross.normalized()) : Eigen::Vector3f::Zero());
  }
  if (!(total_area > 0.0)) G6D_THROW("BuildPpfModel: the mesh has no area");
  std::mt19937 random(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Eigen::Vector3f> samples, sample_normals;
  samples.reserve(static_cast<size_t>(options.surface_samples));
  sample_normals.reserve(static_cast<size_t>(options.surface_samples));
  for (int k = 0; k < options.surface_samples; ++k) {
    const double target = uniform(random) * total_area;
    const size_t face = static_cast<size_t>(std::lower_bound(cumulative_area.begin(), cumulative_area.end(), target) -
                                            cumulative_area.begin());
    const size_t f = std::min(face, mesh.faces.size() - 1);
    if (face_normals[f].isZero()) continue;
    double u = uniform(random), v = uniform(random);
    if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
    const Eigen::Vector3i& tri = mesh.faces[f];
    const Eigen::Vector3f a = mesh.vertices[static_cast<size_t>(tri[0])], b = mesh.vertices[static_cast<size_t>(tri[1])],
                          c = mesh.vertices[static_cast<size_t>(tri[2])];
    samples.push_back(a + static_cast<float>(u) * (b - a) + static_cast<float>(v) * (c - a));
    sample_normals.push_back(face_normals[f]);
  }
  PpfModel model;
  model.options = options;
  model.step_m = options.step_fraction * diameter_m;
  for (;;) {
    VoxelReduceOriented(samples, sample_normals, model.step_m, options.normal_cluster_deg, &model.points, &model.normals);
    if (static_cast<int>(model.points.size()) <= options.max_points) break;
    model.step_m *= 1.1;  // too many points for the budget: a coarser step
  }
  DerivePpfTable(&model);
  return model;
}

void DerivePpfTable(PpfModel* model) {
  const size_t n = model->points.size();
  model->offsets.clear();
  model->entries.clear();
  model->reference_from_object.clear();
  model->max_distance_m = 0.0;
  model->distance_bins = model->angle_bins = model->alpha_bins = 0;
  if (n == 0 || !(model->step_m > 0.0)) return;  // no model: nothing to look up
  model->angle_bins = std::max(1, static_cast<int>(std::ceil(180.0 / model->options.angle_step_deg - 1e-9)));
  model->alpha_bins = 2 * model->angle_bins;
  model->reference_from_object.resize(n);
  float max_distance = 0.0f;
  for (size_t r = 0; r < n; ++r) {
    model->reference_from_object[r] = PpfReferenceFrame(model->points[r], model->normals[r]);
    for (size_t i = r + 1; i < n; ++i) max_distance = std::max(max_distance, (model->points[i] - model->points[r]).norm());
  }
  model->max_distance_m = max_distance;
  model->distance_bins = static_cast<int>(std::floor(max_distance / model->step_m)) + 1;
  const int keys = model->distance_bins * model->angle_bins * model->angle_bins * model->angle_bins;
  const float inverse_distance = static_cast<float>(1.0 / model->step_m);
  const float inverse_angle = static_cast<float>(model->angle_bins / M_PI);
  auto key_of = [&](size_t r, size_t i) {
    const Eigen::Vector4f f = PpfFeature(model->points[r], model->normals[r], model->points[i], model->normals[i]);
    auto angle_bin = [&](float a) { return std::min(model->angle_bins - 1, static_cast<int>(a * inverse_angle)); };
    return model->Key(static_cast<int>(f[0] * inverse_distance), angle_bin(f[1]), angle_bin(f[2]), angle_bin(f[3]));
  };
  // Counting sort of the ordered pairs by key.
  std::vector<int> pair_keys(n * n, -1);
  model->offsets.assign(static_cast<size_t>(keys) + 1, 0);
  for (size_t r = 0; r < n; ++r) {
    for (size_t i = 0; i < n; ++i) {
      if (i == r) continue;
      const int key = key_of(r, i);
      pair_keys[r * n + i] = key;
      if (key >= 0) ++model->offsets[static_cast<size_t>(key) + 1];
    }
  }
  for (size_t k = 1; k < model->offsets.size(); ++k) model->offsets[k] += model->offsets[k - 1];
  model->entries.assign(model->offsets.back(), PpfEntry{});
  std::vector<uint32_t> fill(model->offsets.begin(), model->offsets.end() - 1);
  for (size_t r = 0; r < n; ++r) {
    for (size_t i = 0; i < n; ++i) {
      const int key = pair_keys[r * n + i];
      if (key < 0) continue;
      const Eigen::Vector3f q = model->reference_from_object[r] * model->points[i];
      model->entries[fill[static_cast<size_t>(key)]++] = PpfEntry{static_cast<uint16_t>(r), PpfAngleUnits(PpfAlpha(q))};
    }
  }
}

}  // namespace g6d
