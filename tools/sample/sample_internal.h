#pragma once
/// @file sample_internal.h
/// What the four files of g6d_sample share and nothing else uses: the seeds of the
/// sample's parts, object placements (sample_layout.cc) and the renderers and frame
/// rendering (sample_render.cc). The public interface is sample_scene.h.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "core/hash.h"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "sample/sample_scene.h"

namespace g6d::sample_internal {

/// Seeds of the parts, derived from the one seed so that changing e.g. the number of
/// frames leaves the objects and the first images unchanged.
inline uint64_t DerivedSeed(uint64_t seed, uint64_t part) {
  return Fnv1a64(&part, sizeof(part), Fnv1a64(&seed, sizeof(seed)));
}
constexpr uint64_t kObjectsPart = 1, kTablePart = 2, kSequencePart = 3, kFramePartBase = 1000;

// ---- sample_layout.cc ----------------------------------------------------------------

/// One object placed on the table.
struct Placement {
  Eigen::Isometry3d world_from_object = Eigen::Isometry3d::Identity();
  std::vector<cv::Point2f> footprint;  ///< convex hull of the vertices seen from above, metres
};

/// Places every object at a random rest, yaw and position without overlapping footprints.
/// False when some object found no free spot.
bool DrawPlacements(const SampleOptions& options, const std::vector<SampleObject>& objects,
                    cv::RNG* rng, std::vector<Placement>* placements);

/// A camera looking at the placements' centroid (jittered) from a random azimuth,
/// elevation and distance within the options' ranges: cam_from_world.
Eigen::Isometry3d DrawCamera(const SampleOptions& options, const std::vector<Placement>& placements,
                             cv::RNG* rng);

// ---- sample_render.cc ----------------------------------------------------------------

/// OSMesa renderers of the objects and the table, created once per dataset.
struct SampleRenderers {
  std::vector<std::unique_ptr<GlRenderer>> objects;
  std::unique_ptr<GlRenderer> table;

  SampleRenderers(const std::vector<SampleObject>& sample_objects, const Mesh& table_mesh) {
    for (const SampleObject& object : sample_objects)
      objects.push_back(std::make_unique<GlRenderer>(object.mesh));
    table = std::make_unique<GlRenderer>(table_mesh);
  }
};

/// Places `objects` at `world_from_object` before the camera at frame->cam_from_world and
/// fills frame->instances (poses; counts, boxes and visibility among the objects alone) and
/// frame->masks. False as soon as an object is not wholly inside the image with the border
/// margin; the frame is then incomplete.
bool MeasureArrangement(const SampleOptions& options, const std::vector<SampleObject>& objects,
                        const std::vector<Eigen::Isometry3d>& world_from_object,
                        SampleFrame* frame);

/// The smallest visib_fract of `instances` (1 when there are none).
double LeastVisible(const std::vector<SampleInstance>& instances);

/// One image of the classic sample: arrangements drawn from `frame_seed` until one is valid
/// (preferring mutual occlusion), then rendered. Throws g6d::Error when none is valid
/// within options.max_tries.
SampleFrame RenderFrameWith(const SampleOptions& options, const std::vector<SampleObject>& objects,
                            const Mesh& table, uint64_t frame_seed, SampleRenderers* renderers);

/// Image `im_id` of a planned sequence; `frame_seed` draws its noise.
SampleFrame RenderPlannedFrame(const SampleOptions& options,
                               const std::vector<SampleObject>& objects, const Mesh& table,
                               const SampleSequencePlan& plan, int im_id, uint64_t frame_seed,
                               SampleRenderers* renderers);

}  // namespace g6d::sample_internal
