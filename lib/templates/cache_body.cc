#include "templates/cache_body.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "core/error.h"
#include "templates/cache_format.h"

namespace g6d {
namespace cache_format {
namespace {

// ---- Field groups -------------------------------------------------------------------------

// Stored poses are rotations to (nearly) double precision; anything else is refused on
// both sides, so a file that was written can always be read back.
bool IsRotation(const Eigen::Matrix3d& rotation) {
  return rotation.allFinite() &&
         (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() <= 1e-6 &&
         rotation.determinant() > 0.0;
}

void WritePose(const Eigen::Isometry3d& pose, Writer* w) {
  if (!IsRotation(pose.linear()) || !pose.translation().allFinite()) {
    G6D_THROW(
        "WriteTemplateCache: a pose or symmetry is not a rigid transform (rotation "
        "not orthonormal or values not finite)");
  }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) w->F64(pose.linear()(r, c));
  for (int r = 0; r < 3; ++r) w->F64(pose.translation()[r]);
}

Eigen::Isometry3d ReadPose(Reader* r, const char* what) {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rotation(i, j) = r->Finite(what);
  for (int i = 0; i < 3; ++i) translation[i] = r->Finite(what);
  if (!IsRotation(rotation)) r->Fail(what, "is not a rotation");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

// Geometric symmetries: revolution flag, axis, point, errors, diameter, discrete poses.
// The per-rotation test log of FindSymmetries is not stored (a build-time report).
void WriteGeometricSymmetries(const MeshSymmetries& symmetries, Writer* w) {
  w->U8(symmetries.revolution ? 1 : 0);
  for (int i = 0; i < 3; ++i) w->F64(symmetries.axis[i]);
  for (int i = 0; i < 3; ++i) w->F64(symmetries.point[i]);
  w->F64(symmetries.worst_error);
  w->F64(symmetries.worst_p95_error);
  w->F64(symmetries.diameter_m);
  w->Count(symmetries.discrete.size(), kMaxSymmetries, "geometric symmetry");
  for (const Eigen::Isometry3d& g : symmetries.discrete) WritePose(g, w);
}

MeshSymmetries ReadGeometricSymmetries(Reader* r) {
  MeshSymmetries symmetries;
  const uint8_t revolution = r->U8("geometric symmetry revolution");
  if (revolution > 1) r->Fail("geometric symmetry revolution", "code " + std::to_string(revolution) + " is not a bool");
  symmetries.revolution = revolution == 1;
  for (int i = 0; i < 3; ++i) symmetries.axis[i] = r->Finite("geometric symmetry axis");
  for (int i = 0; i < 3; ++i) symmetries.point[i] = r->Finite("geometric symmetry point");
  if (std::abs(symmetries.axis.norm() - 1.0) > 1e-6) r->Fail("geometric symmetry axis", "is not a unit vector");
  symmetries.worst_error = r->Finite("geometric symmetry error");
  symmetries.worst_p95_error = r->Finite("geometric symmetry p95 error");
  symmetries.diameter_m = r->Finite("geometric symmetry diameter");
  const uint32_t n = r->Count(kMaxSymmetries, 96, "geometric symmetry");
  for (uint32_t i = 0; i < n; ++i) symmetries.discrete.push_back(ReadPose(r, "geometric symmetry"));
  return symmetries;
}

// Appearance samples: count, then points and normals (f32, byte-shuffled) and 8-bit RGB.
void WriteAppearance(const AppearanceModel& model, Writer* w) {
  G6D_CHECK(model.normals.size() == model.points.size() && model.colors.size() == model.points.size());
  w->Count(model.points.size(), kMaxVertices, "appearance sample");
  w->ShuffledF32(model.points.empty() ? nullptr : model.points[0].data(), 3 * model.points.size());
  w->ShuffledF32(model.normals.empty() ? nullptr : model.normals[0].data(), 3 * model.normals.size());
  for (const Eigen::Vector3f& c : model.colors) {
    for (int i = 0; i < 3; ++i) w->U8(static_cast<uint8_t>(std::lround(std::clamp(c[i], 0.0f, 1.0f) * 255.0f)));
  }
}

AppearanceModel ReadAppearance(Reader* r) {
  AppearanceModel model;
  const uint32_t n = r->Count(kMaxVertices, 27, "appearance sample");
  model.points.resize(n);
  model.normals.resize(n);
  model.colors.resize(n);
  r->ShuffledFiniteF32(n > 0 ? model.points[0].data() : nullptr, 3 * size_t{n}, "appearance sample point");
  r->ShuffledFiniteF32(n > 0 ? model.normals[0].data() : nullptr, 3 * size_t{n}, "appearance sample normal");
  for (Eigen::Vector3f& c : model.colors) {
    for (int i = 0; i < 3; ++i) c[i] = r->U8("appearance sample colour") / 255.0f;
  }
  return model;
}

void WriteOptions(const TemplateBuildOptions& o, Writer* w) {
  w->I32(o.views.num_directions);
  w->I32(o.views.num_inplane);
  w->F64(o.views.fill_fraction);
  w->F64(o.crop.padding);
  w->I32(o.crop.size_px);
  w->I32(o.crop.background_gray);
  w->F64(o.crop.normalized_mean);
  w->F64(o.crop.normalized_std);
  w->F64(o.crop.min_std);
  w->I32(o.orb.max_features);
  w->F32(o.orb.scale_factor);
  w->I32(o.orb.num_levels);
  w->I32(o.orb.edge_threshold);
  w->I32(o.orb.fast_threshold);
  w->I32(o.orb.mask_erosion_px);
  w->I32(o.render_size_px);
  w->F64(o.render_focal_px);
  w->I32(o.online_mesh_faces);
  w->F64(o.max_view_angle_deg);
  w->I32(o.thumbnail_size_px);
  w->U8(o.find_symmetries ? 1 : 0);
  w->I32(o.symmetry.sample_points);
  w->F64(o.symmetry.mean_tolerance);
  w->F64(o.symmetry.max_tolerance);
  w->I32(o.symmetry.max_order);
  w->U64(o.symmetry.seed);
  w->U8(o.sample_appearance ? 1 : 0);
  w->I32(o.appearance.sample_points);
  w->U64(o.appearance.seed);
  w->F64(o.appearance.min_color_std);
  w->I32(o.appearance.texture_max_side_px);
  w->U8(o.build_ppf ? 1 : 0);
  w->F64(o.ppf.step_fraction);
  w->F64(o.ppf.angle_step_deg);
  w->F64(o.ppf.normal_cluster_deg);
  w->I32(o.ppf.surface_samples);
  w->I32(o.ppf.max_points);
  w->U32(o.ppf.seed);
}

// The point-pair-feature model's stored part: step, then points and unit normals (f32,
// byte-shuffled). Its options are the build options' (TemplateBuildOptions::ppf).
void WritePpfModel(const PpfModel& model, Writer* w) {
  G6D_CHECK(model.normals.size() == model.points.size());
  w->F64(model.step_m);
  w->Count(model.points.size(), kMaxPpfPoints, "ppf point");
  w->ShuffledF32(model.points.empty() ? nullptr : model.points[0].data(), 3 * model.points.size());
  w->ShuffledF32(model.normals.empty() ? nullptr : model.normals[0].data(), 3 * model.normals.size());
}

PpfModel ReadPpfModel(Reader* r, const TemplateBuildOptions& options) {
  PpfModel model;
  model.options = options.ppf;
  model.step_m = r->Finite("ppf step");
  const uint32_t n = r->Count(kMaxPpfPoints, 24, "ppf point");
  if (n > 0 && !(model.step_m > 0.0)) r->Fail("ppf step", "is not positive");
  if (n > 0 && !options.build_ppf) r->Fail("ppf point", "count is not 0 for a cache built without a ppf model");
  model.points.resize(n);
  model.normals.resize(n);
  r->ShuffledFiniteF32(n > 0 ? model.points[0].data() : nullptr, 3 * size_t{n}, "ppf point");
  r->ShuffledFiniteF32(n > 0 ? model.normals[0].data() : nullptr, 3 * size_t{n}, "ppf normal");
  for (const Eigen::Vector3f& normal : model.normals) {
    if (std::abs(normal.norm() - 1.0f) > 1e-3f) r->Fail("ppf normal", "is not a unit vector");
  }
  return model;
}

TemplateBuildOptions ReadOptions(Reader* r, const std::string& name) {
  TemplateBuildOptions o;
  o.views.num_directions = r->I32("views.num_directions");
  o.views.num_inplane = r->I32("views.num_inplane");
  o.views.fill_fraction = r->F64("views.fill_fraction");
  o.crop.padding = r->F64("crop.padding");
  o.crop.size_px = r->I32("crop.size_px");
  o.crop.background_gray = r->I32("crop.background_gray");
  o.crop.normalized_mean = r->F64("crop.normalized_mean");
  o.crop.normalized_std = r->F64("crop.normalized_std");
  o.crop.min_std = r->F64("crop.min_std");
  o.orb.max_features = r->I32("orb.max_features");
  o.orb.scale_factor = r->F32("orb.scale_factor");
  o.orb.num_levels = r->I32("orb.num_levels");
  o.orb.edge_threshold = r->I32("orb.edge_threshold");
  o.orb.fast_threshold = r->I32("orb.fast_threshold");
  o.orb.mask_erosion_px = r->I32("orb.mask_erosion_px");
  o.render_size_px = r->I32("render_size_px");
  o.render_focal_px = r->F64("render_focal_px");
  o.online_mesh_faces = r->I32("online_mesh_faces");
  o.max_view_angle_deg = r->F64("max_view_angle_deg");
  o.thumbnail_size_px = r->I32("thumbnail_size_px");
  const uint8_t find_symmetries = r->U8("find_symmetries");
  if (find_symmetries > 1) r->Fail("find_symmetries", "code " + std::to_string(find_symmetries) + " is not a bool");
  o.find_symmetries = find_symmetries == 1;
  o.symmetry.sample_points = r->I32("symmetry.sample_points");
  o.symmetry.mean_tolerance = r->F64("symmetry.mean_tolerance");
  o.symmetry.max_tolerance = r->F64("symmetry.max_tolerance");
  o.symmetry.max_order = r->I32("symmetry.max_order");
  o.symmetry.seed = r->U64("symmetry.seed");
  const uint8_t sample_appearance = r->U8("sample_appearance");
  if (sample_appearance > 1) r->Fail("sample_appearance", "code " + std::to_string(sample_appearance) + " is not a bool");
  o.sample_appearance = sample_appearance == 1;
  o.appearance.sample_points = r->I32("appearance.sample_points");
  o.appearance.seed = r->U64("appearance.seed");
  o.appearance.min_color_std = r->F64("appearance.min_color_std");
  o.appearance.texture_max_side_px = r->I32("appearance.texture_max_side_px");
  const uint8_t build_ppf = r->U8("build_ppf");
  if (build_ppf > 1) r->Fail("build_ppf", "code " + std::to_string(build_ppf) + " is not a bool");
  o.build_ppf = build_ppf == 1;
  o.ppf.step_fraction = r->F64("ppf.step_fraction");
  o.ppf.angle_step_deg = r->F64("ppf.angle_step_deg");
  o.ppf.normal_cluster_deg = r->F64("ppf.normal_cluster_deg");
  o.ppf.surface_samples = r->I32("ppf.surface_samples");
  o.ppf.max_points = r->I32("ppf.max_points");
  o.ppf.seed = r->U32("ppf.seed");
  if (const std::string problem = o.Check(); !problem.empty()) {
    G6D_THROW(name << ": corrupted: build option out of range: " << problem);
  }
  return o;
}

// Masks are 0/255; stored as alternating run lengths starting with a run of 0s.
void WriteMask(const cv::Mat& mask, Writer* w) {
  if (mask.empty()) {
    w->I32(0);
    w->I32(0);
    w->U32(0);
    return;
  }
  G6D_CHECK(mask.type() == CV_8UC1);
  w->I32(mask.rows);
  w->I32(mask.cols);
  std::vector<uint32_t> runs;
  bool value = false;
  uint32_t run = 0;
  for (int y = 0; y < mask.rows; ++y) {
    const uint8_t* row = mask.ptr<uint8_t>(y);
    for (int x = 0; x < mask.cols; ++x) {
      const bool on = row[x] != 0;
      if (on != value) {
        runs.push_back(run);
        run = 0;
        value = on;
      }
      ++run;
    }
  }
  runs.push_back(run);
  w->U32(static_cast<uint32_t>(runs.size()));
  for (uint32_t r : runs) w->U32(r);
}

// Empty when a template image of `rows` x `cols` is one the writer produces: `side`
// square, or empty; else the problem.
std::string TemplateImageSizeProblem(int32_t rows, int32_t cols, int side, const char* option) {
  if ((rows == 0 && cols == 0) || (rows == side && cols == side)) return {};
  return "has a bad size " + std::to_string(cols) + "x" + std::to_string(rows) + " (expected " +
         std::to_string(side) + "x" + std::to_string(side) + " from " + option + ", or empty)";
}

// A mask of `side` x `side` (crop.size_px) or empty.
cv::Mat ReadMask(Reader* r, const char* what, int side) {
  const int32_t rows = r->I32(what);
  const int32_t cols = r->I32(what);
  if (const std::string problem = TemplateImageSizeProblem(rows, cols, side, "crop.size_px");
      !problem.empty()) {
    r->Fail(what, problem);
  }
  const uint64_t pixels = static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols);
  const uint32_t num_runs =
      r->Count(static_cast<uint32_t>(std::min<uint64_t>(pixels + 1, UINT32_MAX)), 4, what);
  if (pixels == 0) {
    if (num_runs != 0) r->Fail(what, "is empty but has runs");
    return cv::Mat();
  }
  cv::Mat mask(rows, cols, CV_8UC1);
  uint8_t* data = mask.ptr<uint8_t>(0);  // freshly allocated: continuous
  uint64_t filled = 0;
  uint8_t value = 0;
  for (uint32_t i = 0; i < num_runs; ++i) {
    const uint32_t run = r->U32(what);
    if (run > pixels - filled) r->Fail(what, "runs exceed the mask size");
    std::memset(data + filled, value, run);
    filled += run;
    value = value ? 0 : 255;
  }
  if (filled != pixels) r->Fail(what, "runs do not cover the mask");
  return mask;
}

// JPEG-LS median edge detector from the left (a), upper (b) and upper-left (c) pixels;
// missing neighbours count as 0.
inline uint8_t PredictPixel(const uint8_t* row, const uint8_t* above, int x) {
  const int a = x > 0 ? row[x - 1] : 0;
  const int b = above != nullptr ? above[x] : 0;
  const int c = (above != nullptr && x > 0) ? above[x - 1] : 0;
  if (c >= std::max(a, b)) return static_cast<uint8_t>(std::min(a, b));
  if (c <= std::min(a, b)) return static_cast<uint8_t>(std::max(a, b));
  return static_cast<uint8_t>(a + b - c);
}

void WriteGrayImage(const cv::Mat& image, Writer* w) {
  if (image.empty()) {
    w->I32(0);
    w->I32(0);
    return;
  }
  G6D_CHECK(image.type() == CV_8UC1);
  w->I32(image.rows);
  w->I32(image.cols);
  // Each pixel minus its LOCO-I / JPEG-LS median edge prediction (mod 256): smooth images
  // become mostly small values, which zstd packs far better than raw grey levels.
  for (int y = 0; y < image.rows; ++y) {
    const uint8_t* row = image.ptr<uint8_t>(y);
    const uint8_t* above = y > 0 ? image.ptr<uint8_t>(y - 1) : nullptr;
    for (int x = 0; x < image.cols; ++x) {
      w->U8(static_cast<uint8_t>(row[x] - PredictPixel(row, above, x)));
    }
  }
}

// A thumbnail of `side` x `side` (thumbnail_size_px) or empty.
cv::Mat ReadGrayImage(Reader* r, const char* what, int side) {
  const int32_t rows = r->I32(what);
  const int32_t cols = r->I32(what);
  if (const std::string problem = TemplateImageSizeProblem(rows, cols, side, "thumbnail_size_px");
      !problem.empty()) {
    r->Fail(what, problem);
  }
  if (rows == 0) return cv::Mat();
  r->Need(static_cast<size_t>(rows) * static_cast<size_t>(cols), what);
  cv::Mat image(rows, cols, CV_8UC1);
  r->Bytes(image.ptr<uint8_t>(0), static_cast<size_t>(rows) * static_cast<size_t>(cols), what);
  for (int y = 0; y < rows; ++y) {  // undo the prediction in the writer's order
    uint8_t* row = image.ptr<uint8_t>(y);
    const uint8_t* above = y > 0 ? image.ptr<uint8_t>(y - 1) : nullptr;
    for (int x = 0; x < cols; ++x)
      row[x] = static_cast<uint8_t>(row[x] + PredictPixel(row, above, x));
  }
  return image;
}

void WriteMesh(const Mesh& mesh, Writer* w) {
  w->Count(mesh.vertices.size(), kMaxVertices, "online mesh vertex");
  w->ShuffledF32(mesh.vertices.empty() ? nullptr : mesh.vertices[0].data(),
                 3 * mesh.vertices.size());
  w->Count(mesh.faces.size(), kMaxFaces, "online mesh face");
  for (const Eigen::Vector3i& f : mesh.faces)
    for (int i = 0; i < 3; ++i) w->I32(f[i]);
  // Geometry only: normals when present; colours and texture are not needed online.
  w->Count(mesh.normals.size(), kMaxVertices, "online mesh normal");
  w->ShuffledF32(mesh.normals.empty() ? nullptr : mesh.normals[0].data(), 3 * mesh.normals.size());
}

Mesh ReadMesh(Reader* r) {
  Mesh mesh;
  const uint32_t num_vertices = r->Count(kMaxVertices, 12, "online mesh vertex");
  mesh.vertices.resize(num_vertices);
  r->ShuffledFiniteF32(num_vertices > 0 ? mesh.vertices[0].data() : nullptr,
                       3 * size_t{num_vertices}, "online mesh vertex");
  const uint32_t num_faces = r->Count(kMaxFaces, 12, "online mesh face");
  mesh.faces.resize(num_faces);
  for (Eigen::Vector3i& f : mesh.faces) {
    for (int i = 0; i < 3; ++i) {
      f[i] = r->I32("online mesh face");
      if (f[i] < 0 || static_cast<uint32_t>(f[i]) >= num_vertices) {
        r->Fail("online mesh face", "index " + std::to_string(f[i]) + " is out of range");
      }
    }
  }
  const uint32_t num_normals = r->Count(kMaxVertices, 12, "online mesh normal");
  if (num_normals != 0 && num_normals != num_vertices) {
    r->Fail("online mesh normal", "count differs from the vertex count");
  }
  mesh.normals.resize(num_normals);
  r->ShuffledFiniteF32(num_normals > 0 ? mesh.normals[0].data() : nullptr, 3 * size_t{num_normals},
                       "online mesh normal");
  return mesh;
}

constexpr size_t kKeypointBytes = 8 + 32 + 12;  // xy, descriptor, point

void WriteTemplate(const Template& t, const TemplateBuildOptions& options, Writer* w) {
  // Refused here as on reading, so that a file that was written can always be read back.
  auto check_size = [](const cv::Mat& image, int side, const char* option, const char* what) {
    const std::string problem = TemplateImageSizeProblem(image.rows, image.cols, side, option);
    if (!problem.empty()) G6D_THROW("WriteTemplateCache: a template " << what << " " << problem);
  };
  check_size(t.mask, options.crop.size_px, "crop.size_px", "mask");
  check_size(t.thumbnail, options.thumbnail_size_px, "thumbnail_size_px", "thumbnail");
  WritePose(t.cam_from_object, w);
  w->F64(t.crop_scale);
  w->F64(t.crop_offset.x());
  w->F64(t.crop_offset.y());
  WriteMask(t.mask, w);
  WriteGrayImage(t.thumbnail, w);
  G6D_CHECK(t.keypoints.size() == t.descriptors.size() && t.keypoints.size() == t.points.size());
  w->Count(t.keypoints.size(), kMaxKeypointsPerTemplate, "keypoint");
  // Eigen fixed-size float vectors are packed arrays of 2 / 3 floats.
  static_assert(sizeof(Eigen::Vector2f) == 8 && sizeof(Eigen::Vector3f) == 12);
  w->ShuffledF32(t.keypoints.empty() ? nullptr : t.keypoints[0].data(), 2 * t.keypoints.size());
  for (const auto& d : t.descriptors) w->Bytes(d.data(), d.size());
  w->ShuffledF32(t.points.empty() ? nullptr : t.points[0].data(), 3 * t.points.size());
}

Template ReadTemplate(Reader* r, const TemplateBuildOptions& options) {
  Template t;
  t.cam_from_object = ReadPose(r, "template pose");
  t.crop_scale = r->Finite("template crop scale");
  if (!(t.crop_scale > 0.0)) r->Fail("template crop scale", "is not positive");
  t.crop_offset.x() = r->Finite("template crop offset");
  t.crop_offset.y() = r->Finite("template crop offset");
  t.mask = ReadMask(r, "template mask", options.crop.size_px);
  t.thumbnail = ReadGrayImage(r, "template thumbnail", options.thumbnail_size_px);
  const uint32_t n = r->Count(kMaxKeypointsPerTemplate, kKeypointBytes, "keypoint");
  t.keypoints.resize(n);
  t.descriptors.resize(n);
  t.points.resize(n);
  r->ShuffledFiniteF32(n > 0 ? t.keypoints[0].data() : nullptr, 2 * size_t{n}, "keypoint");
  for (auto& d : t.descriptors) r->Bytes(d.data(), d.size(), "descriptor");
  r->ShuffledFiniteF32(n > 0 ? t.points[0].data() : nullptr, 3 * size_t{n}, "3D point");
  return t;
}

}  // namespace

std::string EncodeBody(const TemplateBank& bank) {
  Writer w;
  w.String(bank.object_id);
  w.U64(bank.mesh_hash);
  w.String(bank.mesh_path);
  w.U8(bank.mesh_units == Units::kMillimetres ? 1 : 0);
  WriteOptions(bank.options, &w);
  const Camera& c = bank.template_camera;
  w.F64(c.fx);
  w.F64(c.fy);
  w.F64(c.cx);
  w.F64(c.cy);
  w.I32(c.width);
  w.I32(c.height);
  w.F64(bank.diameter_m);
  for (int i = 0; i < 3; ++i) w.F64(bank.bounding_box.min()[i]);
  for (int i = 0; i < 3; ++i) w.F64(bank.bounding_box.max()[i]);
  w.Count(bank.symmetries.size(), kMaxSymmetries, "symmetry");
  for (const Eigen::Isometry3d& s : bank.symmetries) WritePose(s, &w);
  WriteGeometricSymmetries(bank.geometric_symmetries, &w);
  WriteAppearance(bank.appearance, &w);
  WritePpfModel(bank.ppf, &w);
  WriteMesh(bank.online_mesh, &w);
  w.Count(bank.templates.size(), kMaxTemplates, "template");
  for (const Template& t : bank.templates) WriteTemplate(t, bank.options, &w);
  return std::move(w.bytes());
}

TemplateBank DecodeBody(const uint8_t* data, size_t size, const std::string& name) {
  Reader r(data, size, name);
  TemplateBank bank;
  bank.object_id = r.String("object id");
  bank.mesh_hash = r.U64("mesh hash");
  bank.mesh_path = r.String("mesh path");
  const uint8_t units = r.U8("mesh units");
  if (units > 1) r.Fail("mesh units", "code " + std::to_string(units) + " is unknown");
  bank.mesh_units = units == 1 ? Units::kMillimetres : Units::kMetres;
  bank.options = ReadOptions(&r, name);
  Camera& c = bank.template_camera;
  c.fx = r.F64("camera fx");
  c.fy = r.F64("camera fy");
  c.cx = r.F64("camera cx");
  c.cy = r.F64("camera cy");
  c.width = r.I32("camera width");
  c.height = r.I32("camera height");
  if (const std::string problem = c.Check(); !problem.empty()) {
    r.Fail("template camera", problem);
  }
  bank.diameter_m = r.Finite("diameter");
  if (!(bank.diameter_m > 0.0)) r.Fail("diameter", "is not positive");
  Eigen::Vector3d box_min, box_max;
  for (int i = 0; i < 3; ++i) box_min[i] = r.Finite("bounding box");
  for (int i = 0; i < 3; ++i) box_max[i] = r.Finite("bounding box");
  bank.bounding_box = Eigen::AlignedBox3d(box_min, box_max);
  const uint32_t num_symmetries = r.Count(kMaxSymmetries, 96, "symmetry");
  bank.symmetries.reserve(num_symmetries);
  for (uint32_t i = 0; i < num_symmetries; ++i) bank.symmetries.push_back(ReadPose(&r, "symmetry"));
  bank.geometric_symmetries = ReadGeometricSymmetries(&r);
  bank.appearance = ReadAppearance(&r);
  bank.ppf = ReadPpfModel(&r, bank.options);
  bank.online_mesh = ReadMesh(&r);
  // The smallest possible template: pose, affine, empty mask/thumbnail and no keypoints.
  constexpr size_t kMinTemplateBytes = 96 + 24 + 12 + 8 + 4;
  const uint32_t num_templates = r.Count(kMaxTemplates, kMinTemplateBytes, "template");
  // Bounded before any template is read: a run-length mask of S x S pixels takes 16 bytes.
  const uint64_t mask_side = static_cast<uint64_t>(bank.options.crop.size_px);
  const uint64_t thumbnail_side = static_cast<uint64_t>(bank.options.thumbnail_size_px);
  const uint64_t image_bytes =
      num_templates * (mask_side * mask_side + thumbnail_side * thumbnail_side);
  if (image_bytes > kMaxImageBytes) {
    r.Fail("template count", std::to_string(num_templates) + " with crop.size_px " +
                                 std::to_string(mask_side) + " and thumbnail_size_px " +
                                 std::to_string(thumbnail_side) + " declares " +
                                 std::to_string(image_bytes) +
                                 " bytes of masks and thumbnails, more than the limit " +
                                 std::to_string(kMaxImageBytes));
  }
  bank.templates.reserve(num_templates);
  for (uint32_t i = 0; i < num_templates; ++i) {
    bank.templates.push_back(ReadTemplate(&r, bank.options));
  }
  if (r.Remaining() != 0) {
    G6D_THROW(name << ": corrupted: " << r.Remaining()
                   << " unexpected bytes after the last template");
  }
  return bank;
}

}  // namespace cache_format
}  // namespace g6d
