#include "templates/template_bank.h"

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "render/gl_renderer.h"
#include "render/raster.h"

namespace g6d {

std::string TemplateBuildOptions::Check() const {
  if (std::string problem = views.Check(); !problem.empty()) return problem;
  if (std::string problem = crop.Check(); !problem.empty()) return problem;
  if (std::string problem = orb.Check(); !problem.empty()) return problem;
  if (std::string problem = symmetry.Check(); !problem.empty()) return problem;
  if (std::string problem = appearance.Check(); !problem.empty()) return problem;
  if (std::string problem = ppf.Check(); !problem.empty()) return problem;
  std::ostringstream out;
  if (render_size_px < 16 || render_size_px > 8192) {
    out << "render_size_px must be in 16..8192 (got " << render_size_px << ")";
  } else if (!std::isfinite(render_focal_px) || render_focal_px <= 0.0 || render_focal_px > 1e6) {
    out << "render_focal_px must be in (0, 1e6] (got " << render_focal_px << ")";
  } else if (online_mesh_faces < 4 || online_mesh_faces > 10000000) {
    out << "online_mesh_faces must be in 4..10000000 (got " << online_mesh_faces << ")";
  } else if (!std::isfinite(max_view_angle_deg) || max_view_angle_deg <= 0.0 ||
             max_view_angle_deg > 90.0) {
    out << "max_view_angle_deg must be in (0, 90] (got " << max_view_angle_deg << ")";
  } else if (thumbnail_size_px < 0 || thumbnail_size_px > crop.size_px) {
    out << "thumbnail_size_px must be in 0..crop.size_px=" << crop.size_px << " (got "
        << thumbnail_size_px << ")";
  }
  return out.str();
}

size_t TemplateBank::NumKeypoints() const {
  size_t total = 0;
  for (const Template& t : templates) total += t.keypoints.size();
  return total;
}

namespace {

// Closed, consistently oriented and with its faces counter-clockwise seen from outside
// (positive enclosed volume, by the divergence theorem).
bool IsClosedOutward(const Mesh& mesh) {
  if (!IsClosedAndOriented(mesh)) return false;
  double six_volume = 0.0;
  for (const Eigen::Vector3i& face : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[static_cast<size_t>(face[0])].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[static_cast<size_t>(face[1])].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[static_cast<size_t>(face[2])].cast<double>();
    six_volume += a.dot(b.cross(c));
  }
  return six_volume > 0.0;
}

}  // namespace

void DeriveOnlineMeshes(TemplateBank* bank) {
  bank->silhouettes.clear();
  for (const Template& view : bank->templates) {
    TemplateSilhouette silhouette;
    const MaskMoments in_crop = MomentsOfMask(view.mask);
    silhouette.bits = EncodeSilhouette(view.mask, in_crop, 0.0);
    // Template image px = crop_scale * crop px + crop_offset (A_j).
    silhouette.moments.centroid_px = view.crop_scale * in_crop.centroid_px + view.crop_offset;
    silhouette.moments.area_px = in_crop.area_px * view.crop_scale * view.crop_scale;
    bank->silhouettes.push_back(silhouette);
  }
  bank->selection_mesh = Mesh();
  bank->online_mesh_closed = false;
  bank->selection_mesh_closed = false;
  if (bank->online_mesh.faces.empty()) return;
  bank->online_mesh_closed = IsClosedOutward(bank->online_mesh);
  if (static_cast<int>(bank->online_mesh.faces.size()) > kSelectionMeshFaces) {
    bank->selection_mesh = Decimate(bank->online_mesh, kSelectionMeshFaces);
    bank->selection_mesh_closed = IsClosedOutward(bank->selection_mesh);
  }
}

namespace {

// Storage grids (powers of two, so the rounded values are exact floats whose low mantissa
// bytes are zero and compress away): far below ORB's localization and the mesh accuracy.
constexpr double kKeypointGridPx = 1.0 / 64.0;
constexpr double kPointGridM = 1.0 / 65536.0;  // about 15 micrometres

float Snap(double value, double grid) {
  return static_cast<float>(std::round(value / grid) * grid);
}

// Working state of one worker thread: one GlRenderer (one OSMesa context) and the
// rasterizer's reusable buffers. Created lazily by the thread that uses it and owned by one
// BuildTemplateBank call, so no GL context outlives the call or is used by two threads.
// Keyed by thread id rather than held in thread_local storage: thread_local renderers
// would keep the mesh and the context alive until the pool's threads exit, and would have
// to be keyed by mesh anyway. GlRenderer makes its context current on every Render() and
// on destruction, so destroying them all on the calling thread is fine.
struct WorkerState {
  std::unique_ptr<GlRenderer> renderer;
  RasterImage raster;
};

class PerThreadState {
 public:
  explicit PerThreadState(const Mesh& mesh) : mesh_(mesh) {}

  WorkerState& ForThisThread() {
    const std::thread::id id = std::this_thread::get_id();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = states_.find(id);
      if (it != states_.end()) return *it->second;
    }
    // Context creation and mesh upload are slow; do them outside the lock. Only this
    // thread inserts its own id, so there is no race on the key.
    auto state = std::make_unique<WorkerState>();
    state->renderer = std::make_unique<GlRenderer>(mesh_);
    std::lock_guard<std::mutex> lock(mutex_);
    return *states_.emplace(id, std::move(state)).first->second;
  }

 private:
  const Mesh& mesh_;
  std::mutex mutex_;
  std::map<std::thread::id, std::unique_ptr<WorkerState>> states_;
};

// Back-projects the template keypoints to object-frame points (paper eq. 2). The depth z
// is not read from the depth image at the rounded pixel but by intersecting the keypoint's
// exact sub-pixel ray with the plane of the face the rasterizer saw at that pixel: the same
// as an exactly interpolated rendered depth. Appends the kept keypoints, descriptors and
// points to `out`.
void BackprojectKeypoints(const Mesh& mesh, const Camera& camera,
                          const Eigen::Isometry3d& cam_from_object, const RasterImage& raster,
                          const std::vector<Feature>& features, double diameter_m,
                          double max_view_angle_deg, Template* out) {
  const Eigen::Matrix3d camera_inverse = camera.K().inverse();
  const double max_depth_jump_m = 0.01 * diameter_m;
  const double min_cos_view = std::cos(max_view_angle_deg * M_PI / 180.0);
  const Eigen::Matrix3d object_from_cam_rotation = cam_from_object.linear().transpose();

  // Plane of face f in the camera frame: normal n and offset n . p0.
  auto face_plane = [&](int face, Eigen::Vector3d* normal, double* offset) {
    const Eigen::Vector3i& indices = mesh.faces[static_cast<size_t>(face)];
    const Eigen::Vector3d p0 = cam_from_object * mesh.vertices[indices[0]].cast<double>();
    const Eigen::Vector3d p1 = cam_from_object * mesh.vertices[indices[1]].cast<double>();
    const Eigen::Vector3d p2 = cam_from_object * mesh.vertices[indices[2]].cast<double>();
    *normal = (p1 - p0).cross(p2 - p0);
    *offset = normal->dot(p0);
  };

  for (const Feature& feature : features) {
    // OpenCV pixel (u, v) covers [u - 0.5, u + 0.5).
    const int u = static_cast<int>(std::floor(feature.xy.x() + 0.5f));
    const int v = static_cast<int>(std::floor(feature.xy.y() + 0.5f));
    if (u < 1 || v < 1 || u >= camera.width - 1 || v >= camera.height - 1) continue;
    const int face = raster.face_id.at<int32_t>(v, u);
    if (face < 0) continue;  // background

    Eigen::Vector3d normal;
    double offset = 0.0;
    face_plane(face, &normal, &offset);
    const double normal_norm = normal.norm();
    if (!(normal_norm > 0.0)) continue;  // degenerate face

    const Eigen::Vector3d ray =
        camera_inverse *
        Eigen::Vector3d(feature.xy.x() + kOpenCvToImage, feature.xy.y() + kOpenCvToImage, 1.0);
    const double denominator = normal.dot(ray);
    // Grazing view: the angle between the surface normal and the viewing ray.
    if (std::abs(denominator) < min_cos_view * normal_norm * ray.norm()) continue;
    const double depth_m = offset / denominator;  // ray has z = 1, so this is z
    if (!(depth_m > 0.0)) continue;

    // Depth discontinuity: every 3x3 neighbour must be covered and lie on (nearly) the
    // keypoint's plane. Comparing with the plane, not with the centre pixel's depth, keeps
    // slanted but smooth surfaces whose per-pixel depth step exceeds the tolerance.
    bool continuous = true;
    for (int dv = -1; dv <= 1 && continuous; ++dv) {
      for (int du = -1; du <= 1 && continuous; ++du) {
        const int nu = u + du;
        const int nv = v + dv;
        if (raster.face_id.at<int32_t>(nv, nu) < 0) {
          continuous = false;
          break;
        }
        const Eigen::Vector3d neighbour_ray =
            camera_inverse * Eigen::Vector3d(nu + 0.5, nv + 0.5, 1.0);
        const double plane_depth = offset / normal.dot(neighbour_ray);
        const double raster_depth = raster.depth.at<float>(nv, nu);
        if (!(std::abs(raster_depth - plane_depth) <= max_depth_jump_m)) continuous = false;
      }
    }
    if (!continuous) continue;

    // eq. (2): X = R^T (z K^-1 u~ - t)
    const Eigen::Vector3d point_in_cam = depth_m * ray;
    const Eigen::Vector3d point_in_object =
        object_from_cam_rotation * (point_in_cam - cam_from_object.translation());
    out->keypoints.emplace_back(Snap(feature.xy.x(), kKeypointGridPx),
                                Snap(feature.xy.y(), kKeypointGridPx));
    out->descriptors.push_back(feature.descriptor);
    out->points.emplace_back(Snap(point_in_object.x(), kPointGridM),
                             Snap(point_in_object.y(), kPointGridM),
                             Snap(point_in_object.z(), kPointGridM));
  }
}

}  // namespace

TemplateBank BuildTemplateBank(const Mesh& mesh, const std::string& object_id,
                               const TemplateBuildOptions& options, Executor* executor,
                               const ProgressCallback& progress) {
  if (const std::string problem = options.Check(); !problem.empty()) {
    G6D_THROW("BuildTemplateBank: " << problem);
  }
  if (executor == nullptr) G6D_THROW("BuildTemplateBank: executor must not be null");
  if (mesh.vertices.empty() || mesh.faces.empty()) {
    G6D_THROW("BuildTemplateBank: mesh for '" << object_id << "' has no faces");
  }

  TemplateBank bank;
  bank.object_id = object_id;
  bank.options = options;
  bank.diameter_m = ComputeDiameter(mesh);
  bank.bounding_box = ComputeBoundingBox(mesh);
  if (!(bank.diameter_m > 0.0)) {
    G6D_THROW("BuildTemplateBank: mesh for '" << object_id << "' has zero diameter");
  }

  Camera& camera = bank.template_camera;
  camera.fx = camera.fy = options.render_focal_px;
  camera.cx = camera.cy = 0.5 * options.render_size_px;
  camera.width = camera.height = options.render_size_px;

  const std::vector<Eigen::Isometry3d> views =
      SampleTemplateViews(options.views, camera, bank.diameter_m, bank.bounding_box.center());
  const int num_views = static_cast<int>(views.size());
  bank.templates.resize(views.size());

  PerThreadState per_thread(mesh);
  std::mutex progress_mutex;
  int done = 0;
  RasterOptions raster_options;
  raster_options.want_face_id = true;

  // Item 0 decimates the online mesh (a single long task, so it goes first and overlaps
  // the views on the other threads); items 1..N are the views.
  executor->ParallelFor(num_views + 1, [&](int item) {
    if (item == 0) {
      bank.online_mesh = Decimate(mesh, options.online_mesh_faces);
      if (options.find_symmetries) bank.geometric_symmetries = FindSymmetries(mesh, options.symmetry);
      if (options.sample_appearance) bank.appearance = SampleAppearance(mesh, options.appearance);
      if (options.build_ppf) bank.ppf = BuildPpfModel(mesh, bank.diameter_m, options.ppf);
      return;
    }
    const int j = item - 1;
    Template& result = bank.templates[static_cast<size_t>(j)];
    result.cam_from_object = views[static_cast<size_t>(j)];

    WorkerState& state = per_thread.ForThisThread();
    const GlImage image = state.renderer->Render(camera, result.cam_from_object);
    RasterImage& raster = state.raster;
    Rasterize(mesh, camera, result.cam_from_object, raster_options, &raster);

    const NormalizedCrop crop = NormalizeCrop(image.rgb, raster.Mask(), options.crop);
    if (crop.valid) {
      result.crop_scale = crop.scale;
      result.crop_offset = crop.offset;
      result.mask = crop.mask;
      const std::vector<Feature> features = DetectOrb(crop, options.orb);
      BackprojectKeypoints(mesh, camera, result.cam_from_object, raster, features, bank.diameter_m,
                           options.max_view_angle_deg, &result);
      if (options.thumbnail_size_px > 0) {
        cv::resize(crop.gray, result.thumbnail,
                   cv::Size(options.thumbnail_size_px, options.thumbnail_size_px), 0.0, 0.0,
                   cv::INTER_AREA);
      }
    } else {
      // The object is out of view (cannot happen with centred views); keep an empty mask.
      result.mask = cv::Mat::zeros(options.crop.size_px, options.crop.size_px, CV_8UC1);
    }

    if (progress) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress(++done, num_views);
    }
  });
  DeriveOnlineMeshes(&bank);
  return bank;
}

}  // namespace g6d
