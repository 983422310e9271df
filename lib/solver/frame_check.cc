#include "solver/frame_check.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/frame.h"
#include "render/raster.h"
#include "templates/template_bank.h"

namespace g6d {

namespace {

bool ValidDepth(float z) { return z > 0.0f && std::isfinite(z); }

// A rendering's pixels (`drawn`, CV_8U of the frame), their bounding box (`tight`) and that
// box grown by `margin` inside the image (`box`) and the grey image there (`gray`), for the
// outline's colour tests; false without colour of the rendering's size or without a rendered
// pixel.
struct OutlineCrop {
  cv::Mat drawn, gray;
  cv::Rect tight, box;
  bool Take(const cv::Mat& rendered, const cv::Mat& rgb, int margin) {
    if (rgb.empty() || rgb.type() != CV_8UC3 || rgb.size() != rendered.size()) return false;
    drawn = rendered > 0.0f;
    tight = cv::boundingRect(drawn);
    if (tight.area() == 0) return false;
    box = (tight + cv::Point(-margin, -margin) + cv::Size(2 * margin, 2 * margin)) & cv::Rect(0, 0, rendered.cols, rendered.rows);
    cv::cvtColor(rgb(box), gray, cv::COLOR_RGB2GRAY);
    return true;
  }
};

// Inside the image, a rendered pixel (u, v) of `drawn` beside an unrendered one; the image's
// border is no outline.
bool OnOutline(const cv::Mat& drawn, int u, int v) {
  const uint8_t* d = drawn.ptr<uint8_t>(v);
  if (!d[u]) return false;
  return (u > 0 && !d[u - 1]) || (u + 1 < drawn.cols && !d[u + 1]) || (v > 0 && !drawn.ptr<uint8_t>(v - 1)[u]) ||
         (v + 1 < drawn.rows && !drawn.ptr<uint8_t>(v + 1)[u]);
}

}  // namespace

double FreeSpaceBand(const cv::Mat& rendered, const cv::Mat& observed, float tolerance_m) {
  const cv::Mat drawn = rendered > 0.0f;
  const cv::Rect tight = cv::boundingRect(drawn);
  int outline = 0, behind = 0;
  for (int v = tight.y; v < tight.y + tight.height; ++v) {
    const float* r = rendered.ptr<float>(v);
    const float* z = observed.ptr<float>(v);
    for (int u = tight.x; u < tight.x + tight.width; ++u) {
      if (!(r[u] > 0.0f)) continue;
      outline += OnOutline(drawn, u, v);
      behind += ValidDepth(z[u]) && z[u] > r[u] + tolerance_m;
    }
  }
  return outline > 0 ? static_cast<double>(behind) / outline : 0.0;
}

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

double EdgeSupport(const cv::Mat& rendered, const cv::Mat& rgb, int reach_px, double threshold, double* interior_share) {
  if (interior_share != nullptr) *interior_share = 0.0;
  // Canny's hysteresis reaches a few pixels: a margin beyond the reach keeps the crop's own
  // border out of the outline's neighbourhood.
  OutlineCrop crop;
  if (!crop.Take(rendered, rgb, reach_px + 4)) return 0.0;
  const cv::Mat& drawn = crop.drawn;
  const cv::Rect &tight = crop.tight, &box = crop.box;
  cv::Mat edges;
  cv::Canny(crop.gray, edges, threshold, 2.0 * threshold);
  if (reach_px > 0) {
    cv::dilate(edges, edges, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * reach_px + 1, 2 * reach_px + 1)));
  }
  int outline = 0, edged = 0;
  for (int v = tight.y; v < tight.y + tight.height; ++v) {
    const uint8_t* e = edges.ptr<uint8_t>(v - box.y);
    for (int u = tight.x; u < tight.x + tight.width; ++u) {
      if (!OnOutline(drawn, u, v)) continue;
      ++outline;
      edged += e[u - box.x] != 0;
    }
  }
  if (interior_share != nullptr) {
    // The interior beyond the outline's own edge (dilated by reach_px): what the outline
    // would meet by chance.
    const int in = reach_px + 2;
    cv::Mat interior;
    cv::erode(drawn(box), interior, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * in + 1, 2 * in + 1)));
    const int pixels = cv::countNonZero(interior);
    if (pixels > 0) *interior_share = static_cast<double>(cv::countNonZero(interior & edges)) / pixels;
  }
  return outline > 0 ? static_cast<double>(edged) / outline : 0.0;
}

double OrientedEdgeSupport(const cv::Mat& rendered, const cv::Mat& rgb, int reach_px, double threshold, double* chance) {
  if (chance != nullptr) *chance = 0.0;
  OutlineCrop crop;
  if (!crop.Take(rendered, rgb, reach_px + 2)) return 0.0;
  const cv::Mat& drawn = crop.drawn;
  const cv::Rect& box = crop.box;
  cv::Mat gx, gy;
  cv::Sobel(crop.gray, gx, CV_32F, 1, 0, 3);
  cv::Sobel(crop.gray, gy, CV_32F, 0, 1, 3);
  // The outline's normals: the gradient of the signed distance to it (inward).
  const cv::Mat inside = drawn(box);
  cv::Mat inner, outer, outside;
  cv::bitwise_not(inside, outside);
  cv::distanceTransform(inside, inner, cv::DIST_L2, 5);
  cv::distanceTransform(outside, outer, cv::DIST_L2, 5);
  const cv::Mat signed_distance = inner - outer;
  cv::Mat nx, ny;
  cv::Sobel(signed_distance, nx, CV_32F, 1, 0, 3);
  cv::Sobel(signed_distance, ny, CV_32F, 0, 1, 3);
  const float min_cos = static_cast<float>(std::cos(kOutlineEdgeAngleDeg * M_PI / 180.0));
  const float min_magnitude = static_cast<float>(threshold);
  // Is the strongest gradient across (x, y) (crop coordinates) at least the threshold and along the normal?
  auto along = [&](int x, int y) -> int {  // -1: no normal there
    const float a = nx.at<float>(y, x), b = ny.at<float>(y, x);
    const float length = std::sqrt(a * a + b * b);
    if (!(length > 0.0f)) return -1;
    const float ux = a / length, uy = b / length;
    float best = 0.0f, best_cos = 0.0f;
    for (int k = -reach_px; k <= reach_px; ++k) {
      const int qx = x + static_cast<int>(std::lround(k * ux)), qy = y + static_cast<int>(std::lround(k * uy));
      if (qx < 0 || qy < 0 || qx >= box.width || qy >= box.height) continue;
      const float g = gx.at<float>(qy, qx), h = gy.at<float>(qy, qx);
      const float magnitude = std::sqrt(g * g + h * h);
      if (magnitude > best) best = magnitude, best_cos = std::abs(g * ux + h * uy) / magnitude;
    }
    return best >= min_magnitude && best_cos >= min_cos ? 1 : 0;
  };
  int outline = 0, edged = 0, ring = 0, ring_edged = 0;
  const float ring_from = static_cast<float>(reach_px + 3), ring_to = ring_from + 1.0f;
  for (int y = 0; y < box.height; ++y) {
    const int v = y + box.y;
    const uint8_t* d = drawn.ptr<uint8_t>(v);
    const float* depth_in = inner.ptr<float>(y);
    for (int x = 0; x < box.width; ++x) {
      const int u = x + box.x;
      if (!d[u]) continue;
      if (OnOutline(drawn, u, v)) {
        const int hit = along(x, y);
        if (hit < 0) continue;
        ++outline;
        edged += hit;
      } else if (chance != nullptr && depth_in[x] >= ring_from && depth_in[x] < ring_to) {
        const int hit = along(x, y);
        if (hit < 0) continue;
        ++ring;
        ring_edged += hit;
      }
    }
  }
  if (chance != nullptr && ring > 0) *chance = static_cast<double>(ring_edged) / ring;
  return outline > 0 ? static_cast<double>(edged) / outline : 0.0;
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
  check.free_space_band_px = FreeSpaceBand(raster.depth, frame.depth, tolerance);
  check.contour_support = ContourSupport(raster.depth, frame.depth, 2, static_cast<float>(step_m));
  check.edge_support = EdgeSupport(raster.depth, frame.rgb, kOutlineEdgeReachPx, kOutlineEdgeThreshold, &check.edge_chance);
  check.oriented_edge = OrientedEdgeSupport(raster.depth, frame.rgb, kOutlineEdgeReachPx, kOutlineEdgeThreshold,
                                            &check.oriented_edge_chance);
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
