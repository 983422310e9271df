// Speed of the CPU rasterizer (mask + depth, with and without face ids; with back-face
// culling for reference) on the LM-O meshes decimated to 4000 faces, at 128x128 (object
// filling the crop) and 640x480 (object at 0.8 m); plus the OSMesa renderer at 640x480.
// Skips (prints why) when the shared data is absent.
//
//   g6d-bench-raster [--benchmark_filter=...]

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "render/raster.h"

namespace g6d {
namespace {

constexpr int kTargetFaces = 4000;
constexpr int kCropSide = 128;
const int kLmoObjectIds[] = {1, 5, 6, 8, 9, 10, 11, 12};

// The LM-O camera (camera.json).
Camera LmoCamera() { return Camera{572.4114, 573.57043, 325.2611, 242.04899, 640, 480}; }

// Views of one object: 64 seeded random rotations at 0.8 m. Cycling through different
// poses matters: repeating one pose lets the branch predictor learn that pose's pixel
// pattern and reports up to 3x too optimistic times.
struct View {
  Eigen::Isometry3d cam_from_object;
  Camera crop;  // 128x128 camera around the object's silhouette in this view
};

// A 128x128 camera whose image is the object's bounding box (plus 10%), as the online
// stages crop and rescale around a hypothesis.
Camera CropCamera(const Mesh& mesh, const Camera& full, const Eigen::Isometry3d& pose) {
  RasterImage image;
  RasterOptions options;
  options.want_face_id = false;
  Rasterize(mesh, full, pose, options, &image);
  const cv::Rect box = cv::boundingRect(image.Mask());
  const double side = 1.1 * std::max(box.width, box.height);
  const double x0 = box.x + 0.5 * box.width - 0.5 * side;
  const double y0 = box.y + 0.5 * box.height - 0.5 * side;
  const double scale = kCropSide / side;
  Camera crop = full;
  crop.fx *= scale;
  crop.fy *= scale;
  crop.cx = (full.cx - x0) * scale;
  crop.cy = (full.cy - y0) * scale;
  crop.width = crop.height = kCropSide;
  return crop;
}

std::vector<View> MakeViews(const Mesh& mesh, const Camera& full) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<View> views;
  for (int i = 0; i < 64; ++i) {
    View view;
    view.cam_from_object = Eigen::Isometry3d::Identity();
    view.cam_from_object.linear() =
        Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng))
            .normalized()
            .toRotationMatrix();
    view.cam_from_object.translation() = Eigen::Vector3d(0.03, -0.02, 0.8);
    view.crop = CropCamera(mesh, full, view.cam_from_object);
    views.push_back(view);
  }
  return views;
}

struct BenchObject {
  int obj_id = 0;
  Mesh mesh;  // decimated
  std::vector<View> views;
};

void BM_Rasterize(benchmark::State& state, const BenchObject* object, bool crop, bool want_face_id,
                  bool cull_backfaces) {
  const Camera full = LmoCamera();
  RasterOptions options;
  options.want_face_id = want_face_id;
  options.cull_backfaces = cull_backfaces;
  RasterImage image;  // reused, as callers do
  size_t i = 0;
  int64_t pixels = 0;
  for (auto _ : state) {
    const View& view = object->views[i++ % object->views.size()];
    Rasterize(object->mesh, crop ? view.crop : full, view.cam_from_object, options, &image);
    benchmark::DoNotOptimize(image.depth.data);
    pixels += image.pixel_count;
  }
  state.counters["faces"] = static_cast<double>(object->mesh.faces.size());
  state.counters["pixels"] = static_cast<double>(pixels) / std::max<int64_t>(1, state.iterations());
}

void BM_GlRender(benchmark::State& state, const BenchObject* object) {
  const Camera full = LmoCamera();
  GlRenderer renderer(object->mesh);
  size_t i = 0;
  for (auto _ : state) {
    const View& view = object->views[i++ % object->views.size()];
    GlImage image = renderer.Render(full, view.cam_from_object);
    benchmark::DoNotOptimize(image.depth.data);
  }
  state.counters["faces"] = static_cast<double>(object->mesh.faces.size());
}

}  // namespace
}  // namespace g6d

int main(int argc, char** argv) {
  using namespace g6d;
  benchmark::Initialize(&argc, argv);
  const std::filesystem::path models = std::filesystem::path(G6D_SHARED_DATA_DIR) / "lmo/models";
  static std::vector<std::unique_ptr<BenchObject>> objects;  // outlives the benchmarks
  for (const int obj_id : kLmoObjectIds) {
    char name[32];
    std::snprintf(name, sizeof(name), "obj_%06d.ply", obj_id);
    const std::filesystem::path path = models / name;
    if (!std::filesystem::exists(path)) {
      std::fprintf(stderr, "skipping obj %d: shared data '%s' is absent\n", obj_id,
                   path.string().c_str());
      continue;
    }
    auto object = std::make_unique<BenchObject>();
    object->obj_id = obj_id;
    object->mesh = Decimate(LoadMesh(path.string(), Units::kMillimetres), kTargetFaces);
    objects.push_back(std::move(object));
  }
  if (objects.empty()) {
    std::fprintf(stderr, "no LM-O meshes under %s: nothing to benchmark\n",
                 models.string().c_str());
    return 0;
  }
  const Camera full = LmoCamera();
  for (auto& object : objects) object->views = MakeViews(object->mesh, full);
  for (const auto& object : objects) {
    const BenchObject* o = object.get();
    const std::string id = "obj" + std::to_string(o->obj_id);
    for (const bool crop : {true, false}) {
      const std::string size = crop ? "128x128/" : "640x480/";
      for (const bool face_id : {false, true}) {
        benchmark::RegisterBenchmark(
            ("Rasterize/" + size + id + (face_id ? "/face_id" : "/no_face_id")).c_str(),
            BM_Rasterize, o, crop, face_id, false)
            ->Unit(benchmark::kMicrosecond);
      }
    }
    benchmark::RegisterBenchmark(("Rasterize/128x128/" + id + "/face_id_culled").c_str(),
                                 BM_Rasterize, o, true, true, true)
        ->Unit(benchmark::kMicrosecond);
    // llvmpipe rasterizes on its own threads: wall time is what counts.
    benchmark::RegisterBenchmark(("GlRender/640x480/" + id).c_str(), BM_GlRender, o)
        ->Unit(benchmark::kMicrosecond)
        ->UseRealTime();
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
