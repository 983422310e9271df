// g6d-bench-match: how good are the 2D-3D correspondences that template matching gives
// on a BOP dataset? For every target instance (GT visible mask) it reports how many
// correspondence sets contain enough correspondences that agree with the GT pose (the
// sets MSAC-PnP can solve), where the template nearest the GT view ranks by Q_j, and
// the inlier ratio of the best sets. This separates "matching found nothing" from "PnP
// or the later stages lost it".
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/executor.h"
#include "core/se3.h"
#include "eval/bop.h"
#include "solver/match.h"
#include "solver/pipeline.h"
#include "solver/pnp.h"
#include "templates/cache.h"
#include "templates/crop.h"
#include "templates/features.h"

namespace {

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-bench-match: quality of template matching correspondences on a BOP dataset"};
  std::string dataset_dir, caches_dir;
  int every = 5, threads = 2;
  int min_inliers = 6;
  app.add_option("--dataset", dataset_dir, "BOP dataset folder")->required();
  app.add_option("--caches", caches_dir, "folder with <obj_XXXXXX>.g6dcache files")->required();
  app.add_option("--every", every, "every N-th target instance")->capture_default_str();
  app.add_option("--threads", threads, "threads")->capture_default_str();
  app.add_option("--min-inliers", min_inliers, "GT inliers for a set to count as solvable")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    const g6d::BopDataset dataset = g6d::LoadBopDataset(dataset_dir);
    g6d::ThreadPool pool(std::max(1, threads));
    g6d::SolverOptions options;
    g6d::MatchOptions all_sets = options.match;
    all_sets.max_sets = 100000;  // rank every template
    std::map<int, g6d::TemplateBank> banks;
    std::map<int, g6d::BopScene> scenes;
    std::map<int, std::vector<double>> solvable_by_object, nearest_rank_by_object;
    int seen = 0;
    std::printf("scene im obj | feats | solvable sets in top N_P / all | nearest tmpl: angle rank GT-inl/n | best set: rank GT-inl/n\n");
    for (const g6d::BopTarget& target : dataset.targets) {
      if (!scenes.count(target.scene_id)) scenes.emplace(target.scene_id, g6d::LoadBopScene(dataset_dir, target.scene_id));
      const g6d::BopScene& scene = scenes.at(target.scene_id);
      if (!banks.count(target.obj_id)) {
        banks.emplace(target.obj_id, g6d::ReadTemplateCache(caches_dir + "/" + g6d::BopObjectName(target.obj_id) + ".g6dcache"));
      }
      const g6d::TemplateBank& bank = banks.at(target.obj_id);
      const g6d::BopFrame& bop_frame = scene.Frame(target.im_id);
      const cv::Mat rgb = g6d::LoadBopRgb(scene, target.im_id);
      g6d::Camera camera = bop_frame.camera;
      camera.width = rgb.cols;
      camera.height = rgb.rows;
      for (size_t gt_idx = 0; gt_idx < bop_frame.gt.size(); ++gt_idx) {
        const g6d::BopGtInstance& gt = bop_frame.gt[gt_idx];
        if (gt.obj_id != target.obj_id) continue;
        if (seen++ % every != 0) continue;
        const cv::Mat mask = g6d::LoadBopMaskVisib(scene, target.im_id, static_cast<int>(gt_idx)) > 0;
        const cv::Rect box = cv::boundingRect(mask);
        if (box.area() == 0) continue;
        const g6d::NormalizedCrop crop = g6d::NormalizeCrop(rgb, mask, bank.options.crop);
        const std::vector<g6d::Feature> query = g6d::DetectOrb(crop, options.query_orb);
        std::vector<g6d::CorrespondenceSet> sets;
        g6d::MatchReport report;
        g6d::MatchTemplates(all_sets, query, bank, &pool, &sets, &report);
        const double tau = g6d::PnpThreshold(options.pnp, std::max(box.width, box.height));
        // GT inliers of each set: correspondences whose 3D point projects within τ_P under GT.
        std::vector<int> gt_inliers(sets.size(), 0);
        for (size_t s = 0; s < sets.size(); ++s) {
          for (size_t i = 0; i < sets[s].image_points.size(); ++i) {
            const Eigen::Vector3d p = gt.cam_from_object * sets[s].object_points[i];
            if (p.z() > 0 && (camera.Project(p) - sets[s].image_points[i]).norm() < tau) ++gt_inliers[s];
          }
        }
        int solvable_top = 0, solvable_all = 0, best_set = -1;
        for (size_t s = 0; s < sets.size(); ++s) {
          const bool ok = gt_inliers[s] >= min_inliers;
          solvable_all += ok;
          if (s < static_cast<size_t>(options.match.max_sets)) solvable_top += ok;
          if (best_set < 0 || gt_inliers[s] > gt_inliers[static_cast<size_t>(best_set)]) best_set = static_cast<int>(s);
        }
        // The template nearest to the GT rotation and its rank.
        int nearest = -1;
        double nearest_angle = 1e9;
        for (size_t j = 0; j < bank.templates.size(); ++j) {
          const double angle = g6d::RotationErrorDeg(bank.templates[j].cam_from_object.linear(), gt.cam_from_object.linear());
          if (angle < nearest_angle) {
            nearest_angle = angle;
            nearest = static_cast<int>(j);
          }
        }
        int nearest_rank = -1;
        for (size_t s = 0; s < sets.size(); ++s) {
          if (sets[s].template_index == nearest) nearest_rank = static_cast<int>(s);
        }
        // What MSAC-PnP makes of the set richest in GT inliers.
        g6d::PnpResult pnp;
        cv::Mat depth = g6d::LoadBopDepth(scene, target.im_id);
        std::vector<Eigen::Vector2d> query_image_points;
        for (const g6d::Feature& f : query) query_image_points.push_back(f.xy.cast<double>() + Eigen::Vector2d::Constant(g6d::kOpenCvToImage));
        const std::vector<Eigen::Vector3d> query_points = g6d::BackprojectKeypoints(camera, depth, mask, query_image_points);
        g6d::PnpPrior prior;
        prior.z_m = g6d::MeanMaskedDepth(mask, depth);
        prior.diameter_m = bank.diameter_m;
        prior.centre_in_object = bank.bounding_box.center();
        prior.query_points_in_cam = &query_points;
        if (best_set >= 0) g6d::EstimatePnp(options.pnp, sets[static_cast<size_t>(best_set)], camera, std::max(box.width, box.height), prior, &pnp);
        const double pnp_rot = pnp.success ? g6d::RotationErrorDeg(pnp.cam_from_object.linear(), gt.cam_from_object.linear()) : -1;
        const double pnp_t_mm = pnp.success ? 1000 * (pnp.cam_from_object.translation() - gt.cam_from_object.translation()).norm() : -1;
        std::printf("   pnp on best set: %s inliers %d rot %.1f deg t %.0f mm | tau %.1f\n", pnp.message.c_str(), pnp.inliers, pnp_rot, pnp_t_mm, tau);
        const auto n_of = [&](int s) { return s < 0 ? 0 : static_cast<int>(sets[static_cast<size_t>(s)].image_points.size()); };
        std::printf("%d %d %d | %zu | %d / %d | %.0f %d %d/%d | %d %d/%d\n", target.scene_id, target.im_id, target.obj_id,
                    query.size(), solvable_top, solvable_all, nearest_angle, nearest_rank,
                    nearest_rank >= 0 ? gt_inliers[static_cast<size_t>(nearest_rank)] : 0, n_of(nearest_rank), best_set,
                    best_set >= 0 ? gt_inliers[static_cast<size_t>(best_set)] : 0, n_of(best_set));
        solvable_by_object[target.obj_id].push_back(solvable_top);
        nearest_rank_by_object[target.obj_id].push_back(nearest_rank < 0 ? 1e6 : nearest_rank);
      }
    }
    std::printf("\n| object | n | instances with a solvable set in top N_P | median solvable sets | median rank of nearest template |\n|---|---|---|---|---|\n");
    for (const auto& [obj_id, solvable] : solvable_by_object) {
      const int with = static_cast<int>(std::count_if(solvable.begin(), solvable.end(), [](double v) { return v > 0; }));
      std::printf("| %s | %zu | %d | %.0f | %.0f |\n", g6d::BopObjectName(obj_id).c_str(), solvable.size(), with, Median(solvable),
                  Median(nearest_rank_by_object[obj_id]));
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bench-match: error: %s\n", e.what());
    return 2;
  }
}
