// The embedded sample's pictures: the exact z-buffer of objects and table
// (ComposeSampleDepth), per-instance visibility, depth noise, and colour from OSMesa
// renders composed with the same z-buffer and area-downsampled. One of the four files of
// g6d_sample (sample_texture, sample_layout, sample_render, sample_writers).
#include <algorithm>
#include <memory>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "render/raster.h"
#include "sample/sample_internal.h"
#include "sample/sample_scene.h"

namespace g6d {
namespace {

using sample_internal::DerivedSeed;
using sample_internal::kTablePart;
using sample_internal::RenderFrameWith;
using sample_internal::SampleRenderers;

RasterOptions DepthOnlyRaster() {
  RasterOptions options;
  options.want_face_id = false;
  return options;
}

// Per-instance counts and boxes from the full silhouettes and the nearest-surface index.
void MeasureInstances(const std::vector<cv::Mat>& full_masks, const cv::Mat& nearest_index,
                      std::vector<SampleInstance>* instances) {
  for (size_t k = 0; k < full_masks.size(); ++k) {
    SampleInstance& instance = (*instances)[k];
    const cv::Mat visible = nearest_index == static_cast<int>(k);
    instance.px_count_all = cv::countNonZero(full_masks[k]);
    instance.px_count_visib = cv::countNonZero(visible);
    instance.visib_fract =
        instance.px_count_all > 0
            ? static_cast<double>(instance.px_count_visib) / instance.px_count_all
            : 0.0;
    instance.bbox_obj = cv::boundingRect(full_masks[k]);
    instance.bbox_visib = cv::boundingRect(visible);
  }
}

// The colour of pixel (x, y) of `image`, or, when the render does not cover it (its
// coverage can differ from the rasterizer's by a pixel along edges), the mean of the
// covered pixels around it.
cv::Vec3b CoveredColour(const GlImage& image, int x, int y, const cv::Vec3b& fallback) {
  if (image.mask.at<uint8_t>(y, x) != 0) return image.rgb.at<cv::Vec3b>(y, x);
  for (int radius = 1; radius <= 3; ++radius) {
    cv::Vec3d sum(0, 0, 0);
    int count = 0;
    for (int dy = -radius; dy <= radius; ++dy) {
      for (int dx = -radius; dx <= radius; ++dx) {
        const int u = x + dx, v = y + dy;
        if (u < 0 || v < 0 || u >= image.mask.cols || v >= image.mask.rows ||
            image.mask.at<uint8_t>(v, u) == 0) {
          continue;
        }
        sum += cv::Vec3d(image.rgb.at<cv::Vec3b>(v, u));
        ++count;
      }
    }
    if (count > 0)
      return cv::Vec3b(cv::saturate_cast<uint8_t>(sum[0] / count),
                       cv::saturate_cast<uint8_t>(sum[1] / count),
                       cv::saturate_cast<uint8_t>(sum[2] / count));
  }
  return fallback;
}

// Depth, visible masks and colour of a frame whose camera, instance poses and full masks
// are set; `rng` draws the noise.
void ShadeFrame(const SampleOptions& options, const std::vector<SampleObject>& objects,
                const Mesh& table, SampleRenderers* renderers, cv::RNG* rng, SampleFrame* frame) {
  const Camera& camera = options.camera;
  const int n = static_cast<int>(objects.size());
  std::vector<const Mesh*> meshes;
  for (const SampleObject& object : objects) meshes.push_back(&object.mesh);
  std::vector<Eigen::Isometry3d> poses;
  for (const SampleInstance& instance : frame->instances) poses.push_back(instance.cam_from_object);

  // 1. Depth and visible masks: objects and table by z-buffer, at the camera's resolution.
  cv::Mat nearest;
  ComposeSampleDepth(meshes, poses, &table, frame->cam_from_world, camera, &nearest,
                     &frame->depth_m);
  MeasureInstances(frame->masks, nearest, &frame->instances);
  frame->masks_visib.clear();
  for (int k = 0; k < n; ++k) frame->masks_visib.push_back(nearest == k);
  const double range_m = 65535.0 * options.depth_scale_mm / 1000.0;
  for (int y = 0; y < frame->depth_m.rows; ++y) {
    float* row = frame->depth_m.ptr<float>(y);
    for (int x = 0; x < frame->depth_m.cols; ++x) {
      if (row[x] <= 0.0f) continue;
      row[x] += static_cast<float>(rng->gaussian(options.depth_noise_m));
      if (row[x] <= 0.0f || row[x] >= range_m) row[x] = 0.0f;  // out of the sensor's range
    }
  }

  // 2. Colour: OSMesa renders composed with the same z-buffer at `supersampling` times the
  //    resolution, area-downsampled, plus noise.
  const Camera fine = camera.Scaled(options.supersampling);
  cv::Mat fine_nearest, fine_depth;
  ComposeSampleDepth(meshes, poses, &table, frame->cam_from_world, fine, &fine_nearest,
                     &fine_depth);
  std::vector<GlImage> images;
  for (int k = 0; k < n; ++k) images.push_back(renderers->objects[k]->Render(fine, poses[k]));
  images.push_back(renderers->table->Render(fine, frame->cam_from_world));
  std::vector<cv::Vec3b> mean_colours;
  for (const GlImage& image : images) {
    const cv::Scalar mean = cv::mean(image.rgb, image.mask);
    mean_colours.emplace_back(cv::saturate_cast<uint8_t>(mean[0]),
                              cv::saturate_cast<uint8_t>(mean[1]),
                              cv::saturate_cast<uint8_t>(mean[2]));
  }
  cv::Mat fine_rgb(fine.height, fine.width, CV_8UC3);
  for (int y = 0; y < fine.height; ++y) {
    for (int x = 0; x < fine.width; ++x) {
      const int index = fine_nearest.at<int>(y, x);
      if (index < 0) {
        // Nothing within range: a dim wall, brighter towards the top.
        const uint8_t level =
            static_cast<uint8_t>(70 + 50 * (1.0 - static_cast<double>(y) / fine.height));
        fine_rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(level, level, static_cast<uint8_t>(level + 8));
      } else {
        fine_rgb.at<cv::Vec3b>(y, x) = CoveredColour(images[index], x, y, mean_colours[index]);
      }
    }
  }
  cv::resize(fine_rgb, frame->rgb, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_AREA);
  cv::Mat noise(frame->rgb.size(), CV_32FC3);
  rng->fill(noise, cv::RNG::NORMAL, 0.0, options.color_noise);
  cv::Mat noisy;
  frame->rgb.convertTo(noisy, CV_32FC3);
  noisy += noise;
  noisy.convertTo(frame->rgb, CV_8UC3);  // saturating
}

}  // namespace

namespace sample_internal {

bool MeasureArrangement(const SampleOptions& options, const std::vector<SampleObject>& objects,
                        const std::vector<Eigen::Isometry3d>& world_from_object,
                        SampleFrame* frame) {
  const Camera& camera = options.camera;
  const int n = static_cast<int>(objects.size());
  frame->instances.clear();
  frame->masks.clear();
  std::vector<const Mesh*> meshes;
  std::vector<Eigen::Isometry3d> poses;
  RasterImage raster;
  for (int k = 0; k < n; ++k) {
    SampleInstance instance;
    instance.obj_id = objects[k].obj_id;
    instance.cam_from_object = frame->cam_from_world * world_from_object[k];
    meshes.push_back(&objects[k].mesh);
    poses.push_back(instance.cam_from_object);
    Rasterize(objects[k].mesh, camera, instance.cam_from_object, DepthOnlyRaster(), &raster);
    const cv::Mat mask = raster.Mask();
    const cv::Rect box = cv::boundingRect(mask);
    const int m = options.border_margin_px;
    const bool inside = raster.pixel_count > 0 && box.x >= m && box.y >= m &&
                        box.x + box.width <= camera.width - m &&
                        box.y + box.height <= camera.height - m;
    frame->instances.push_back(instance);
    frame->masks.push_back(mask);
    if (!inside) return false;
  }
  cv::Mat nearest, depth;
  ComposeSampleDepth(meshes, poses, nullptr, Eigen::Isometry3d::Identity(), camera, &nearest,
                     &depth);
  MeasureInstances(frame->masks, nearest, &frame->instances);
  return true;
}

double LeastVisible(const std::vector<SampleInstance>& instances) {
  double least_visible = 1.0;
  for (const SampleInstance& instance : instances)
    least_visible = std::min(least_visible, instance.visib_fract);
  return least_visible;
}

SampleFrame RenderFrameWith(const SampleOptions& options, const std::vector<SampleObject>& objects,
                            const Mesh& table, uint64_t frame_seed, SampleRenderers* renderers) {
  cv::RNG rng(frame_seed);
  const int n = static_cast<int>(objects.size());

  // Arrangements until one is valid and shows mutual occlusion.
  SampleFrame best;
  bool have_valid = false;
  int tries = 0;
  for (; tries < options.max_tries; ++tries) {
    std::vector<Placement> placements;
    if (!DrawPlacements(options, objects, &rng, &placements)) continue;
    SampleFrame frame;
    frame.cam_from_world = DrawCamera(options, placements, &rng);
    std::vector<Eigen::Isometry3d> world_from_object;
    for (const Placement& placement : placements)
      world_from_object.push_back(placement.world_from_object);
    if (!MeasureArrangement(options, objects, world_from_object, &frame)) continue;
    const double least_visible = LeastVisible(frame.instances);
    if (least_visible < options.min_visible_fraction) continue;
    if (!have_valid || least_visible < options.occlusion_below_fraction) {
      best = std::move(frame);
      have_valid = true;
    }
    if (least_visible < options.occlusion_below_fraction) break;
  }
  if (!have_valid) {
    G6D_THROW("no valid arrangement of "
              << n << " objects in " << options.max_tries
              << " tries (every object inside the image and at least "
              << options.min_visible_fraction
              << " visible): relax min_visible_fraction or the camera distances");
  }
  SampleFrame frame = std::move(best);
  frame.tries = std::min(tries + 1, options.max_tries);
  ShadeFrame(options, objects, table, renderers, &rng, &frame);
  return frame;
}

SampleFrame RenderPlannedFrame(const SampleOptions& options,
                               const std::vector<SampleObject>& objects, const Mesh& table,
                               const SampleSequencePlan& plan, int im_id, uint64_t frame_seed,
                               SampleRenderers* renderers) {
  SampleFrame frame;
  frame.cam_from_world = plan.cam_from_world[im_id];
  std::vector<Eigen::Isometry3d> world_from_object;
  for (int k = 0; k < static_cast<int>(objects.size()); ++k)
    world_from_object.push_back(plan.WorldFromObject(im_id, k));
  // PlanSampleSequence() checked this very view.
  const bool inside = MeasureArrangement(options, objects, world_from_object, &frame);
  G6D_CHECK(inside);
  frame.tries = 1;
  cv::RNG rng(frame_seed);
  ShadeFrame(options, objects, table, renderers, &rng, &frame);
  return frame;
}

}  // namespace sample_internal

void ComposeSampleDepth(const std::vector<const Mesh*>& meshes,
                        const std::vector<Eigen::Isometry3d>& cam_from_object, const Mesh* table,
                        const Eigen::Isometry3d& cam_from_world, const Camera& camera,
                        cv::Mat* nearest_index, cv::Mat* depth_m) {
  G6D_CHECK(meshes.size() == cam_from_object.size());
  *nearest_index = cv::Mat(camera.height, camera.width, CV_32S, cv::Scalar(-1));
  *depth_m = cv::Mat::zeros(camera.height, camera.width, CV_32F);
  RasterImage raster;
  const int n = static_cast<int>(meshes.size());
  for (int k = 0; k <= n; ++k) {
    if (k < n) {
      Rasterize(*meshes[k], camera, cam_from_object[k], DepthOnlyRaster(), &raster);
    } else if (table != nullptr) {
      Rasterize(*table, camera, cam_from_world, DepthOnlyRaster(), &raster);
    } else {
      break;
    }
    for (int y = 0; y < camera.height; ++y) {
      const float* z = raster.depth.ptr<float>(y);
      float* best = depth_m->ptr<float>(y);
      int* index = nearest_index->ptr<int>(y);
      for (int x = 0; x < camera.width; ++x) {
        // Strictly nearer wins: ties keep the lower index.
        if (z[x] > 0.0f && (index[x] < 0 || z[x] < best[x])) {
          best[x] = z[x];
          index[x] = k;
        }
      }
    }
  }
}

Mesh SampleTableFor(const SampleOptions& options) {
  return MakeSampleTable(options.table_size_m, options.table_cells, options.table_tile_m,
                         DerivedSeed(options.seed, kTablePart));
}

SampleFrame RenderSampleFrame(const SampleOptions& options,
                              const std::vector<SampleObject>& objects, const Mesh& table,
                              uint64_t frame_seed) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad sample option: " << bad);
  SampleRenderers renderers(objects, table);
  return RenderFrameWith(options, objects, table, frame_seed, &renderers);
}

}  // namespace g6d
