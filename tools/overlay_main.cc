// g6d-overlay: draws the estimates of a BOP results CSV over the images of a BOP dataset.
//
//   g6d-overlay --dataset DIR --results CSV --out DIR [--caches DIR] [--split test]
//       [--max-images N]
//
// One PNG per image that has estimates, <out>/<scene_id:06d>_<im_id:06d>.png: the RGB image
// (dimmed a little), the ground-truth silhouette contour of every GT instance of an
// estimated object (thin, blue), and per estimate its silhouette contour (green) and the
// object axes (x red, y green, z blue, 0.4 diameters long) projected with the estimated
// pose, labelled with the object, the score (the CSV's confidence) and the ADD(-S) error
// to the nearest GT instance of that object (green when within 0.1 d, else red). Contours
// come from the CPU rasterizer's exact silhouettes (cv::findContours).
// Meshes: the online mesh of <caches>/<obj_XXXXXX>.g6dcache when --caches holds one (fast,
// decimated), else the mesh models_info.json names (`mesh`, `units`).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "core/error.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "render/raster.h"
#include "templates/cache.h"

namespace {

namespace fs = std::filesystem;

// Colours in RGB order (the canvas is RGB until it is written).
const cv::Scalar kEstimateColour(40, 255, 40);
const cv::Scalar kGtColour(60, 110, 255);
const cv::Scalar kAxisColours[3] = {cv::Scalar(255, 50, 50), cv::Scalar(50, 230, 50),
                                    cv::Scalar(60, 90, 255)};
const cv::Scalar kCorrectColour(120, 255, 120);
const cv::Scalar kWrongColour(255, 90, 70);
constexpr double kDim = 0.8;           // image brightness under the drawing
constexpr double kAxisLength = 0.4;    // axis length, fraction of the diameter
constexpr int kMaxErrorPoints = 2000;  // model points for the ADD(-S) label
constexpr double kAddThreshold = 0.1;  // ADD(-S) correct below this fraction of the diameter

// A mesh to draw with, and points for the error label.
struct DrawModel {
  g6d::Mesh mesh;
  std::vector<Eigen::Vector3f> points;  // every k-th vertex, at most kMaxErrorPoints
  std::string source;                   // where the mesh came from
};

class ModelLibrary {
 public:
  ModelLibrary(const g6d::BopDataset& dataset, std::string cache_dir)
      : dataset_(dataset), cache_dir_(std::move(cache_dir)) {}

  // The model of obj_id, loaded on first use. Throws g6d::Error for an unknown object or
  // an unreadable mesh.
  const DrawModel& Get(int obj_id) {
    auto it = models_.find(obj_id);
    if (it != models_.end()) return *it->second;
    const g6d::BopObjectInfo& info = dataset_.Object(obj_id);
    auto model = std::make_unique<DrawModel>();
    const fs::path cache = fs::path(cache_dir_) / (info.name + ".g6dcache");
    if (!cache_dir_.empty() && fs::is_regular_file(cache)) {
      model->mesh = g6d::ReadTemplateCache(cache.string()).online_mesh;
      model->source = cache.string();
    } else {
      model->mesh = g6d::LoadMesh(info.mesh_path, info.mesh_units);
      model->source = info.mesh_path;
    }
    const size_t step = std::max<size_t>(1, model->mesh.vertices.size() / kMaxErrorPoints);
    for (size_t i = 0; i < model->mesh.vertices.size(); i += step)
      model->points.push_back(model->mesh.vertices[i]);
    return *models_.emplace(obj_id, std::move(model)).first->second;
  }

 private:
  const g6d::BopDataset& dataset_;
  std::string cache_dir_;
  std::map<int, std::unique_ptr<DrawModel>> models_;
};

std::vector<std::vector<cv::Point>> Silhouette(const g6d::Mesh& mesh, const g6d::Camera& camera,
                                               const Eigen::Isometry3d& cam_from_object,
                                               g6d::RasterImage* raster) {
  g6d::RasterOptions options;
  options.want_face_id = false;
  g6d::Rasterize(mesh, camera, cam_from_object, options, raster);
  std::vector<std::vector<cv::Point>> contours;
  if (raster->pixel_count > 0)
    cv::findContours(raster->Mask(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  return contours;
}

void DrawAxes(cv::Mat* canvas, const g6d::Camera& camera, const Eigen::Isometry3d& cam_from_object,
              double length_m) {
  const Eigen::Vector3d origin = cam_from_object.translation();
  if (origin.z() <= 0.0) return;
  const Eigen::Vector2d o = camera.Project(origin) - Eigen::Vector2d::Constant(g6d::kOpenCvToImage);
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d tip = cam_from_object * (length_m * Eigen::Vector3d::Unit(axis));
    if (tip.z() <= 0.0) continue;
    const Eigen::Vector2d t = camera.Project(tip) - Eigen::Vector2d::Constant(g6d::kOpenCvToImage);
    cv::arrowedLine(*canvas, cv::Point2d(o.x(), o.y()), cv::Point2d(t.x(), t.y()),
                    kAxisColours[axis], 2, cv::LINE_AA, 0, 0.15);
  }
}

// Text with a dark outline, readable on any background.
void Label(cv::Mat* canvas, const std::string& text, cv::Point origin, const cv::Scalar& colour,
           double scale = 0.45) {
  origin.x = std::clamp(origin.x, 2, std::max(2, canvas->cols - 8 * static_cast<int>(text.size())));
  origin.y = std::clamp(origin.y, 14, canvas->rows - 4);
  cv::putText(*canvas, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(*canvas, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "g6d-overlay: draw the estimates of a BOP results CSV (green) and the ground truth (blue) "
      "over the "
      "dataset's images"};
  std::string dataset_dir, results_path, out_dir, cache_dir, split = "test";
  int max_images = 0;
  app.add_option("--dataset", dataset_dir, "BOP dataset folder (models/, test/, ...)")->required();
  app.add_option("--results", results_path,
                 "BOP results CSV (scene_id,im_id,obj_id,score,R,t,time; mm)")
      ->required();
  app.add_option("--out", out_dir, "folder for the overlay PNGs (created)")->required();
  app.add_option("--caches", cache_dir,
                 "template cache folder: draw with the caches' online meshes");
  app.add_option("--split", split, "dataset split folder")->capture_default_str();
  app.add_option("--max-images", max_images, "draw at most this many images (0 = all)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    if (!fs::is_directory(dataset_dir))
      G6D_THROW("dataset folder '" << dataset_dir << "' does not exist");
    if (!fs::is_regular_file(results_path))
      G6D_THROW("results file '" << results_path << "' does not exist");
    const g6d::BopDataset dataset = g6d::LoadBopDataset(dataset_dir, split);
    const std::vector<g6d::BopEstimate> estimates = g6d::ReadBopCsv(results_path);
    std::map<std::pair<int, int>, std::vector<const g6d::BopEstimate*>> by_image;
    for (const g6d::BopEstimate& e : estimates) by_image[{e.scene_id, e.im_id}].push_back(&e);
    fs::create_directories(out_dir);

    ModelLibrary models(dataset, cache_dir);
    std::map<int, g6d::BopScene> scenes;
    g6d::RasterImage raster;
    int written = 0, correct = 0, with_gt = 0;
    for (const auto& [key, image_estimates] : by_image) {
      if (max_images > 0 && written >= max_images) break;
      const auto [scene_id, im_id] = key;
      if (!scenes.count(scene_id))
        scenes.emplace(scene_id, g6d::LoadBopScene(dataset_dir, scene_id, split));
      const g6d::BopScene& scene = scenes.at(scene_id);
      const g6d::BopFrame& frame = scene.Frame(im_id);
      const cv::Mat rgb = g6d::LoadBopRgb(scene, im_id);
      g6d::Camera camera = frame.camera;
      camera.width = rgb.cols;
      camera.height = rgb.rows;
      cv::Mat canvas;
      rgb.convertTo(canvas, CV_8UC3, kDim);

      std::vector<int> estimated_objects;
      for (const g6d::BopEstimate* e : image_estimates) estimated_objects.push_back(e->obj_id);
      for (const g6d::BopGtInstance& gt : frame.gt) {
        if (std::find(estimated_objects.begin(), estimated_objects.end(), gt.obj_id) ==
            estimated_objects.end())
          continue;
        cv::drawContours(
            canvas, Silhouette(models.Get(gt.obj_id).mesh, camera, gt.cam_from_object, &raster), -1,
            kGtColour, 1, cv::LINE_AA);
      }
      for (const g6d::BopEstimate* e : image_estimates) {
        const g6d::BopObjectInfo& info = dataset.Object(e->obj_id);
        const DrawModel& model = models.Get(e->obj_id);
        const auto contours = Silhouette(model.mesh, camera, e->cam_from_object, &raster);
        cv::drawContours(canvas, contours, -1, kEstimateColour, 2, cv::LINE_AA);
        DrawAxes(&canvas, camera, e->cam_from_object, kAxisLength * info.diameter_m);
        // The error to the nearest GT instance of the object (ADD-S for symmetric objects).
        double error_m = std::numeric_limits<double>::infinity();
        for (const g6d::BopGtInstance& gt : frame.gt) {
          if (gt.obj_id != e->obj_id) continue;
          const double error =
              info.IsSymmetric()
                  ? g6d::ComputeAdds(e->cam_from_object, gt.cam_from_object, model.points)
                  : g6d::ComputeAdd(e->cam_from_object, gt.cam_from_object, model.points);
          error_m = std::min(error_m, error);
        }
        char text[160];
        cv::Scalar colour = kEstimateColour;
        if (std::isfinite(error_m)) {
          const bool ok = error_m < kAddThreshold * info.diameter_m;
          correct += ok;
          ++with_gt;
          colour = ok ? kCorrectColour : kWrongColour;
          std::snprintf(text, sizeof(text), "%s %.2f %s %.1f mm", info.name.c_str(), e->score,
                        info.IsSymmetric() ? "ADD-S" : "ADD", error_m * 1000.0);
        } else {
          std::snprintf(text, sizeof(text), "%s %.2f", info.name.c_str(), e->score);
        }
        const cv::Rect box =
            contours.empty() ? cv::Rect(10, 40, 1, 1) : cv::boundingRect(contours.front());
        Label(&canvas, text, {box.x, box.y - 6}, colour);
      }
      char header[200];
      std::snprintf(header, sizeof(header),
                    "scene %d image %d: %zu estimate(s) green, ground truth blue", scene_id, im_id,
                    image_estimates.size());
      Label(&canvas, header, {8, 20}, cv::Scalar(255, 255, 255), 0.5);

      char name[64];
      std::snprintf(name, sizeof(name), "%06d_%06d.png", scene_id, im_id);
      const fs::path path = fs::path(out_dir) / name;
      cv::Mat bgr;
      cv::cvtColor(canvas, bgr, cv::COLOR_RGB2BGR);
      if (!cv::imwrite(path.string(), bgr)) G6D_THROW("cannot write '" << path.string() << "'");
      ++written;
    }
    std::printf("g6d-overlay: wrote %d image(s) to %s (estimates green, ground truth blue", written,
                out_dir.c_str());
    if (with_gt > 0) std::printf("; %d of %d estimates within ADD(-S) 0.1 d", correct, with_gt);
    std::printf(")\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-overlay: error: %s\n", e.what());
    return 1;
  }
}
