#pragma once
/// @file detect_benchmark.h
/// `g6d-bench-dataset --masks none`: the BOP localization task without masks. Per image the
/// ids of the target objects and their instance counts (test_targets_bop19.json) are all
/// that is given; DetectObjects finds them, and the answers are scored the BOP'19 way
/// (EvaluateBop: AR of VSD, MSSD, MSPD, and ADD(-S)@0.1d with the same matching; a wrong
/// answer among an object's top inst_count by confidence is a miss, as in BOP).

#include <string>
#include <vector>

#include "eval/bop.h"
#include "eval/depth_sensor.h"
#include "solver/detect.h"
#include "solver/pipeline.h"

namespace g6d::bench {

/// What the run needs.
struct DetectBenchmarkArgs {
  std::string dataset_dir;
  std::string caches_dir;
  std::string targets_file;   ///< "" = the dataset's test_targets_bop19.json
  std::vector<int> adds_ids;  ///< objects scored with ADD-S besides models_info's symmetric ones
  std::string out_csv;        ///< BOP results CSV ("" = none)
  std::string pictures_dir;   ///< DrawDetectionPicture per image, <dir>/<scene>_<im>.png ("" = none)
  int threads = 2;
  int every = 1;              ///< every N-th image only
  int limit = 0;              ///< at most this many images (0 = all)
  /// Per GT instance, where detection lost it: no region formed, not solved, or solved
  /// wrong (best IoU of the regions with its visible mask; a summary table at the end).
  bool diagnose = false;
  /// Requests for objects that are not in the image: this many per image, besides its
  /// targets (the dataset's objects without a GT instance there, taken in turn). Their
  /// answers are counted apart (an answer for an absent object is wrong; no answer is the
  /// right one) and stay out of the BOP scores. Targets of --targets FILE whose object has
  /// no GT instance in their image are absent requests too.
  int absent_requests = 0;
  /// Per answer: the features the confidence is fitted on (S_A, the frame check, the
  /// region's terms), the confidence, and whether it is right ("" = none).
  std::string records_csv;
  /// The depth the solver reads (BenchDepth): the scene's folder of that name, and a
  /// simulated sensor over it when `simulate_sensor`.
  std::string depth_folder = "depth";
  bool simulate_sensor = false;
  DepthSensorModel sensor;
  SolverOptions solver;
  DetectOptions detect;
};

/// The depth of image `im_id` of `scene` (scene id `scene_id`) as the benchmarks give it to
/// the solver: `folder` (depth/ or depth_gt/), through SimulateDepthSensor when
/// `simulate_sensor` (with the image's colours `rgb`; keyed by scene and image, so every run
/// and both benchmarks' modes see the same noise).
cv::Mat BenchDepth(const BopScene& scene, int scene_id, int im_id, const Camera& camera, const cv::Mat& rgb,
                   const std::string& folder, bool simulate_sensor, const DepthSensorModel& sensor);

/// Runs the benchmark, prints per-image lines to stderr and the tables to stdout. Returns
/// the process exit code; throws g6d::Error for bad arguments or data.
int RunDetectBenchmark(const DetectBenchmarkArgs& args);

}  // namespace g6d::bench
