#include "solver/frame_check.h"

#include <cmath>

#include "core/frame.h"
#include "render/raster.h"
#include "templates/template_bank.h"

namespace g6d {

namespace {

bool ValidDepth(float z) { return z > 0.0f && std::isfinite(z); }

}  // namespace

double ContourSupport(const cv::Mat& rendered, const cv::Mat& observed, int gap, float step_m) {
  int outline = 0, stepped = 0;
  const int rows = rendered.rows, cols = rendered.cols;
  static const int kDu[4] = {1, -1, 0, 0}, kDv[4] = {0, 0, 1, -1};
  for (int v = 0; v < rows; ++v) {
    const float* r = rendered.ptr<float>(v);
    for (int u = 0; u < cols; ++u) {
      if (!(r[u] > 0.0f)) continue;
      for (int k = 0; k < 4; ++k) {
        const int x = u + kDu[k] * gap, y = v + kDv[k] * gap;
        const int x1 = u + kDu[k], y1 = v + kDv[k];
        if (x < 0 || y < 0 || x >= cols || y >= rows) continue;
        if (rendered.at<float>(y1, x1) > 0.0f || rendered.at<float>(y, x) > 0.0f) continue;
        const float z = observed.at<float>(y, x);
        if (!ValidDepth(z)) break;  // no depth says nothing either way
        ++outline;
        stepped += std::abs(z - r[u]) > step_m;
        break;
      }
    }
  }
  return outline > 0 ? static_cast<double>(stepped) / outline : 0.0;
}

FrameCheck CheckAgainstFrame(const Frame& frame, const TemplateBank& bank, const Eigen::Isometry3d& cam_from_object,
                             double surface_m, double step_m) {
  FrameCheck check;
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  raster_options.cull_backfaces = bank.online_mesh_closed;
  RasterImage raster;
  Rasterize(bank.online_mesh, frame.camera, cam_from_object, raster_options, &raster);
  const float tolerance = static_cast<float>(surface_m);
  int on_surface = 0, free_space = 0;
  for (int v = 0; v < raster.depth.rows; ++v) {
    const float* rendered = raster.depth.ptr<float>(v);
    const float* observed = frame.depth.ptr<float>(v);
    for (int u = 0; u < raster.depth.cols; ++u) {
      if (!(rendered[u] > 0.0f) || !ValidDepth(observed[u])) continue;
      ++check.rendered_pixels;
      if (observed[u] > rendered[u] + tolerance) ++free_space;
      else if (observed[u] >= rendered[u] - tolerance) ++on_surface;
    }
  }
  if (check.rendered_pixels > 0) {
    check.on_surface = static_cast<double>(on_surface) / check.rendered_pixels;
    check.free_space = static_cast<double>(free_space) / check.rendered_pixels;
  }
  check.contour_support = ContourSupport(raster.depth, frame.depth, 2, static_cast<float>(step_m));
  const std::vector<Eigen::Vector3f>& surface = bank.ppf.empty() ? bank.online_mesh.vertices : bank.ppf.points;
  int inside = 0;
  for (const Eigen::Vector3f& point : surface) {
    const Eigen::Vector3d p = cam_from_object * point.cast<double>();
    if (!(p.z() > 0.0)) continue;
    const Eigen::Vector2d uv = frame.camera.Project(p);
    inside += uv.x() >= 0.0 && uv.y() >= 0.0 && uv.x() < frame.camera.width && uv.y() < frame.camera.height;
  }
  if (!surface.empty()) check.in_image = static_cast<double>(inside) / static_cast<double>(surface.size());
  return check;
}

}  // namespace g6d
