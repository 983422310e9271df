#include "solver/solve_context.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "render/raster.h"

namespace g6d {

std::string ValidateInputs(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                           const SolverOptions& options) {
  std::ostringstream out;
  const std::string bad_camera = frame.camera.Check();
  const std::string bad_options = options.Check();
  const cv::Size size(frame.camera.width, frame.camera.height);
  if (!bad_options.empty()) out << "bad solver options: " << bad_options;
  else if (!bad_camera.empty()) out << "bad camera intrinsics: " << bad_camera;
  else if (frame.rgb.type() != CV_8UC3 || frame.rgb.size() != size)
    out << "rgb must be CV_8UC3 of " << size.width << "x" << size.height << " (got type " << frame.rgb.type() << ", " << frame.rgb.cols << "x" << frame.rgb.rows << ")";
  else if (frame.depth.type() != CV_32F || frame.depth.size() != size)
    out << "depth must be CV_32F metres of " << size.width << "x" << size.height << " (got type " << frame.depth.type() << ", " << frame.depth.cols << "x" << frame.depth.rows << ")";
  else if (instance.mask.type() != CV_8U || instance.mask.size() != size)
    out << "mask must be CV_8U of " << size.width << "x" << size.height << " (got type " << instance.mask.type() << ", " << instance.mask.cols << "x" << instance.mask.rows << ")";
  else if (instance.object_id != bank.object_id)
    out << "the template bank is for object '" << bank.object_id << "', not '" << instance.object_id << "'";
  else if (bank.templates.empty() || bank.online_mesh.faces.empty() || !(bank.diameter_m > 0.0))
    out << "the template bank for '" << bank.object_id << "' is empty";
  return out.str();
}

namespace {

// Visible model points of a rendering on `grid` at `cam_from_object`, in the object frame:
// the ICP source. Pixels hidden behind an unmasked occluder (outside the mask, observed
// depth in front) are left out: nothing observed can match them; with `inside_mask_only`
// every pixel outside the observed mask is. Parts outside the image are never on the grid.
// With `normals`, also the unit normal (object frame) of the face each point lies on.
std::vector<Eigen::Vector3d> VisibleModelPoints(const Mesh& mesh, const EvaluationGrid& grid,
                                                const Eigen::Isometry3d& cam_from_object,
                                                const ScoreOptions& score_options, int max_points,
                                                bool inside_mask_only, RasterImage* scratch,
                                                std::vector<Eigen::Vector3d>* normals = nullptr) {
  RasterOptions raster_options;
  raster_options.want_face_id = normals != nullptr;
  raster_options.cull_backfaces = score_options.cull_backfaces;
  const Camera& camera = grid.camera;
  Rasterize(mesh, camera, cam_from_object, raster_options, scratch);
  const int count = std::max(1, scratch->pixel_count);
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count) / max_points))));
  const Eigen::Isometry3d object_from_cam = cam_from_object.inverse();
  std::vector<Eigen::Vector3d> points;
  if (normals != nullptr) normals->clear();
  for (int v = stride / 2; v < scratch->depth.rows; v += stride) {
    const float* row = scratch->depth.ptr<float>(v);
    const uint8_t* mask = grid.mask.ptr<uint8_t>(v);
    const float* observed = grid.depth.ptr<float>(v);
    for (int u = stride / 2; u < scratch->depth.cols; u += stride) {
      if (!(row[u] > 0.0f)) continue;
      if (!mask[u] && (inside_mask_only || IsOccluded(row[u], observed[u], score_options))) continue;
      points.push_back(object_from_cam * camera.Backproject(PixelCentre(u, v), row[u]));
      if (normals == nullptr) continue;
      const Eigen::Vector3i& face = mesh.faces[static_cast<size_t>(scratch->face_id.at<int32_t>(v, u))];
      const Eigen::Vector3d a = mesh.vertices[static_cast<size_t>(face[0])].cast<double>();
      const Eigen::Vector3d normal =
          (mesh.vertices[static_cast<size_t>(face[1])].cast<double>() - a).cross(mesh.vertices[static_cast<size_t>(face[2])].cast<double>() - a);
      const double length = normal.norm();
      normals->push_back(length > 0.0 ? Eigen::Vector3d(normal / length) : Eigen::Vector3d::Zero());
    }
  }
  return points;
}

}  // namespace

IcpReport RunIcpFrom(const SolverOptions& options, const Mesh& mesh, const EvaluationGrid& grid,
                     const ScoreOptions& score_options, const PointCloudIndex& observed, double diameter_m,
                     int max_points, int max_iterations, RasterImage* scratch, Eigen::Isometry3d* cam_from_object) {
  std::vector<Eigen::Vector3d> normals;
  const std::vector<Eigen::Vector3d> source =
      VisibleModelPoints(mesh, grid, *cam_from_object, score_options, max_points, options.icp_source_in_mask, scratch,
                         options.icp.point_to_plane ? &normals : nullptr);
  IcpOptions icp = options.icp;
  icp.max_iterations = max_iterations;
  IcpReport report;
  RefineByTrimmedIcp(icp, source, observed, diameter_m, cam_from_object, &report,
                     options.icp.point_to_plane ? &normals : nullptr);
  return report;
}

PoseResult Failed(Termination termination, const std::string& message, const Stopwatch& total, PoseResult* result) {
  result->success = false;
  result->termination = termination;
  result->message = message;
  result->stages.total_ms = total.ElapsedMs();
  return *result;
}

MeshSymmetries ShapeSymmetries(const TemplateBank& bank) {
  MeshSymmetries symmetries = bank.geometric_symmetries;
  for (const Eigen::Isometry3d& g : bank.symmetries) symmetries.discrete.push_back(g);
  return symmetries;
}

std::vector<Eigen::Isometry3d> BoxFlips(const Eigen::Isometry3d& cam_from_object, const TemplateBank& bank) {
  const Eigen::Vector3d centre = bank.bounding_box.center();
  std::vector<Eigen::Isometry3d> flips;
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
    flip.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
    flip.translation() = centre - flip.linear() * centre;  // about the box centre
    flips.push_back(cam_from_object * flip);
  }
  return flips;
}

MeshSymmetries AnswerSymmetries(const TemplateBank& bank) {
  if (bank.appearance.Empty()) return ShapeSymmetries(bank);
  MeshSymmetries symmetries;
  symmetries.discrete = bank.symmetries;
  return symmetries;
}

std::vector<Eigen::Vector3d> DistancePoints(const Mesh& mesh, size_t count) {
  std::vector<Eigen::Vector3d> points;
  const size_t step = std::max<size_t>(1, mesh.vertices.size() / count);
  for (size_t i = 0; i < mesh.vertices.size(); i += step) points.push_back(mesh.vertices[i].cast<double>());
  return points;
}

SolveContext MakeSolveContext(const Frame& frame, const TemplateBank& bank, const SolverOptions& options,
                              Executor* executor, const Observation& observation, const PoseComparer& comparer,
                              SolveClock* clock, StageReport* stages) {
  SolveContext context{frame, bank, options, executor, observation, comparer, observation.score, observation.score,
                       &bank.online_mesh, clock, stages};
  context.online_score.cull_backfaces = options.cull_backfaces && bank.online_mesh_closed;
  const bool coarse = options.coarse_selection_mesh && !bank.selection_mesh.faces.empty();
  context.selection_mesh = coarse ? &bank.selection_mesh : &bank.online_mesh;
  context.selection_score.cull_backfaces =
      options.cull_backfaces && (coarse ? bank.selection_mesh_closed : bank.online_mesh_closed);
  // Observable selection ranks PnP poses before any refinement, their depth often
  // centimetres off: the depth cannot judge them yet (a pose 2 cm too far would have every
  // mask pixel "in front of it", an occluder). It reads the region the depth corrected, as
  // the paper reads the mask; the depth's evidence enters from ICP on.
  context.selection_score.depth_evidence = false;
  return context;
}

}  // namespace g6d
