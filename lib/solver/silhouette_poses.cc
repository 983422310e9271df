#include "solver/silhouette_poses.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.h"

namespace g6d {

std::string SilhouetteOptions::Check() const {
  std::ostringstream out;
  if (rotations < 1 || rotations > 360) out << "SilhouetteOptions.rotations must be in [1, 360] (got " << rotations << ")";
  else if (candidates < 0) out << "SilhouetteOptions.candidates must be >= 0 (got " << candidates << ")";
  else if (!(min_iou >= 0.0 && min_iou <= 1.0)) out << "SilhouetteOptions.min_iou must be in [0, 1] (got " << min_iou << ")";
  else if (min_mask_pixels < 1) out << "SilhouetteOptions.min_mask_pixels must be >= 1 (got " << min_mask_pixels << ")";
  return out.str();
}

Eigen::Isometry3d PoseFromSilhouette(const TemplateBank& bank, int view, double angle_rad,
                                     const Eigen::Vector2d& centroid_px, double area_px, const Camera& camera) {
  G6D_CHECK(view >= 0 && view < static_cast<int>(bank.templates.size()) &&
            bank.silhouettes.size() == bank.templates.size());
  const Camera& template_camera = bank.template_camera;
  const Eigen::Isometry3d& template_from_object = bank.templates[static_cast<size_t>(view)].cam_from_object;
  const MaskMoments& template_outline = bank.silhouettes[static_cast<size_t>(view)].moments;
  const Eigen::Vector3d centre_in_object = bank.bounding_box.center();
  const Eigen::Vector3d centre_in_template = template_from_object * centre_in_object;
  // Continuous image coordinates (corner origin): OpenCV pixel centres sit at +0.5.
  const Eigen::Vector2d half(0.5, 0.5);
  const Eigen::Vector2d template_centroid = template_outline.centroid_px + half;
  const Eigen::Vector2d observed_centroid = centroid_px + half;
  // Observed px per template px; the outline turns by R(angle) (x towards y).
  const double scale = std::sqrt(area_px / template_outline.area_px);
  const Eigen::Rotation2Dd turn(angle_rad);
  const Eigen::Vector2d centre_px =
      observed_centroid + scale * (turn * (template_camera.Project(centre_in_template) - template_centroid));
  // Apparent size goes as focal / distance.
  const double template_focal = std::sqrt(template_camera.fx * template_camera.fy);
  const double focal = std::sqrt(camera.fx * camera.fy);
  const double distance_m = centre_in_template.norm() * focal / (template_focal * scale);
  const Eigen::Vector3d ray = camera.Ray(centre_px).normalized();
  // Template frame -> its viewing ray on the optical axis -> turned about it -> onto the ray.
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  const Eigen::Matrix3d to_axis = Eigen::Quaterniond::FromTwoVectors(centre_in_template.normalized(), axis).toRotationMatrix();
  const Eigen::Matrix3d about_axis = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix();
  const Eigen::Matrix3d onto_ray = Eigen::Quaterniond::FromTwoVectors(axis, ray).toRotationMatrix();
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  cam_from_object.linear() = onto_ray * about_axis * to_axis * template_from_object.linear();
  cam_from_object.translation() = ray * distance_m - cam_from_object.linear() * centre_in_object;
  return cam_from_object;
}

std::vector<SilhouettePose> SilhouettePoses(const TemplateBank& bank, const Camera& camera, const cv::Mat& mask,
                                            const SilhouetteOptions& options, const SamePose& same) {
  std::vector<SilhouettePose> poses;
  if (options.candidates == 0 || bank.silhouettes.size() != bank.templates.size() || bank.templates.empty()) {
    return poses;
  }
  const MaskMoments observed = MomentsOfMask(mask);
  if (observed.area_px < options.min_mask_pixels) return poses;
  // The mask's code at every angle; a template's code at 0 equal to the mask's at angle a
  // means the mask is the template's outline turned by a.
  const int rotations = options.rotations;
  std::vector<SilhouetteBits> turned(static_cast<size_t>(rotations));
  const double step_rad = 2.0 * M_PI / rotations;
  for (int k = 0; k < rotations; ++k) turned[static_cast<size_t>(k)] = EncodeSilhouette(mask, observed, k * step_rad);
  struct Match {
    double iou;
    int view;
    int rotation;
  };
  std::vector<Match> matches;
  for (size_t j = 0; j < bank.silhouettes.size(); ++j) {
    if (bank.silhouettes[j].moments.area_px <= 0.0) continue;
    for (int k = 0; k < rotations; ++k) {
      const double iou = SilhouetteIou(bank.silhouettes[j].bits, turned[static_cast<size_t>(k)]);
      if (iou >= options.min_iou) matches.push_back({iou, static_cast<int>(j), k});
    }
  }
  // Best agreement first; ties by template, then angle, so the order never depends on the sort.
  std::sort(matches.begin(), matches.end(), [](const Match& a, const Match& b) {
    if (a.iou != b.iou) return a.iou > b.iou;
    if (a.view != b.view) return a.view < b.view;
    return a.rotation < b.rotation;
  });
  // Neighbouring angles of one template make nearly the same pose: look a bounded way down
  // the list for distinct ones.
  const size_t looked_at = std::min(matches.size(), static_cast<size_t>(options.candidates) * 16);
  for (size_t m = 0; m < looked_at; ++m) {
    const Match& match = matches[m];
    if (static_cast<int>(poses.size()) >= options.candidates) break;
    SilhouettePose pose;
    pose.iou = match.iou;
    pose.template_index = match.view;
    pose.angle_rad = match.rotation * step_rad;
    pose.cam_from_object =
        PoseFromSilhouette(bank, match.view, pose.angle_rad, observed.centroid_px, observed.area_px, camera);
    bool distinct = true;
    for (size_t k = 0; k < poses.size() && distinct && same; ++k) distinct = !same(pose.cam_from_object, poses[k].cam_from_object);
    if (distinct) poses.push_back(pose);
  }
  return poses;
}

}  // namespace g6d
