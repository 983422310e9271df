// Micro benchmarks of the solver's per-instance stages on a synthetic textured box
// (324 templates, a 640x480 view at 0.6 m): template matching, one MSAC-PnP set, one
// trimmed ICP, one MHPO round for one hypothesis, and EstimatePose end to end.
//   ./build/bench/g6d-bench-solver
#include <random>

#include <benchmark/benchmark.h>

#include "core/executor.h"
#include "core/se3.h"
#include "solver/pipeline.h"
#include "synthetic/synthetic_scene.h"
#include "templates/crop.h"

namespace g6d {
namespace {

const Camera kCamera{572.4114, 573.57043, 325.2611, 242.04899, 640, 480};

// Everything built once: the bank, one view and the prepared observation.
struct Fixture {
  Mesh mesh = synthetic::MakeTexturedBox(0.10, 0.07, 0.05, 21);
  TemplateBank bank;
  synthetic::SyntheticView view;
  Frame frame;
  Eigen::Isometry3d truth;
  std::vector<Feature> query;
  std::vector<CorrespondenceSet> sets;
  std::vector<Eigen::Vector3d> query_points;
  EvaluationGrid grid;
  double z_m = 0.0;

  Fixture() {
    ThreadPool pool(2);
    bank = BuildTemplateBank(mesh, "box", TemplateBuildOptions(), &pool);
    GlRenderer renderer(mesh);
    std::mt19937_64 rng(3);
    truth = synthetic::RandomPose(kCamera, 0.55, 0.65, &rng);
    view = synthetic::RenderSyntheticView(&renderer, mesh, kCamera, truth, {});
    frame.camera = kCamera;
    frame.rgb = view.rgb;
    frame.depth = view.depth;
    const NormalizedCrop crop = NormalizeCrop(frame.rgb, view.mask, bank.options.crop);
    query = DetectOrb(crop, SolverOptions().query_orb);
    MatchReport report;
    InlineExecutor inline_executor;
    MatchTemplates(MatchOptions(), query, bank, &inline_executor, &sets, &report);
    std::vector<Eigen::Vector2d> image_points;
    for (const Feature& f : query) image_points.push_back(f.xy.cast<double>() + Eigen::Vector2d::Constant(kOpenCvToImage));
    query_points = BackprojectKeypoints(kCamera, frame.depth, view.mask, image_points);
    z_m = MeanMaskedDepth(view.mask, frame.depth);
    grid = MakeEvaluationGrid(kCamera, view.mask, frame.depth, SolverOptions().refine_grid);
  }
};

Fixture& Get() {
  static Fixture* fixture = new Fixture();
  return *fixture;
}

Eigen::Isometry3d Perturbed(const Eigen::Isometry3d& pose) {
  return MakePose(ExpSO3(Eigen::Vector3d(0.08, -0.05, 0.06)), Eigen::Vector3d(0.008, -0.006, 0.012)) * pose;
}

void BM_MatchTemplates(benchmark::State& state) {
  Fixture& f = Get();
  InlineExecutor executor;
  std::vector<CorrespondenceSet> sets;
  MatchReport report;
  for (auto _ : state) {
    MatchTemplates(MatchOptions(), f.query, f.bank, &executor, &sets, &report);
    benchmark::DoNotOptimize(sets.data());
  }
  state.counters["query_features"] = static_cast<double>(f.query.size());
  state.counters["templates"] = static_cast<double>(f.bank.templates.size());
}
BENCHMARK(BM_MatchTemplates)->Unit(benchmark::kMillisecond);

void BM_EstimatePnpOneSet(benchmark::State& state) {
  Fixture& f = Get();
  PnpOptions options;
  options.minimal_solver = static_cast<PnpMinimalSolver>(state.range(0));
  PnpPrior prior;
  prior.z_m = f.z_m;
  prior.diameter_m = f.bank.diameter_m;
  prior.centre_in_object = f.bank.bounding_box.center();
  prior.query_points_in_cam = &f.query_points;
  PnpResult result;
  for (auto _ : state) {
    EstimatePnp(options, f.sets.front(), kCamera, 150.0, prior, &result);
    benchmark::DoNotOptimize(result.inliers);
  }
  state.counters["correspondences"] = static_cast<double>(f.sets.front().image_points.size());
  state.SetLabel(state.range(0) == 0 ? "opencv_usac" : state.range(0) == 1 ? "p3p" : "depth_rigid");
}
BENCHMARK(BM_EstimatePnpOneSet)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_TrimmedIcp(benchmark::State& state) {
  Fixture& f = Get();
  std::vector<Eigen::Vector3d> observed;
  for (int v = 0; v < f.frame.depth.rows; v += 2) {
    for (int u = 0; u < f.frame.depth.cols; u += 2) {
      const float z = f.frame.depth.at<float>(v, u);
      if (f.view.mask.at<uint8_t>(v, u) && z > 0) observed.push_back(kCamera.Backproject(PixelCentre(u, v), z));
    }
  }
  const PointCloudIndex index(observed);
  // 600 model points, as the pipeline uses (max_source_points); visible or not, which
  // only makes this a harder case than the pipeline's rendered visible points.
  std::vector<Eigen::Vector3d> source;
  for (const Eigen::Vector3f& p : SampleSurface(f.mesh, 600, 5)) source.push_back(p.cast<double>());
  IcpReport report;
  for (auto _ : state) {
    Eigen::Isometry3d pose = Perturbed(f.truth);
    RefineByTrimmedIcp(IcpOptions(), source, index, f.bank.diameter_m, &pose, &report);
    benchmark::DoNotOptimize(pose);
  }
  state.counters["iterations"] = report.iterations;
  state.counters["source_points"] = static_cast<double>(source.size());
  state.counters["target_points"] = static_cast<double>(observed.size());
}
BENCHMARK(BM_TrimmedIcp)->Unit(benchmark::kMillisecond);

void BM_MhpoOneRound(benchmark::State& state) {
  Fixture& f = Get();
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  MhpoOptions options;
  options.max_rounds = 1;
  options.early_stop_score = 0.0;
  InlineExecutor executor;
  Eigen::Isometry3d best;
  MhpoReport report;
  const std::vector<Eigen::Isometry3d> hypotheses = {Perturbed(f.truth)};
  for (auto _ : state) {
    RefineByMhpo(options, ScoreOptions(), target, f.bank.online_mesh, hypotheses, &executor, &best, &report);
    benchmark::DoNotOptimize(best);
  }
}
BENCHMARK(BM_MhpoOneRound)->Unit(benchmark::kMillisecond);

void BM_EstimatePose(benchmark::State& state) {
  Fixture& f = Get();
  ThreadPool pool(static_cast<int>(state.range(0)));
  const Instance instance{"box", f.view.mask};
  for (auto _ : state) {
    const PoseResult result = EstimatePose(f.frame, instance, f.bank, SolverOptions(), &pool);
    benchmark::DoNotOptimize(result.score);
  }
}
BENCHMARK(BM_EstimatePose)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace g6d

BENCHMARK_MAIN();
