// Cost of one service debug picture (--debug-images) on a 640x480 frame: drawing (render
// each answer's silhouette with the CPU rasterizer, contour, axes, labels), JPEG encoding
// (quality 80, the service's default), and both, with 1 and 5 answered objects. The
// objects are the sample's (their online meshes from the template caches), at fixed
// seeded poses 0.55-0.7 m in front of the camera; the canvas is a sample image.
//
//   g6d-bench-debug-image --caches=out/demo/sample/caches
//       [--rgb=out/demo/sample/test/000001/rgb/000000.png] [--benchmark_filter=...]
//
// Skips (prints why) when the caches are absent (make them with g6d-make-sample).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "templates/cache.h"
#include "wire/debug_image.h"

namespace g6d {
namespace {

const Camera kCamera{572.4, 573.6, 325.3, 242.0, 640, 480};
constexpr int kJpegQuality = 80;  // DebugImageOptions::jpeg_quality's default

// The value of `--name=value` in argv (removed from it), or `fallback`.
std::string TakeFlag(int* argc, char** argv, const std::string& name, const std::string& fallback) {
  const std::string prefix = "--" + name + "=";
  for (int i = 1; i < *argc; ++i) {
    const std::string argument = argv[i];
    if (argument.rfind(prefix, 0) != 0) continue;
    std::copy(argv + i + 1, argv + *argc, argv + i);
    --*argc;
    return argument.substr(prefix.size());
  }
  return fallback;
}

// An answered frame of `count` objects (the banks cycled), in a row across the image at
// seeded random orientations.
DebugImageInput MakeInput(const std::vector<std::shared_ptr<const TemplateBank>>& banks,
                          const cv::Mat& rgb, int count) {
  DebugImageInput input;
  input.camera = kCamera;
  input.rgb = rgb;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int i = 0; i < count; ++i) {
    const TemplateBank& bank = *banks[i % banks.size()];
    const Eigen::Quaterniond rotation =
        Eigen::Quaterniond(1.0, unit(rng), unit(rng), unit(rng)).normalized();
    pose_estimate_t estimate{};
    estimate.object_id = bank.object_id;
    estimate.status = pose_estimate_t::STATUS_OK;
    estimate.message = "ok";
    estimate.position[0] = -0.24 + 0.12 * i;
    estimate.position[1] = 0.02 * (i % 2);
    estimate.position[2] = 0.55 + 0.03 * i;
    estimate.orientation[0] = rotation.w();
    estimate.orientation[1] = rotation.x();
    estimate.orientation[2] = rotation.y();
    estimate.orientation[3] = rotation.z();
    estimate.score = 0.05;
    estimate.confidence = 0.9;
    input.answer.estimates.push_back(estimate);
    DecodedInstance instance;
    instance.object_id = bank.object_id;
    input.instances.push_back(instance);
    input.banks[bank.object_id] = banks[i % banks.size()];
  }
  input.answer.num_estimates = count;
  return input;
}

void BM_Draw(benchmark::State& state, const DebugImageInput* input) {
  for (auto _ : state) benchmark::DoNotOptimize(DrawDebugImage(*input, OverlayStyle()));
}

void BM_Jpeg(benchmark::State& state, const DebugImageInput* input) {
  const cv::Mat picture = DrawDebugImage(*input, OverlayStyle());
  size_t bytes = 0;
  for (auto _ : state) bytes = MakeBotCoreJpeg(picture, kJpegQuality, 0).data.size();
  state.counters["jpeg_kB"] = static_cast<double>(bytes) / 1000.0;
}

void BM_DrawAndJpeg(benchmark::State& state, const DebugImageInput* input) {
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        MakeBotCoreJpeg(DrawDebugImage(*input, OverlayStyle()), kJpegQuality, 0));
  }
}

}  // namespace
}  // namespace g6d

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  const std::string caches = g6d::TakeFlag(&argc, argv, "caches", "out/demo/sample/caches");
  const std::string rgb_path = g6d::TakeFlag(&argc, argv, "rgb", "");
  benchmark::Initialize(&argc, argv);
  std::vector<std::shared_ptr<const g6d::TemplateBank>> banks;
  if (fs::is_directory(caches)) {
    std::vector<std::string> files;
    for (const auto& entry : fs::directory_iterator(caches))
      if (entry.path().extension() == ".g6dcache") files.push_back(entry.path().string());
    std::sort(files.begin(), files.end());
    for (const std::string& file : files)
      banks.push_back(std::make_shared<g6d::TemplateBank>(g6d::ReadTemplateCache(file)));
  }
  if (banks.empty()) {
    std::fprintf(stderr,
                 "no .g6dcache under %s (make the sample: g6d-make-sample --out out/demo/sample): "
                 "nothing to benchmark\n",
                 caches.c_str());
    return 0;
  }
  cv::Mat rgb(g6d::kCamera.height, g6d::kCamera.width, CV_8UC3, cv::Scalar(150, 120, 90));
  if (!rgb_path.empty()) {
    const cv::Mat bgr = cv::imread(rgb_path, cv::IMREAD_COLOR);
    if (bgr.size() != rgb.size()) {
      std::fprintf(stderr, "--rgb %s: not a 640x480 colour image\n", rgb_path.c_str());
      return 2;
    }
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  }
  static std::vector<g6d::DebugImageInput> inputs;
  inputs.reserve(2);
  for (const int count : {1, 5}) inputs.push_back(g6d::MakeInput(banks, rgb, count));
  for (const g6d::DebugImageInput& input : inputs) {
    const std::string objects = "/objects:" + std::to_string(input.answer.estimates.size());
    benchmark::RegisterBenchmark(("DebugImage/draw" + objects).c_str(), g6d::BM_Draw, &input)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("DebugImage/jpeg" + objects).c_str(), g6d::BM_Jpeg, &input)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("DebugImage/draw_and_jpeg" + objects).c_str(),
                                 g6d::BM_DrawAndJpeg, &input)
        ->Unit(benchmark::kMillisecond);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
