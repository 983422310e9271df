#pragma once
/// @file service_scene.h
/// A small service-sized scene: a textured box, a quick template bank for it (60 x 3 views
/// instead of the paper's 324) and rendered views, with solver options that keep one
/// instance well under a second on one core. Used by the service tests and the service
/// load benchmark.

#include <cstdint>
#include <functional>
#include <string>
#include <random>
#include <vector>

#include "core/executor.h"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "solver/pipeline.h"
#include "synthetic/synthetic_scene.h"
#include "templates/template_bank.h"

namespace g6d::synthetic {

/// The camera of the synthetic service scenes (LM-O-like intrinsics, 640 x 480).
inline const Camera kServiceCamera{572.4, 573.6, 325.3, 242.0, 640, 480};

/// Object id of the synthetic box in the service tests.
inline const char kBoxId[] = "box_000001";

/// A textured box, a small template bank for it and some rendered views.
struct ServiceScene {
  Mesh mesh;
  TemplateBank bank;
  std::vector<SyntheticView> views;
};

/// Template options for quick tests: fewer views than the paper's 324.
inline TemplateBuildOptions QuickTemplateOptions() {
  TemplateBuildOptions options;
  options.views.num_directions = 60;
  options.views.num_inplane = 3;
  return options;
}

/// Solver options that keep one instance well under a second on one core (K = 2, fewer
/// correspondence sets and MHPO rounds than the paper's defaults).
inline SolverOptions QuickSolverOptions() {
  SolverOptions options;
  options.num_hypotheses = 2;
  options.match.max_sets = 48;
  options.query_orb.max_features = 300;
  options.mhpo.max_rounds = 2;
  return options;
}

/// Builds the box, its bank and `num_views` views at random poses 0.5-0.8 m away.
/// Makes a template bank: BuildTemplateBank itself, or a test's shared copy of its answer.
using BankBuilder = std::function<TemplateBank(const Mesh& mesh, const std::string& object_id,
                                               const TemplateBuildOptions& options, Executor* executor)>;

inline TemplateBank BuildBank(const Mesh& mesh, const std::string& object_id, const TemplateBuildOptions& options,
                              Executor* executor) {
  return BuildTemplateBank(mesh, object_id, options, executor);
}

/// The scene of `num_views` random views; `build_bank` makes its bank (tests pass a builder
/// that shares one bank across their processes, test_bank.h).
inline ServiceScene MakeServiceScene(int num_views, uint64_t seed, const BankBuilder& build_bank = BuildBank) {
  ServiceScene scene;
  scene.mesh = MakeTexturedBox(0.10, 0.07, 0.05, 21);
  ThreadPool pool(2);
  scene.bank = build_bank(scene.mesh, kBoxId, QuickTemplateOptions(), &pool);
  GlRenderer renderer(scene.mesh);
  std::mt19937_64 rng(seed);
  for (int i = 0; i < num_views; ++i) {
    SyntheticOptions options;
    options.seed = seed + static_cast<uint64_t>(i);
    scene.views.push_back(RenderSyntheticView(&renderer, scene.mesh, kServiceCamera,
                                              RandomPose(kServiceCamera, 0.5, 0.8, &rng), options));
  }
  return scene;
}

}  // namespace g6d::synthetic
