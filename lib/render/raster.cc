#include "render/raster.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "core/error.h"

namespace g6d {
namespace {

// Vertices are snapped to 1/256 pixel, as GPUs do, so that coverage is decided with exact
// integer edge functions: a pixel centre on a shared edge is then tested identically by
// both triangles and the fill rule gives it to exactly one of them (no cracks).
constexpr int kSubpixelBits = 8;
constexpr int64_t kSubpixelOne = int64_t{1} << kSubpixelBits;  // one pixel, fixed point
constexpr int64_t kSubpixelHalf = kSubpixelOne / 2;            // pixel centre offset
// Fixed-point coordinates stay below 2^29 in magnitude, so edge-function differences stay
// below 2^30 and their products below 2^61: int64 never overflows.
constexpr double kMaxAbsPixel = static_cast<double>(1 << 21);

// Image coordinate to fixed point, rounding half away from zero. Inline arithmetic rather
// than std::llround, which is a library call. |x| < kMaxAbsPixel, so no overflow.
inline int32_t RoundToFixed(double x) {
  const double scaled = x * kSubpixelOne;
  return static_cast<int32_t>(scaled >= 0.0 ? scaled + 0.5 : scaled - 0.5);
}

// Smallest integer u with u * kSubpixelOne + kSubpixelHalf >= fixed.
int64_t FirstPixelAtOrAfter(int64_t fixed) {
  const int64_t n = fixed - kSubpixelHalf;
  return n >= 0 ? (n + kSubpixelOne - 1) >> kSubpixelBits : -((-n) >> kSubpixelBits);
}
// Largest integer u with u * kSubpixelOne + kSubpixelHalf <= fixed.
int64_t LastPixelAtOrBefore(int64_t fixed) {
  const int64_t n = fixed - kSubpixelHalf;
  return n >= 0 ? n >> kSubpixelBits : -((-n + kSubpixelOne - 1) >> kSubpixelBits);
}

// Edge function E_ab(p) = (b - a) x (p - a), z component; y points down in the image.
inline int64_t EdgeFunction(int64_t ax, int64_t ay, int64_t bx, int64_t by, int64_t px,
                            int64_t py) {
  return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

// Top-left rule for triangles with EdgeFunction(a, b, c) > 0 (clockwise as displayed,
// y down): an edge a->b owns the pixel centres lying exactly on it when it is a top edge
// (horizontal, going right) or a left edge (going up). The predicate is antisymmetric, so
// of two triangles sharing an edge exactly one owns it.
inline bool OwnsEdge(int64_t ax, int64_t ay, int64_t bx, int64_t by) {
  const int64_t dy = by - ay;
  return dy < 0 || (dy == 0 && bx - ax > 0);
}

// Triangle setup shared by all pixels of one face.
struct TriangleSetup {
  int64_t u_begin, u_end, v_begin, v_end;            // inclusive pixel box, inside the image
  int64_t w0_row, w1_row, w2_row;                    // biased edge functions at (u_begin, v_begin)
  int64_t w0_du, w0_dv, w1_du, w1_dv, w2_du, w2_dv;  // their steps per pixel
  double inv_z_du, inv_z_dv, inv_z_0;                // 1/z = inv_z_0 + inv_z_du x + inv_z_dv y
  double inv_z_min, inv_z_max;                       // 1/z range of the triangle's vertices
};

// Scans the pixel box of one triangle into the inverse-depth buffer (larger 1/z is
// nearer; 0 means empty, so an empty pixel needs no special case).
template <bool kWantFaceId>
void ScanTriangle(const TriangleSetup& t, int face, cv::Mat* inverse_depth, cv::Mat* face_id) {
  int64_t w0_row = t.w0_row, w1_row = t.w1_row, w2_row = t.w2_row;
  for (int64_t v = t.v_begin; v <= t.v_end; ++v) {
    float* depth_row = inverse_depth->ptr<float>(static_cast<int>(v));
    int32_t* face_row = kWantFaceId ? face_id->ptr<int32_t>(static_cast<int>(v)) : nullptr;
    int64_t w0 = w0_row, w1 = w1_row, w2 = w2_row;
    double inv_z = t.inv_z_0 + t.inv_z_dv * (static_cast<double>(v) + 0.5) +
                   t.inv_z_du * (static_cast<double>(t.u_begin) + 0.5);
    for (int64_t u = t.u_begin; u <= t.u_end; ++u) {
      // Branch-free on purpose: along small triangles' rows inside/outside alternates, and
      // where front and back faces overlap the depth test does too; with branches (even
      // the one GCC makes of a float select) this loop measured 1.2-3x slower. Outside pixels
      // get value +0 (bits masked off), which never wins against the stored 1/z >= 0, so
      // the depth test is a plain max.
      // Centres covered only because of snapping may fall just outside the true triangle,
      // where a grazing plane has wild depth: clamp to the triangle's own range.
      const float clamped = static_cast<float>(std::clamp(inv_z, t.inv_z_min, t.inv_z_max));
      const uint32_t outside = static_cast<uint32_t>((w0 | w1 | w2) < 0);
      uint32_t bits;
      std::memcpy(&bits, &clamped, sizeof(bits));
      bits &= outside - 1u;  // all ones inside, zero outside
      float value;
      std::memcpy(&value, &bits, sizeof(value));
      const float current = depth_row[u];
      depth_row[u] = std::max(current, value);
      if (kWantFaceId) {
        const int32_t take = -static_cast<int32_t>(value > current);  // all ones or zero
        face_row[u] = (face & take) | (face_row[u] & ~take);
      }
      w0 += t.w0_du;
      w1 += t.w1_du;
      w2 += t.w2_du;
      inv_z += t.inv_z_du;
    }
    w0_row += t.w0_dv;
    w1_row += t.w1_dv;
    w2_row += t.w2_dv;
  }
}

// Turns 1/z into z in place inside `box` (the rest of the image is untouched, still 0)
// and returns the number of covered pixels. Written so that the compiler vectorizes it.
int InverseToDepth(const cv::Rect& box, cv::Mat* depth) {
  int count = 0;
  for (int v = box.y; v < box.y + box.height; ++v) {
    float* row = depth->ptr<float>(v);
    for (int u = box.x; u < box.x + box.width; ++u) {
      const float inverse = row[u];
      const bool covered = inverse > 0.0f;
      row[u] = covered ? 1.0f / inverse : 0.0f;
      count += covered ? 1 : 0;
    }
  }
  return count;
}

}  // namespace

cv::Mat RasterImage::Mask() const {
  cv::Mat mask;
  if (!depth.empty()) mask = depth > 0.0f;
  return mask;
}

std::string RasterOptions::Check() const {
  std::ostringstream out;
  if (!std::isfinite(near_m) || near_m <= 0.0) {
    out << "near_m must be finite and > 0 (got " << near_m << ")";
  }
  return out.str();
}

void Rasterize(const Mesh& mesh, const Camera& camera, const Eigen::Isometry3d& cam_from_object,
               const RasterOptions& options, RasterImage* out) {
  G6D_CHECK(out != nullptr);
  if (const std::string error = camera.Check(); !error.empty()) {
    G6D_THROW("Rasterize: bad camera: " << error);
  }
  if (const std::string error = options.Check(); !error.empty()) {
    G6D_THROW("Rasterize: bad RasterOptions: " << error);
  }
  const int width = camera.width;
  const int height = camera.height;

  // Outputs: create() reallocates only when the size or type changed. `depth` holds 1/z
  // while scanning and is converted to z at the end.
  out->depth.create(height, width, CV_32F);
  out->depth.setTo(0.0f);
  if (options.want_face_id) {
    out->face_id.create(height, width, CV_32S);
    out->face_id.setTo(-1);
  } else {
    out->face_id.release();
  }
  out->pixel_count = 0;

  // Transform and project every vertex once.
  const Eigen::Matrix3d rotation = cam_from_object.linear();
  const Eigen::Vector3d translation = cam_from_object.translation();
  std::vector<internal::RasterVertex>& vertices = out->scratch;
  vertices.resize(mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    internal::RasterVertex& vertex = vertices[i];
    vertex.point_in_cam = rotation * mesh.vertices[i].cast<double>() + translation;
    const double z = vertex.point_in_cam.z();
    vertex.usable = false;
    if (!(z >= options.near_m)) continue;  // also rejects NaN
    vertex.inverse_z = 1.0 / z;
    const double x = camera.fx * vertex.point_in_cam.x() * vertex.inverse_z + camera.cx;
    const double y = camera.fy * vertex.point_in_cam.y() * vertex.inverse_z + camera.cy;
    if (!(std::abs(x) < kMaxAbsPixel && std::abs(y) < kMaxAbsPixel)) continue;
    vertex.x_fixed = RoundToFixed(x);
    vertex.y_fixed = RoundToFixed(y);
    vertex.usable = true;
  }

  const double inv_fx = 1.0 / camera.fx;
  const double inv_fy = 1.0 / camera.fy;
  const int num_vertices = static_cast<int>(vertices.size());
  const int num_faces = static_cast<int>(mesh.faces.size());
  int64_t touched_u_begin = width, touched_u_end = -1;  // union of the scanned boxes
  int64_t touched_v_begin = height, touched_v_end = -1;
  TriangleSetup t;
  for (int face = 0; face < num_faces; ++face) {
    const Eigen::Vector3i& indices = mesh.faces[face];
    for (int k = 0; k < 3; ++k) {
      if (indices[k] < 0 || indices[k] >= num_vertices) {
        G6D_THROW("Rasterize: face " << face << " has vertex index " << indices[k]
                                     << " outside [0, " << num_vertices << ")");
      }
    }
    const internal::RasterVertex* v0 = &vertices[indices[0]];
    const internal::RasterVertex* v1 = &vertices[indices[1]];
    const internal::RasterVertex* v2 = &vertices[indices[2]];
    if (!(v0->usable && v1->usable && v2->usable)) continue;

    int64_t area =
        EdgeFunction(v0->x_fixed, v0->y_fixed, v1->x_fixed, v1->y_fixed, v2->x_fixed, v2->y_fixed);
    if (area == 0) continue;  // degenerate on screen (edge-on or collapsed by snapping)
    // area > 0: clockwise as displayed (y down), i.e. the counter-clockwise face is seen
    // from behind.
    if (area > 0 && options.cull_backfaces) continue;
    if (area < 0) std::swap(v1, v2);

    const int64_t x0 = v0->x_fixed, y0 = v0->y_fixed;
    const int64_t x1 = v1->x_fixed, y1 = v1->y_fixed;
    const int64_t x2 = v2->x_fixed, y2 = v2->y_fixed;

    // Pixel box of the centres inside the snapped triangle, clipped to the image.
    t.u_begin = std::max<int64_t>(0, FirstPixelAtOrAfter(std::min({x0, x1, x2})));
    t.u_end = std::min<int64_t>(width - 1, LastPixelAtOrBefore(std::max({x0, x1, x2})));
    t.v_begin = std::max<int64_t>(0, FirstPixelAtOrAfter(std::min({y0, y1, y2})));
    t.v_end = std::min<int64_t>(height - 1, LastPixelAtOrBefore(std::max({y0, y1, y2})));
    if (t.u_begin > t.u_end || t.v_begin > t.v_end) continue;

    // Depth from the unsnapped 3D plane n . X = d of the triangle: on the ray
    // X = z ((x - cx) / fx, (y - cy) / fy, 1) through image point (x, y),
    // 1 / z = (n . ray) / d is affine in (x, y), so it is stepped exactly per pixel and
    // needs no division there.
    const Eigen::Vector3d& p0 = v0->point_in_cam;
    const Eigen::Vector3d& p1 = v1->point_in_cam;
    const Eigen::Vector3d& p2 = v2->point_in_cam;
    const Eigen::Vector3d normal = (p1 - p0).cross(p2 - p0);
    const double plane_d = normal.dot(p0);
    if (plane_d == 0.0) continue;  // plane through the camera centre: seen edge-on
    const double inv_d = 1.0 / plane_d;
    const double a = normal.x() * inv_fx * inv_d;
    const double b = normal.y() * inv_fy * inv_d;
    t.inv_z_du = a;
    t.inv_z_dv = b;
    t.inv_z_0 = normal.z() * inv_d - a * camera.cx - b * camera.cy;
    t.inv_z_min = std::min({v0->inverse_z, v1->inverse_z, v2->inverse_z});
    t.inv_z_max = std::max({v0->inverse_z, v1->inverse_z, v2->inverse_z});

    // Edge functions at the first pixel centre; w_k is opposite vertex k. A centre is
    // inside when every w_k >= 0 after the fill-rule bias (-1 on edges not owned, which
    // turns >= into > for integers).
    const int64_t px = t.u_begin * kSubpixelOne + kSubpixelHalf;
    const int64_t py = t.v_begin * kSubpixelOne + kSubpixelHalf;
    t.w0_row = EdgeFunction(x1, y1, x2, y2, px, py) - (OwnsEdge(x1, y1, x2, y2) ? 0 : 1);
    t.w1_row = EdgeFunction(x2, y2, x0, y0, px, py) - (OwnsEdge(x2, y2, x0, y0) ? 0 : 1);
    t.w2_row = EdgeFunction(x0, y0, x1, y1, px, py) - (OwnsEdge(x0, y0, x1, y1) ? 0 : 1);
    // d E_ab / d px = -(by - ay), d E_ab / d py = bx - ax, times one pixel.
    t.w0_du = -(y2 - y1) * kSubpixelOne;
    t.w0_dv = (x2 - x1) * kSubpixelOne;
    t.w1_du = -(y0 - y2) * kSubpixelOne;
    t.w1_dv = (x0 - x2) * kSubpixelOne;
    t.w2_du = -(y1 - y0) * kSubpixelOne;
    t.w2_dv = (x1 - x0) * kSubpixelOne;

    if (options.want_face_id) {
      ScanTriangle<true>(t, face, &out->depth, &out->face_id);
    } else {
      ScanTriangle<false>(t, face, &out->depth, nullptr);
    }
    touched_u_begin = std::min(touched_u_begin, t.u_begin);
    touched_u_end = std::max(touched_u_end, t.u_end);
    touched_v_begin = std::min(touched_v_begin, t.v_begin);
    touched_v_end = std::max(touched_v_end, t.v_end);
  }
  if (touched_u_begin <= touched_u_end) {
    const cv::Rect touched(static_cast<int>(touched_u_begin), static_cast<int>(touched_v_begin),
                           static_cast<int>(touched_u_end - touched_u_begin + 1),
                           static_cast<int>(touched_v_end - touched_v_begin + 1));
    out->pixel_count = InverseToDepth(touched, &out->depth);
  }
}

}  // namespace g6d
