#include "templates/appearance.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "render/raster.h"

namespace g6d {
namespace {

// Bilinear sample of a CV_8UC3 image at continuous image coordinates (x, y) with pixel
// centres at +0.5 (the BOP convention of camera.h), clamped at the border; RGB in [0, 1].
Eigen::Vector3f SampleBilinear(const cv::Mat& image, double x, double y) {
  const double px = std::clamp(x - 0.5, 0.0, static_cast<double>(image.cols - 1));
  const double py = std::clamp(y - 0.5, 0.0, static_cast<double>(image.rows - 1));
  const int x0 = std::min(static_cast<int>(px), image.cols - 1);
  const int y0 = std::min(static_cast<int>(py), image.rows - 1);
  const int x1 = std::min(x0 + 1, image.cols - 1);
  const int y1 = std::min(y0 + 1, image.rows - 1);
  const float ax = static_cast<float>(px - x0), ay = static_cast<float>(py - y0);
  const uint8_t* row0 = image.ptr<uint8_t>(y0);
  const uint8_t* row1 = image.ptr<uint8_t>(y1);
  Eigen::Vector3f color;
  for (int c = 0; c < 3; ++c) {
    const float top = (1.0f - ax) * row0[3 * x0 + c] + ax * row0[3 * x1 + c];
    const float bottom = (1.0f - ax) * row1[3 * x0 + c] + ax * row1[3 * x1 + c];
    color[c] = ((1.0f - ay) * top + ay * bottom) * (1.0f / 255.0f);
  }
  return color;
}

// Texture colour at (u, v) in OBJ convention (v up; row 0 of the image is v = 1). UVs
// outside [0, 1] repeat, as OBJ's default wrap does.
Eigen::Vector3f SampleTexture(const cv::Mat& texture, double u, double v) {
  if (u < 0.0 || u > 1.0) u -= std::floor(u);
  if (v < 0.0 || v > 1.0) v -= std::floor(v);
  return SampleBilinear(texture, u * texture.cols, (1.0 - v) * texture.rows);
}

void CheckFaces(const Mesh& mesh, const char* where) {
  const int vertex_count = static_cast<int>(mesh.vertices.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Eigen::Vector3i& face = mesh.faces[f];
    if (face.minCoeff() < 0 || face.maxCoeff() >= vertex_count) {
      G6D_THROW(where << ": face " << f << " has a vertex index out of range [0, " << vertex_count
                      << ") (got " << face.transpose() << ")");
    }
  }
}

// Regularizer of the chromaticity c / (R + G + B + kChromaEpsilon), RGB in [0, 1]: the
// chromaticity of a nearly black pixel is mostly sensor noise, this keeps it near 0.
constexpr double kChromaEpsilon = 0.03;

// Sums for the zero-mean normalized cross-correlation (ZNCC) of six paired channels: R, G,
// B and the three chromaticities. One pass; doubles make the cancellation in
// sum_ab - sum_a sum_b / n harmless for values in [0, 1] and a few thousand samples.
struct CorrelationSums {
  int count = 0;
  Eigen::Matrix<double, 6, 1> a = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> aa = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> bb = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> ab = Eigen::Matrix<double, 6, 1>::Zero();

  static Eigen::Matrix<double, 6, 1> Channels(const Eigen::Vector3f& rgb) {
    const Eigen::Vector3d color = rgb.cast<double>();
    Eigen::Matrix<double, 6, 1> channels;
    channels << color, color / (color.sum() + kChromaEpsilon);
    return channels;
  }
  void Add(const Eigen::Vector3f& model_rgb, const Eigen::Vector3f& observed_rgb) {
    const Eigen::Matrix<double, 6, 1> x = Channels(model_rgb), y = Channels(observed_rgb);
    ++count;
    a += x;
    b += y;
    aa += x.cwiseAbs2();
    bb += y.cwiseAbs2();
    ab += x.cwiseProduct(y);
  }
  // Standard deviation of the model (a) or observed (b) values of channel k.
  double StdA(int k) const {
    return std::sqrt(std::max(0.0, aa[k] / count - Square(a[k] / count)));
  }
  double StdB(int k) const {
    return std::sqrt(std::max(0.0, bb[k] / count - Square(b[k] / count)));
  }
  // ZNCC of channel k in [-1, 1]; 0 when either side is constant.
  double Zncc(int k) const {
    const double covariance = ab[k] / count - (a[k] / count) * (b[k] / count);
    const double denominator = StdA(k) * StdB(k);
    return denominator > 0.0 ? std::clamp(covariance / denominator, -1.0, 1.0) : 0.0;
  }
  static double Square(double x) { return x * x; }
};

// Calls visit(model_index, x, y) for every sample of `model` that ScoreAppearance()
// compares at cam_from_object: facing the camera, visible, away from silhouette edges and
// inside the mask; (x, y) are its continuous image coordinates. Checks the arguments.
template <typename Visit>
void ForEachComparedSample(const AppearanceOptions& options, const AppearanceModel& model,
                           const Mesh& online_mesh, const Camera& camera, const cv::Mat& rgb,
                           const cv::Mat& mask, const Eigen::Isometry3d& cam_from_object,
                           RasterImage* rendered, Visit&& visit) {
  if (const std::string problem = options.Check(); !problem.empty()) {
    G6D_THROW("ScoreAppearance: " << problem);
  }
  if (const std::string problem = camera.Check(); !problem.empty()) {
    G6D_THROW("ScoreAppearance: camera: " << problem);
  }
  if (rgb.type() != CV_8UC3 || rgb.cols != camera.width || rgb.rows != camera.height) {
    G6D_THROW("ScoreAppearance: rgb must be CV_8UC3 of the camera's size "
              << camera.width << "x" << camera.height << " (got type " << rgb.type() << ", "
              << rgb.cols << "x" << rgb.rows << ")");
  }
  if (mask.type() != CV_8U || mask.cols != camera.width || mask.rows != camera.height) {
    G6D_THROW("ScoreAppearance: mask must be CV_8U of the camera's size "
              << camera.width << "x" << camera.height << " (got type " << mask.type() << ", "
              << mask.cols << "x" << mask.rows << ")");
  }
  G6D_CHECK(model.normals.size() == model.points.size() &&
            model.colors.size() == model.points.size());
  if (model.Empty()) return;
  const cv::Rect box = cv::boundingRect(mask);
  if (box.area() == 0) return;

  // Visibility: the online mesh rasterized on the mask box, downscaled to the grid size.
  // Samples outside the mask box are never compared, so the grid need not extend beyond it.
  const double scale = std::min(
      1.0, static_cast<double>(options.grid_max_side_px) / std::max(box.width, box.height));
  const Camera grid_camera = camera.Cropped(box.x, box.y, box.width, box.height).Scaled(scale);
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  Rasterize(online_mesh, grid_camera, cam_from_object, raster_options, rendered);

  const Eigen::Matrix3f rotation = cam_from_object.linear().cast<float>();
  const Eigen::Vector3f translation = cam_from_object.translation().cast<float>();
  const float tolerance = static_cast<float>(options.visibility_tolerance_m);
  const float min_facing_cos = static_cast<float>(options.min_facing_cos);
  const int margin = options.edge_margin_px;
  for (size_t i = 0; i < model.points.size(); ++i) {
    const Eigen::Vector3f point_in_cam = rotation * model.points[i] + translation;
    if (!(point_in_cam.z() > 0.0f)) continue;
    // Facing: the normal points towards the camera centre by at least min_facing_cos.
    const Eigen::Vector3f normal_in_cam = rotation * model.normals[i];
    if (-normal_in_cam.dot(point_in_cam) < min_facing_cos * point_in_cam.norm()) continue;
    const double inverse_z = 1.0 / point_in_cam.z();
    const double x = camera.fx * point_in_cam.x() * inverse_z + camera.cx;
    const double y = camera.fy * point_in_cam.y() * inverse_z + camera.cy;
    if (!(x >= 0.0 && y >= 0.0 && x < camera.width && y < camera.height)) continue;
    // Inside the mask, `margin` image pixels away from its border in the four directions.
    const int u = static_cast<int>(std::floor(x)), v = static_cast<int>(std::floor(y));
    if (u < margin || v < margin || u + margin >= mask.cols || v + margin >= mask.rows) continue;
    if (!mask.at<uint8_t>(v, u) || !mask.at<uint8_t>(v - margin, u) ||
        !mask.at<uint8_t>(v + margin, u) || !mask.at<uint8_t>(v, u - margin) ||
        !mask.at<uint8_t>(v, u + margin)) {
      continue;
    }
    // The grid pixel containing the point (grid camera = crop then scale of this camera).
    const int grid_u = static_cast<int>((x - box.x) * scale);
    const int grid_v = static_cast<int>((y - box.y) * scale);
    if (grid_u < margin || grid_v < margin || grid_u + margin >= grid_camera.width ||
        grid_v + margin >= grid_camera.height) {
      continue;
    }
    const float surface_m = rendered->depth.at<float>(grid_v, grid_u);
    if (!(surface_m > 0.0f) || point_in_cam.z() > surface_m + tolerance) continue;
    // Away from the rendered silhouette and from depth steps (self-occlusion edges): there
    // a small pose or mask error mixes in the colour of whatever lies beside the object.
    bool interior = true;
    for (int dv = -margin; dv <= margin && interior; ++dv) {
      const float* row = rendered->depth.ptr<float>(grid_v + dv);
      for (int du = -margin; du <= margin; ++du) {
        const float neighbour_m = row[grid_u + du];
        if (!(neighbour_m > 0.0f) || std::abs(neighbour_m - surface_m) > tolerance) {
          interior = false;
          break;
        }
      }
    }
    if (interior) visit(i, x, y);
  }
}

}  // namespace

std::string AppearanceOptions::Check() const {
  std::ostringstream out;
  if (sample_points < 1 || sample_points > 10000000) {
    out << "AppearanceOptions.sample_points must be in [1, 1e7] (got " << sample_points << ")";
  } else if (!(min_color_std >= 0.0 && min_color_std < 0.5)) {
    out << "AppearanceOptions.min_color_std must be in [0, 0.5) (got " << min_color_std << ")";
  } else if (texture_max_side_px < 1) {
    out << "AppearanceOptions.texture_max_side_px must be >= 1 (got " << texture_max_side_px << ")";
  } else if (grid_max_side_px < 8 || grid_max_side_px > 4096) {
    out << "AppearanceOptions.grid_max_side_px must be in [8, 4096] (got " << grid_max_side_px
        << ")";
  } else if (!(visibility_tolerance_m > 0.0 && std::isfinite(visibility_tolerance_m))) {
    out << "AppearanceOptions.visibility_tolerance_m must be finite and > 0 (got "
        << visibility_tolerance_m << ")";
  } else if (!(min_facing_cos >= 0.0 && min_facing_cos < 1.0)) {
    out << "AppearanceOptions.min_facing_cos must be in [0, 1) (got " << min_facing_cos << ")";
  } else if (!(min_chroma_std >= 0.0 && min_chroma_std < 0.5)) {
    out << "AppearanceOptions.min_chroma_std must be in [0, 0.5) (got " << min_chroma_std << ")";
  } else if (edge_margin_px < 0 || edge_margin_px > 16) {
    out << "AppearanceOptions.edge_margin_px must be in [0, 16] (got " << edge_margin_px << ")";
  } else if (min_visible_points < 2) {
    out << "AppearanceOptions.min_visible_points must be >= 2 (got " << min_visible_points << ")";
  }
  return out.str();
}

AppearanceModel SampleAppearance(const Mesh& mesh, const AppearanceOptions& options) {
  if (const std::string problem = options.Check(); !problem.empty()) {
    G6D_THROW("SampleAppearance: " << problem);
  }
  CheckFaces(mesh, "SampleAppearance");
  const bool textured = mesh.HasTexture() && mesh.uvs.size() == mesh.vertices.size();
  const bool coloured = mesh.colors.size() == mesh.vertices.size() && !mesh.colors.empty();
  AppearanceModel model;
  if (!textured && !coloured) return model;
  if (textured && mesh.texture.type() != CV_8UC3) {
    G6D_THROW("SampleAppearance: the texture must be CV_8UC3 (got type " << mesh.texture.type()
                                                                         << ")");
  }

  cv::Mat texture;
  if (textured) {
    // Area averaging is the low-pass filter: see AppearanceOptions::texture_max_side_px.
    const int longer = std::max(mesh.texture.cols, mesh.texture.rows);
    if (longer > options.texture_max_side_px) {
      const double scale = static_cast<double>(options.texture_max_side_px) / longer;
      cv::resize(mesh.texture, texture,
                 cv::Size(std::max(1, static_cast<int>(std::lround(mesh.texture.cols * scale))),
                          std::max(1, static_cast<int>(std::lround(mesh.texture.rows * scale)))),
                 0.0, 0.0, cv::INTER_AREA);
    } else {
      texture = mesh.texture;
    }
  }

  // The shared area-weighted sampler, which also gives the face to interpolate colours on.
  const std::vector<SurfaceSample> samples = [&] {
    try {
      return SampleSurfaceFaces(mesh, options.sample_points, options.seed);
    } catch (const Error& e) {
      G6D_THROW("SampleAppearance: " << e.what());
    }
  }();
  const bool with_vertex_normals = mesh.normals.size() == mesh.vertices.size();
  const size_t count = samples.size();
  model.points.reserve(count);
  model.normals.reserve(count);
  model.colors.reserve(count);
  for (const SurfaceSample& sample : samples) {
    const Eigen::Vector3i& face = mesh.faces[static_cast<size_t>(sample.face)];
    const double w0 = sample.weights[0], w1 = sample.weights[1], w2 = sample.weights[2];
    const Eigen::Vector3d a = mesh.vertices[face[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[face[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[face[2]].cast<double>();
    model.points.push_back((w0 * a + w1 * b + w2 * c).cast<float>());
    Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
    // Files with vertex normals tell the outside even where a face's winding is wrong.
    if (with_vertex_normals && normal.dot(w0 * mesh.normals[face[0]].cast<double>() +
                                          w1 * mesh.normals[face[1]].cast<double>() +
                                          w2 * mesh.normals[face[2]].cast<double>()) < 0.0) {
      normal = -normal;
    }
    model.normals.push_back(normal.cast<float>());
    if (textured) {
      const Eigen::Vector2d uv = w0 * mesh.uvs[face[0]].cast<double>() +
                                 w1 * mesh.uvs[face[1]].cast<double>() +
                                 w2 * mesh.uvs[face[2]].cast<double>();
      model.colors.push_back(SampleTexture(texture, uv.x(), uv.y()));
    } else {
      const Eigen::Vector3d color = w0 * mesh.colors[face[0]].cast<double>() +
                                    w1 * mesh.colors[face[1]].cast<double>() +
                                    w2 * mesh.colors[face[2]].cast<double>();
      model.colors.push_back(color.cast<float>());
    }
    // The cache stores 8-bit colours: keep them on that grid here, so a bank just built
    // answers exactly as the same bank saved and loaded.
    for (int i = 0; i < 3; ++i) {
      float& c = model.colors.back()[i];
      c = static_cast<float>(std::lround(std::clamp(c, 0.0f, 1.0f) * 255.0f)) / 255.0f;
    }
  }

  // A (nearly) uniform colour cannot tell poses apart: report the model as untextured.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum_squares = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& color : model.colors) {
    sum += color.cast<double>();
    sum_squares += color.cast<double>().cwiseAbs2();
  }
  const Eigen::Vector3d mean = sum / static_cast<double>(count);
  const Eigen::Vector3d variance =
      (sum_squares / static_cast<double>(count) - mean.cwiseAbs2()).cwiseMax(0.0);
  if (variance.cwiseSqrt().maxCoeff() < options.min_color_std) return AppearanceModel();
  return model;
}

AppearanceScore ScoreAppearance(const AppearanceOptions& options, const AppearanceModel& model,
                                const Mesh& online_mesh, const Camera& camera, const cv::Mat& rgb,
                                const cv::Mat& mask, const Eigen::Isometry3d& cam_from_object,
                                RasterImage* scratch) {
  RasterImage local_scratch;
  CorrelationSums sums;
  ForEachComparedSample(
      options, model, online_mesh, camera, rgb, mask, cam_from_object,
      scratch != nullptr ? scratch : &local_scratch,
      [&](size_t i, double x, double y) { sums.Add(model.colors[i], SampleBilinear(rgb, x, y)); });
  AppearanceScore score;
  score.points = sums.count;
  if (model.Empty()) {
    score.message = "the appearance model is empty (untextured or uniformly coloured mesh)";
    return score;
  }
  if (sums.count < options.min_visible_points) {
    std::ostringstream out;
    out << "too few visible samples inside the mask (" << sums.count << " < "
        << options.min_visible_points << ")";
    score.message = out.str();
    return score;
  }
  // Two lighting-robust comparisons, each a mean of per-channel ZNCCs over the channels in
  // which the model varies over these samples (elsewhere the correlation is noise):
  // RGB, invariant to a gain and offset per channel (exposure, white balance, ambient), and
  // chromaticity c / (R + G + B), invariant to shading that changes from point to point
  // (surfaces at different angles to the light) but blind on grey objects.
  double rgb_sum = 0.0, chroma_sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    if (sums.StdA(k) >= options.min_color_std && sums.StdB(k) > 0.0) {
      rgb_sum += sums.Zncc(k);
      ++score.rgb_channels;
    }
    if (sums.StdA(3 + k) >= options.min_chroma_std && sums.StdB(3 + k) > 0.0) {
      chroma_sum += sums.Zncc(3 + k);
      ++score.chroma_channels;
    }
  }
  // Chromaticity alone is not enough: a model whose RGB does not vary over the compared
  // samples is uniformly coloured there (on dark objects the chromaticity is noise).
  if (score.rgb_channels == 0) {
    score.message = "the model's colours do not vary over the visible samples";
    return score;
  }
  score.rgb_zncc = rgb_sum / score.rgb_channels;
  score.agreement = score.rgb_zncc;
  int parts = 1;
  if (score.chroma_channels > 0) {
    score.chroma_zncc = chroma_sum / score.chroma_channels;
    score.agreement += score.chroma_zncc;
    ++parts;
  }
  score.agreement /= parts;
  score.valid = true;
  score.message.clear();
  return score;
}

namespace internal {

int CollectAppearancePairs(const AppearanceOptions& options, const AppearanceModel& model,
                           const Mesh& online_mesh, const Camera& camera, const cv::Mat& rgb,
                           const cv::Mat& mask, const Eigen::Isometry3d& cam_from_object,
                           std::vector<Eigen::Vector3f>* model_colors,
                           std::vector<Eigen::Vector3f>* observed_colors) {
  G6D_CHECK(model_colors != nullptr && observed_colors != nullptr);
  model_colors->clear();
  observed_colors->clear();
  RasterImage rendered;
  ForEachComparedSample(options, model, online_mesh, camera, rgb, mask, cam_from_object, &rendered,
                        [&](size_t i, double x, double y) {
                          model_colors->push_back(model.colors[i]);
                          observed_colors->push_back(SampleBilinear(rgb, x, y));
                        });
  return static_cast<int>(model_colors->size());
}

}  // namespace internal

}  // namespace g6d
