// g6d-build-templates: turns a metric CAD mesh into a template cache file (DESIGN.md,
// "Offline: template cache").
//
//   g6d-build-templates --mesh obj_000001.ply --units mm --object-id obj_000001
//       --out caches/obj_000001.g6dcache [--views 324] [--inplane 3] [--threads 2]
//       [--models-info models_info.json]
//
// --views is the total number of templates N_T. It is split into --inplane in-plane
// rotations (default 3) times N_T / inplane viewing directions on a Fibonacci sphere, so
// it must be a multiple of --inplane (324 = 108 x 3; use --inplane 1 for any N).
// --models-info reads the object's symmetries from a BOP models_info.json (the entry whose
// key is the number at the end of --object-id): discrete ones as given, continuous ones
// sampled every 360 / --continuous-steps degrees.

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/executor.h"
#include "core/hash.h"
#include "core/se3.h"
#include "core/timer.h"
#include "mesh/mesh.h"
#include "templates/cache.h"
#include "templates/template_bank.h"

namespace {

// Symmetries of `object_id` from a BOP models_info.json, as object_from_object transforms
// in metres (the file is in the mesh's units).
std::vector<Eigen::Isometry3d> ReadBopSymmetries(const std::string& path,
                                                 const std::string& object_id,
                                                 double metres_per_unit, int continuous_steps) {
  size_t digits_start = object_id.size();
  while (digits_start > 0 &&
         std::isdigit(static_cast<unsigned char>(object_id[digits_start - 1]))) {
    --digits_start;
  }
  if (digits_start == object_id.size()) {
    G6D_THROW("--models-info needs an --object-id ending in the BOP object number (got '"
              << object_id << "')");
  }
  const std::string key = std::to_string(std::stoi(object_id.substr(digits_start)));
  std::ifstream in(path);
  if (!in) G6D_THROW("cannot open models info '" << path << "'");
  nlohmann::json info;
  try {
    in >> info;
  } catch (const nlohmann::json::exception& e) {
    G6D_THROW("models info '" << path << "' is not valid JSON: " << e.what());
  }
  if (!info.contains(key)) G6D_THROW("models info '" << path << "' has no entry \"" << key << "\"");
  const nlohmann::json& entry = info[key];
  std::vector<Eigen::Isometry3d> symmetries;
  try {
    if (entry.contains("symmetries_discrete")) {
      for (const auto& values : entry["symmetries_discrete"]) {
        if (values.size() != 16) G6D_THROW("a symmetries_discrete entry must have 16 numbers");
        Eigen::Matrix3d rotation;
        Eigen::Vector3d translation;
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) rotation(r, c) = values[4 * r + c].get<double>();
          translation[r] = values[4 * r + 3].get<double>() * metres_per_unit;
        }
        // BOP stores them to 6 digits; project back onto SO(3).
        symmetries.push_back(g6d::MakePose(g6d::Orthonormalize(rotation), translation));
      }
    }
    if (entry.contains("symmetries_continuous")) {
      for (const auto& symmetry : entry["symmetries_continuous"]) {
        Eigen::Vector3d axis, offset;
        for (int i = 0; i < 3; ++i) {
          axis[i] = symmetry["axis"][i].get<double>();
          offset[i] = symmetry["offset"][i].get<double>() * metres_per_unit;
        }
        if (!(axis.norm() > 0.0)) G6D_THROW("a continuous symmetry axis is zero");
        axis.normalize();
        for (int step = 1; step < continuous_steps; ++step) {
          const Eigen::Matrix3d rotation =
              Eigen::AngleAxisd(2.0 * M_PI * step / continuous_steps, axis).toRotationMatrix();
          // Rotation about the axis through `offset`: x -> R (x - o) + o.
          symmetries.push_back(g6d::MakePose(rotation, offset - rotation * offset));
        }
      }
    }
  } catch (const nlohmann::json::exception& e) {
    G6D_THROW("models info '" << path << "', entry \"" << key << "\": " << e.what());
  }
  return symmetries;
}

// Progress on stderr: a redrawn bar on a terminal, a line per 10% otherwise.
class ProgressPrinter {
 public:
  ProgressPrinter() : terminal_(::isatty(STDERR_FILENO) == 1) {}

  void operator()(int done, int total) {
    if (terminal_) {
      constexpr int kWidth = 30;
      const int filled = total > 0 ? kWidth * done / total : kWidth;
      std::fprintf(stderr, "\r[%s%s] %d/%d", std::string(filled, '#').c_str(),
                   std::string(kWidth - filled, ' ').c_str(), done, total);
      if (done == total) std::fprintf(stderr, "\n");
    } else {
      const int decile = total > 0 ? 10 * done / total : 10;
      if (decile != last_decile_ || done == total) {
        std::fprintf(stderr, "templates %d/%d\n", done, total);
        last_decile_ = decile;
      }
    }
    std::fflush(stderr);
  }

 private:
  bool terminal_;
  int last_decile_ = 0;
};

std::string HumanBytes(uintmax_t bytes) {
  char text[32];
  if (bytes >= (1u << 20)) {
    std::snprintf(text, sizeof(text), "%.2f MB", bytes / 1048576.0);
  } else {
    std::snprintf(text, sizeof(text), "%.1f kB", bytes / 1024.0);
  }
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-build-templates: render a CAD mesh into a G6D template cache"};
  std::string mesh_path, units_text, object_id, out_path, models_info_path;
  int num_views = 324;
  int num_inplane = 3;
  int num_threads = 2;
  int zstd_level = 9;
  int continuous_steps = 36;
  g6d::TemplateBuildOptions options;
  app.add_option("--mesh", mesh_path, "mesh file (PLY with vertex colours, OBJ/MTL with texture)")
      ->required();
  app.add_option("--units", units_text, "units of the mesh file: mm or m")
      ->required()
      ->check(CLI::IsMember({"mm", "m"}));
  app.add_option("--object-id", object_id, "object id stored in the cache, e.g. obj_000001")
      ->required();
  app.add_option("--out", out_path, "output cache file")->required();
  app.add_option("--views", num_views, "total number of templates N_T (multiple of --inplane)")
      ->capture_default_str();
  app.add_option("--inplane", num_inplane, "in-plane rotations per viewing direction")
      ->capture_default_str();
  app.add_option("--threads", num_threads, "worker threads (including the main thread)")
      ->capture_default_str();
  app.add_option("--render-size", options.render_size_px, "template render side, pixels")
      ->capture_default_str();
  app.add_option("--render-focal", options.render_focal_px, "template focal length, pixels")
      ->capture_default_str();
  app.add_option("--crop-size", options.crop.size_px, "normalized crop side S, pixels")
      ->capture_default_str();
  app.add_option("--max-features", options.orb.max_features, "ORB features per template")
      ->capture_default_str();
  app.add_option("--fast-threshold", options.orb.fast_threshold, "ORB FAST threshold")
      ->capture_default_str();
  app.add_option("--online-faces", options.online_mesh_faces, "faces of the online mesh")
      ->capture_default_str();
  app.add_option("--zstd-level", zstd_level, "zstd compression level")->capture_default_str();
  bool no_ppf = false;
  app.add_flag("--no-ppf", no_ppf, "no point-pair-feature model (the solver then uses ORB-PnP hypotheses alone)");
  app.add_option("--ppf-step", options.ppf.step_fraction,
                 "point-pair-feature model: sampling step as a fraction of the diameter")
      ->capture_default_str();
  app.add_option("--ppf-max-points", options.ppf.max_points, "point-pair-feature model: points at most")
      ->capture_default_str();
  app.add_option("--models-info", models_info_path,
                 "BOP models_info.json to read the object's symmetries from");
  app.add_option("--continuous-steps", continuous_steps,
                 "samples of a continuous symmetry (with --models-info)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  options.build_ppf = !no_ppf;

  try {
    if (num_inplane < 1) G6D_THROW("--inplane must be >= 1 (got " << num_inplane << ")");
    if (num_views < 1 || num_views % num_inplane != 0) {
      G6D_THROW("--views " << num_views << " must be a positive multiple of --inplane "
                           << num_inplane << " (or pass --inplane 1)");
    }
    if (num_threads < 1) G6D_THROW("--threads must be >= 1 (got " << num_threads << ")");
    if (continuous_steps < 2) G6D_THROW("--continuous-steps must be >= 2");
    options.views.num_directions = num_views / num_inplane;
    options.views.num_inplane = num_inplane;
    if (const std::string problem = options.Check(); !problem.empty()) {
      G6D_THROW("bad option: " << problem);
    }

    const g6d::Stopwatch total_watch;
    const g6d::Units units = g6d::ParseUnits(units_text);
    // LoadMesh first: its errors name the file and the problem. The hash then identifies
    // the file's bytes; a changed file later makes the cache stale.
    const g6d::Mesh mesh = g6d::LoadMesh(mesh_path, units);
    const uint64_t mesh_hash = g6d::HashFile(mesh_path);
    std::vector<Eigen::Isometry3d> symmetries;
    if (!models_info_path.empty()) {
      symmetries = ReadBopSymmetries(models_info_path, object_id, g6d::MetresPerUnit(units),
                                     continuous_steps);
    }
    std::fprintf(stderr, "%s: %zu vertices, %zu faces%s%s; rendering %d templates on %d threads\n",
                 mesh_path.c_str(), mesh.vertices.size(), mesh.faces.size(),
                 mesh.HasTexture() ? ", textured" : "", mesh.HasColors() ? ", vertex colours" : "",
                 num_views, num_threads);

    // Our own threads do the fan-out; OpenCV's internal pool would only oversubscribe.
    cv::setNumThreads(1);
    g6d::ThreadPool pool(num_threads);
    ProgressPrinter progress;
    g6d::TemplateBank bank = g6d::BuildTemplateBank(
        mesh, object_id, options, &pool, [&](int done, int total) { progress(done, total); });
    bank.mesh_hash = mesh_hash;
    bank.mesh_path = mesh_path;
    bank.mesh_units = units;
    bank.symmetries = std::move(symmetries);

    const std::filesystem::path out_parent = std::filesystem::path(out_path).parent_path();
    if (!out_parent.empty()) std::filesystem::create_directories(out_parent);
    g6d::WriteTemplateCache(bank, out_path, zstd_level);
    const double seconds = total_watch.ElapsedMs() / 1000.0;

    std::vector<size_t> counts;
    for (const g6d::Template& t : bank.templates) counts.push_back(t.keypoints.size());
    std::sort(counts.begin(), counts.end());
    const size_t median = counts.empty() ? 0 : counts[counts.size() / 2];
    std::printf(
        "object %s: %zu templates, keypoints per template min %zu / median %zu / max %zu, "
        "total %zu\n",
        object_id.c_str(), bank.templates.size(), counts.empty() ? 0 : counts.front(), median,
        counts.empty() ? 0 : counts.back(), bank.NumKeypoints());
    std::printf("diameter %.1f mm, %zu symmetries given, online mesh %zu faces\n",
                bank.diameter_m * 1000.0, bank.symmetries.size(), bank.online_mesh.faces.size());
    std::printf("geometric symmetries: %s\n", bank.geometric_symmetries.Describe().c_str());
    std::printf("appearance: %s\n", bank.appearance.Empty()
                                          ? "none (no texture or vertex colours, or uniform): no appearance tie-break"
                                          : (std::to_string(bank.appearance.points.size()) + " coloured surface samples").c_str());
    std::printf("wrote %s (%s) in %.2f s\n", out_path.c_str(),
                HumanBytes(std::filesystem::file_size(out_path)).c_str(), seconds);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-build-templates: error: %s\n", e.what());
    return 1;
  }
}
