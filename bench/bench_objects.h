#pragma once
/// @file bench_objects.h
/// The objects of a BOP dataset as the dataset benchmarks need them: the template bank and
/// the model points for ADD(-S). Header only, for g6d-bench-dataset and g6d-bench-tracking.

#include <algorithm>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "eval/bop.h"
#include "mesh/mesh.h"
#include "templates/cache.h"
#include "templates/template_bank.h"

namespace g6d::bench {

/// One object of the dataset.
struct BenchObject {
  TemplateBank bank;
  std::vector<Eigen::Vector3f> points;  ///< about 3000 model points for ADD(-S), metres
  bool symmetric = false;               ///< scored with ADD-S
  double diameter_m = 0.0;
};

/// Reads <caches>/<obj_XXXXXX>.g6dcache and the mesh of `obj_id`; ADD-S when models_info
/// says the object is symmetric or `adds_ids` names it. Throws g6d::Error as the readers do.
inline BenchObject LoadBenchObject(const BopDataset& dataset, int obj_id, const std::string& caches,
                                   const std::vector<int>& adds_ids) {
  const BopObjectInfo& info = dataset.Object(obj_id);
  BenchObject object;
  object.bank = ReadTemplateCache(caches + "/" + info.name + ".g6dcache");
  const Mesh mesh = LoadMesh(info.mesh_path, info.mesh_units);
  const size_t step = std::max<size_t>(1, mesh.vertices.size() / 3000);
  for (size_t i = 0; i < mesh.vertices.size(); i += step) object.points.push_back(mesh.vertices[i]);
  object.symmetric = info.IsSymmetric() || std::count(adds_ids.begin(), adds_ids.end(), obj_id) > 0;
  object.diameter_m = info.diameter_m;
  return object;
}

}  // namespace g6d::bench
