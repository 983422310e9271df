// g6d-make-sample: the embedded default. Writes, from nothing but the project's own code,
// procedurally textured objects (OBJ + MTL + PNG), a short RGB-D sequence of them on a
// table as a BOP dataset with ground truth, their template caches and an LCM log of the
// sequence, ready for g6d-service + g6d-replay:
//
//   g6d-make-sample --out out/demo/sample [--frames 12] [--seed 1] [--objects 3]
//       [--fps 10] [--views 324] [--threads 2] [--no-caches] [--no-log] [--reuse]
//       [--sequence [--abrupt-frame N]]
//
// Every image has its own arrangement and camera. With --sequence (for testing object
// tracking; --frames defaults to 90 and --fps to 30 there) one arrangement holds for the
// whole sequence, the camera orbits the objects smoothly at --fps (an azimuth sweep of
// 40-70 degrees with gentle changes of elevation and distance, at most 0.3 m/s and
// 30 deg/s), and object 2 (the last when fewer) jumps once, at image --abrupt-frame
// (default frames / 2, -1 = never), by 6-12 cm and 60-120 degrees about the table normal.
// sample.json then records "sequence": true, "abrupt_frame" and "abrupt_obj_id".
//
// Layout of --out (BOP, plus the g6d parts):
//   models/        obj_00000N.obj/.mtl/.png, models_info.json (`mesh`, `units` = "m")
//   test/000001/   rgb/, depth/ (uint16, depth_scale 0.1 mm), mask/, mask_visib/,
//                  scene_gt.json, scene_camera.json, scene_gt_info.json
//   camera.json, test_targets_bop19.json
//   caches/        obj_00000N.g6dcache (as g6d-build-templates would write them)
//   sample.lcmlog  g6d_rgbd_frame_t on G6D_RGBD, one event per image (as g6d-bop2lcm)
//   sample.json    what was written and with which options; written last
// A non-empty folder that g6d-make-sample did not write is refused, never overwritten.
// The same seed and options give the same files. --reuse leaves a folder alone whose
// sample.json records the same options, was written by this very binary, and whose files
// are all there.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "bop_to_lcm.h"
#include "core/error.h"
#include "core/executor.h"
#include "core/hash.h"
#include "core/timer.h"
#include "eval/bop.h"
#include "sample/sample_scene.h"
#include "templates/template_bank.h"

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr int kManifestFormat = 1;
constexpr const char* kManifestName = "sample.json";
// Marks a folder as written by this tool from the first step on (sample.json only comes at
// the end), so an interrupted run can be redone while a foreign folder is never overwritten.
constexpr const char* kMarkerName = ".g6d-sample";
constexpr const char* kLogName = "sample.lcmlog";
constexpr const char* kCacheFolder = "caches";

// Everything the tool was asked for that changes the output.
struct ToolOptions {
  g6d::SampleOptions sample;
  int views = 324;
  int inplane = 3;
  double fps = 10.0;
  bool caches = true;
  bool log = true;
};

Json OptionsJson(const ToolOptions& o) {
  Json options = {{"frames", o.sample.num_frames},
                  {"seed", o.sample.seed},
                  {"objects", o.sample.num_objects},
                  {"depth_noise_mm", o.sample.depth_noise_m * 1000.0},
                  {"min_visible", o.sample.min_visible_fraction},
                  {"views", o.views},
                  {"inplane", o.inplane},
                  {"fps", o.fps},
                  {"caches", o.caches},
                  {"log", o.log}};
  // Only in sequence mode, so that the classic sample's manifest stays as it was.
  if (o.sample.sequence.enabled) {
    options["sequence"] = true;
    options["abrupt_frame"] = o.sample.sequence.abrupt_frame;
  }
  return options;
}

// The files a complete sample folder holds.
std::vector<fs::path> ExpectedFiles(const fs::path& out, const ToolOptions& o,
                                    const Json& manifest) {
  std::vector<fs::path> files = {out / "camera.json",
                                 out / "test_targets_bop19.json",
                                 out / "models" / "models_info.json",
                                 out / "test" / "000001" / "scene_gt.json",
                                 out / "test" / "000001" / "scene_camera.json",
                                 out / "test" / "000001" / "scene_gt_info.json"};
  for (const Json& object : manifest.value("objects", Json::array())) {
    const std::string name = object.value("name", "");
    files.push_back(out / "models" / (name + ".obj"));
    if (o.caches) files.push_back(out / kCacheFolder / (name + ".g6dcache"));
  }
  if (o.log) files.push_back(out / kLogName);
  return files;
}

// True when `out` already holds this sample, written by this binary.
bool IsCurrent(const fs::path& out, const ToolOptions& o, const std::string& generator_hash) {
  std::ifstream in(out / kManifestName);
  if (!in) return false;
  Json manifest;
  try {
    in >> manifest;
  } catch (const Json::exception&) {
    return false;
  }
  if (manifest.value("format", 0) != kManifestFormat ||
      manifest.value("generator_hash", "") != generator_hash ||
      manifest.value("options", Json()) != OptionsJson(o)) {
    return false;
  }
  const std::vector<fs::path> files = ExpectedFiles(out, o, manifest);
  return std::all_of(files.begin(), files.end(),
                     [](const fs::path& f) { return fs::is_regular_file(f); });
}

// True when g6d-make-sample wrote `out` (its marker, or a manifest naming it).
bool IsSampleFolder(const fs::path& out) {
  if (fs::exists(out / kMarkerName)) return true;
  std::ifstream in(out / kManifestName);
  if (!in) return false;
  try {
    Json manifest;
    in >> manifest;
    return manifest.value("generator", "") == "g6d-make-sample";
  } catch (const Json::exception&) {
    return false;
  }
}

void WriteText(const fs::path& path, const std::string& text) {
  const fs::path temporary = path.string() + ".tmp";
  {
    std::ofstream out(temporary);
    out << text;
    out.close();
    if (!out) G6D_THROW("cannot write '" << temporary.string() << "'");
  }
  fs::rename(temporary, path);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "g6d-make-sample: write the embedded sample (textured objects, an RGB-D sequence with ground "
      "truth as a "
      "BOP dataset, template caches, an LCM log) from the project's own code"};
  ToolOptions o;
  std::string out_text;
  int threads = 2;
  bool reuse = false, no_caches = false, no_log = false;
  double depth_noise_mm = o.sample.depth_noise_m * 1000.0;
  app.add_option(
         "--out", out_text,
         "output folder (created; a sample in it is replaced, any other non-empty folder refused)")
      ->required();
  CLI::Option* frames_option =
      app.add_option("--frames", o.sample.num_frames, "images in the sequence (--sequence: 90)")
          ->capture_default_str()
          ->check(CLI::Range(1, 10000));
  app.add_option("--seed", o.sample.seed, "seed of every random choice")->capture_default_str();
  app.add_option("--objects", o.sample.num_objects,
                 "objects: 1 box, 2 + cylinder, 3 + triangular prism")
      ->capture_default_str()
      ->check(CLI::Range(1, 3));
  CLI::Option* fps_option =
      app.add_option(
             "--fps", o.fps,
             "frame rate of the log timestamps (and of the camera path), Hz (--sequence: 30)")
          ->capture_default_str();
  int abrupt_frame = -1;
  bool sequence = false;
  app.add_flag("--sequence", sequence,
               "one arrangement, a smooth camera orbit and one object jumping once (tracking)");
  CLI::Option* abrupt_option = app.add_option(
      "--abrupt-frame", abrupt_frame,
      "--sequence: image (0-based) at which object 2 jumps; default frames / 2, -1 = never");
  app.add_option("--views", o.views, "templates per object cache N_T (multiple of --inplane)")
      ->capture_default_str();
  app.add_option("--inplane", o.inplane, "in-plane rotations per viewing direction of the caches")
      ->capture_default_str();
  app.add_option("--depth-noise-mm", depth_noise_mm, "Gaussian depth noise sigma, mm")
      ->capture_default_str();
  app.add_option("--min-visible", o.sample.min_visible_fraction,
                 "every object at least this visible in every image (fraction)")
      ->capture_default_str();
  app.add_option("--threads", threads, "threads for the template caches")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  app.add_flag("--no-caches", no_caches, "do not build the template caches");
  app.add_flag("--no-log", no_log, "do not write the LCM log");
  app.add_flag("--reuse", reuse,
               "do nothing when --out already holds this sample from this binary");
  CLI11_PARSE(app, argc, argv);
  o.caches = !no_caches;
  o.log = !no_log;
  o.sample.depth_noise_m = depth_noise_mm / 1000.0;

  try {
    const g6d::Stopwatch watch;
    if (sequence) {
      // A tracking sequence wants more and denser images than the classic sample.
      constexpr int kSequenceFrames = 90;
      constexpr double kSequenceFps = 30.0;
      if (frames_option->count() == 0) o.sample.num_frames = kSequenceFrames;
      if (fps_option->count() == 0) o.fps = kSequenceFps;
      o.sample.sequence.enabled = true;
      o.sample.sequence.fps = o.fps;
      o.sample.sequence.abrupt_frame = abrupt_option->count() > 0 ? abrupt_frame
                                       : o.sample.num_frames >= 2 ? o.sample.num_frames / 2
                                                                  : -1;
    } else if (abrupt_option->count() > 0) {
      G6D_THROW("--abrupt-frame needs --sequence");
    }
    if (o.inplane < 1 || o.views < 1 || o.views % o.inplane != 0) {
      G6D_THROW("--views " << o.views << " must be a positive multiple of --inplane " << o.inplane);
    }
    if (!(o.fps > 0.0)) G6D_THROW("--fps must be > 0 (got " << o.fps << ")");
    if (const std::string bad = o.sample.Check(); !bad.empty()) G6D_THROW("bad option: " << bad);
    g6d::TemplateBuildOptions build;
    build.views.num_directions = o.views / o.inplane;
    build.views.num_inplane = o.inplane;
    if (const std::string bad = build.Check(); !bad.empty())
      G6D_THROW("bad template option: " << bad);

    const fs::path out(out_text);
    const std::string generator_hash = g6d::HexString(g6d::HashFile("/proc/self/exe"));
    if (reuse && IsCurrent(out, o, generator_hash)) {
      std::printf(
          "g6d-make-sample: %s is up to date (same options, same generator); nothing to do\n",
          out_text.c_str());
      return 0;
    }
    if (fs::is_directory(out) && !fs::is_empty(out) && !IsSampleFolder(out)) {
      G6D_THROW("'" << out_text
                    << "' is not empty and was not written by g6d-make-sample; refusing to replace "
                    << "its models/ and test/ (choose an empty or new folder)");
    }
    fs::create_directories(out);
    WriteText(out / kMarkerName, "written by g6d-make-sample\n");
    // Until the new manifest is written the folder is not a finished sample.
    fs::remove(out / kManifestName);
    auto progress = [](const std::string& line) {
      std::fprintf(stderr, "g6d-make-sample: %s\n", line.c_str());
    };

    const g6d::SampleReport scene = g6d::WriteSampleDataset(o.sample, out.string(), progress);

    // Template caches; stale ones (e.g. of an object no longer in the sample) go first.
    const fs::path cache_dir = out / kCacheFolder;
    if (fs::is_directory(cache_dir)) {
      for (const fs::directory_entry& entry : fs::directory_iterator(cache_dir)) {
        if (entry.path().extension() == ".g6dcache") fs::remove(entry.path());
      }
    }
    double caches_seconds = 0.0;
    int caches_written = 0;
    if (o.caches) {
      const g6d::Stopwatch caches_watch;
      // Our own threads do the fan-out; OpenCV's pool would only oversubscribe.
      cv::setNumThreads(1);
      const g6d::BopDataset dataset = g6d::LoadBopDataset(out.string());
      for (const auto& [obj_id, object] : dataset.objects) {
        // A fresh pool per object: see WriteSampleCache() on OSMesa contexts and threads.
        g6d::ThreadPool pool(threads);
        const g6d::SampleCacheEntry entry = g6d::WriteSampleCache(
            build, object, (cache_dir / (object.name + ".g6dcache")).string(), &pool);
        char line[256];
        std::snprintf(line, sizeof(line),
                      "cache %s: %d templates, %zu keypoints, %.2f MB in %.1f s",
                      entry.path.c_str(), entry.templates, entry.keypoints, entry.bytes / 1048576.0,
                      entry.seconds);
        progress(line);
        ++caches_written;
      }
      caches_seconds = caches_watch.ElapsedMs() / 1000.0;
    }

    g6d::BopToLcmReport log;
    if (o.log) {
      g6d::BopToLcmOptions log_options;
      log_options.fps = o.fps;
      log_options.camera_id = "sample";
      log = g6d::WriteBopSceneLog(log_options, out.string(), 1, (out / kLogName).string());
      if (!log.success) G6D_THROW("writing the LCM log failed: " << log.message);
      char line[200];
      std::snprintf(line, sizeof(line), "log %s: %d frames, %d instances, %.1f MB",
                    (out / kLogName).c_str(), log.frames_written, log.instances_written,
                    log.bytes_written / 1048576.0);
      progress(line);
    } else {
      fs::remove(out / kLogName);
    }

    Json objects = Json::array();
    for (size_t k = 0; k < scene.objects.size(); ++k) {
      const g6d::SampleObject& object = scene.objects[k];
      objects.push_back({{"name", object.name},
                         {"kind", object.kind},
                         {"dimensions", object.dimensions},
                         {"diameter_mm", scene.diameters_m[k] * 1000.0},
                         {"mesh", "models/" + object.name + ".obj"}});
    }
    Json manifest = {{"generator", "g6d-make-sample"},
                     {"format", kManifestFormat},
                     {"generator_hash", generator_hash},
                     {"options", OptionsJson(o)},
                     {"objects", objects},
                     {"frames", scene.frames_written},
                     {"instances", scene.instances_written},
                     {"occluded_instances", scene.occluded_instances},
                     {"min_visib_fract", scene.min_visib_fract},
                     {"mean_visib_fract", scene.mean_visib_fract},
                     {"scene", "test/000001"},
                     {"caches", o.caches ? Json(kCacheFolder) : Json(nullptr)},
                     {"log", o.log ? Json(kLogName) : Json(nullptr)},
                     {"channel", "G6D_RGBD"}};
    const g6d::SampleSequencePlan& plan = scene.sequence;
    const bool jumps = plan.abrupt_object >= 0;
    if (o.sample.sequence.enabled) {
      manifest["sequence"] = true;
      manifest["abrupt_frame"] = plan.abrupt_frame;
      manifest["abrupt_obj_id"] = jumps ? Json(scene.objects[plan.abrupt_object].obj_id) : Json();
      manifest["abrupt_translation_mm"] = plan.jump_m * 1000.0;
      manifest["abrupt_rotation_deg"] = plan.jump_turn_deg;
      manifest["camera_sweep_deg"] = plan.sweep_deg;
      manifest["max_camera_step_mm"] = plan.max_step_m * 1000.0;
      manifest["max_camera_step_deg"] = plan.max_step_deg;
    }
    WriteText(out / kManifestName, manifest.dump(1) + "\n");

    std::printf("g6d-make-sample: wrote %s (seed %llu) in %.1f s\n", out_text.c_str(),
                static_cast<unsigned long long>(o.sample.seed), watch.ElapsedMs() / 1000.0);
    std::printf("  objects  %zu in models/ (OBJ + MTL + PNG, metres):", scene.objects.size());
    for (const g6d::SampleObject& object : scene.objects) {
      std::printf(" %s %s;", object.name.c_str(), object.kind.c_str());
    }
    std::printf(
        "\n  images   %d in test/000001 (rgb, depth, mask, mask_visib, GT): %d instances, %d "
        "partly occluded, "
        "visible fraction min %.2f, mean %.2f (%.1f s)\n",
        scene.frames_written, scene.instances_written, scene.occluded_instances,
        scene.min_visib_fract, scene.mean_visib_fract, scene.seconds);
    if (o.sample.sequence.enabled) {
      std::printf(
          "  sequence one arrangement, camera sweep %.1f deg at %.0f fps, steps up to %.1f mm and "
          "%.2f deg per image",
          plan.sweep_deg, o.fps, plan.max_step_m * 1000.0, plan.max_step_deg);
      if (jumps) {
        std::printf("; %s jumps at image %d by %.1f mm and %.1f deg",
                    scene.objects[plan.abrupt_object].name.c_str(), plan.abrupt_frame,
                    plan.jump_m * 1000.0, plan.jump_turn_deg);
      }
      std::printf("\n");
    }
    if (o.caches) {
      std::printf("  caches   %d in %s/, %d templates each (%.1f s)\n", caches_written,
                  kCacheFolder, o.views, caches_seconds);
    }
    if (o.log) {
      std::printf("  log      %s: %d frames, %d instances, %.1f MB, channel G6D_RGBD, %.0f fps\n",
                  kLogName, log.frames_written, log.instances_written,
                  log.bytes_written / 1048576.0, o.fps);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-make-sample: error: %s\n", e.what());
    return 1;
  }
}
