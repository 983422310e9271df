#include "solver/ppf.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "core/timer.h"

namespace g6d {

namespace {

constexpr double kPi = 3.14159265358979323846;

// The bins a value falls in: its own and, within `spread` of a border, the neighbour
// across it (clamped to [0, count)). Returns how many (1 or 2).
int SpreadBins(float value, int count, float spread, std::array<int, 2>* bins) {
  const int bin = static_cast<int>(value);
  const float fraction = value - static_cast<float>(bin);
  (*bins)[0] = std::min(bin, count - 1);
  int n = 1;
  if (fraction < spread && bin - 1 >= 0) (*bins)[n++] = bin - 1;
  else if (fraction > 1.0f - spread && bin + 1 < count) (*bins)[n++] = bin + 1;
  return n;
}

// A grid of cells of side `cell_m` over the scene points, for the pairs within reach.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector3f>& points, float cell_m) : points_(points), inverse_cell_(1.0f / cell_m) {
    cells_.reserve(points.size() / 8 + 16);
    for (size_t i = 0; i < points.size(); ++i) cells_[Key(Cell(points[i]))].push_back(static_cast<int>(i));
  }
  // Calls fn(index) for every point in the 27 cells around p.
  template <typename Fn>
  void ForNear(const Eigen::Vector3f& p, Fn&& fn) const {
    const Eigen::Vector3i c = Cell(p);
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = cells_.find(Key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (int i : it->second) fn(i);
        }
      }
    }
  }

 private:
  Eigen::Vector3i Cell(const Eigen::Vector3f& p) const {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() * inverse_cell_)),
                           static_cast<int>(std::floor(p.y() * inverse_cell_)),
                           static_cast<int>(std::floor(p.z() * inverse_cell_)));
  }
  static uint64_t Key(const Eigen::Vector3i& c) {
    auto part = [](int v) { return static_cast<uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
    return (part(c.x()) << 42) | (part(c.y()) << 21) | part(c.z());
  }
  const std::vector<Eigen::Vector3f>& points_;
  float inverse_cell_;
  std::unordered_map<uint64_t, std::vector<int>> cells_;
};

// A peak of one reference point's accumulator.
struct Peak {
  uint32_t votes = 0;
  int scene_reference = 0;
  int model_reference = 0;
  int alpha_bin = 0;
};

// One reference point's vote: every scene point within the model's reach pairs with scene
// point `sr`, and each pair's feature votes for (model point, rotation bin) in
// `accumulator` (model points x alpha bins, cleared first). Adds to *pairs and *votes.
void AccumulateReference(const PpfModel& model, const PpfScene& scene, const PointGrid& grid, int sr, float spread,
                         uint32_t max_bucket, std::vector<uint32_t>* accumulator_out, long long* pairs_out,
                         long long* votes_out) {
  std::vector<uint32_t>& accumulator = *accumulator_out;
  long long pairs = 0, votes = 0;
  const int alpha_bins = model.alpha_bins;
  const float inverse_step = static_cast<float>(1.0 / model.step_m);
  const float inverse_angle = static_cast<float>(model.angle_bins / kPi);
  const float reach = static_cast<float>(model.max_distance_m);
  const Eigen::Vector3f& p = scene.points[static_cast<size_t>(sr)];
  const Eigen::Vector3f& n = scene.normals[static_cast<size_t>(sr)];
  const Eigen::Isometry3f reference_from_cam = PpfReferenceFrame(p, n);
  std::fill(accumulator.begin(), accumulator.end(), 0u);
  grid.ForNear(p, [&](int si) {
    if (si == sr) return;
    const Eigen::Vector3f& q = scene.points[static_cast<size_t>(si)];
    const Eigen::Vector4f f = PpfFeature(p, n, q, scene.normals[static_cast<size_t>(si)]);
    if (f[0] > reach || f[0] * inverse_step < 1.0f) return;  // beyond the model, or closer than a step
    ++pairs;
    std::array<int, 2> d_bins, a1_bins, a2_bins, a3_bins;
    const int nd = SpreadBins(f[0] * inverse_step, model.distance_bins, spread, &d_bins);
    const int n1 = SpreadBins(f[1] * inverse_angle, model.angle_bins, spread, &a1_bins);
    const int n2 = SpreadBins(f[2] * inverse_angle, model.angle_bins, spread, &a2_bins);
    const int n3 = SpreadBins(f[3] * inverse_angle, model.angle_bins, spread, &a3_bins);
    const int16_t alpha_scene = PpfAngleUnits(PpfAlpha(reference_from_cam * q));
    for (int i0 = 0; i0 < nd; ++i0) {
      for (int i1 = 0; i1 < n1; ++i1) {
        for (int i2 = 0; i2 < n2; ++i2) {
          for (int i3 = 0; i3 < n3; ++i3) {
            const int key = model.Key(d_bins[i0], a1_bins[i1], a2_bins[i2], a3_bins[i3]);
            if (key < 0) continue;
            const uint32_t begin = model.offsets[static_cast<size_t>(key)];
            const uint32_t stop = model.offsets[static_cast<size_t>(key) + 1];
            if (stop - begin > max_bucket) continue;
            for (uint32_t e = begin; e < stop; ++e) {
              const PpfEntry& entry = model.entries[e];
              const uint16_t difference = static_cast<uint16_t>(entry.alpha - alpha_scene);
              const int bin = static_cast<int>((static_cast<uint32_t>(difference) * static_cast<uint32_t>(alpha_bins)) >> 16);
              ++accumulator[static_cast<size_t>(entry.reference) * static_cast<size_t>(alpha_bins) + static_cast<size_t>(bin)];
            }
            votes += stop - begin;
          }
        }
      }
    }
  });
  *pairs_out += pairs;
  *votes_out += votes;
}

// The largest table bucket looked up (PpfSearchOptions::max_bucket_fraction).
uint32_t MaxBucket(const PpfModel& model, const PpfSearchOptions& options) {
  return std::max<uint32_t>(1, static_cast<uint32_t>(options.max_bucket_fraction * static_cast<double>(model.entries.size())));
}

}  // namespace

std::string PpfSearchOptions::Check() const {
  std::ostringstream out;
  if (reference_stride < 1) {
    out << "ppf.reference_stride must be >= 1 (got " << reference_stride << ")";
  } else if (max_reference_points < 1) {
    out << "ppf.max_reference_points must be >= 1 (got " << max_reference_points << ")";
  } else if (!(neighbour_spread >= 0.0 && neighbour_spread < 0.5)) {
    out << "ppf.neighbour_spread must be in [0, 0.5) (got " << neighbour_spread << ")";
  } else if (!(max_bucket_fraction > 0.0 && max_bucket_fraction <= 1.0)) {
    out << "ppf.max_bucket_fraction must be in (0, 1] (got " << max_bucket_fraction << ")";
  } else if (peaks_per_reference < 1) {
    out << "ppf.peaks_per_reference must be >= 1 (got " << peaks_per_reference << ")";
  } else if (!(peak_ratio >= 0.0 && peak_ratio <= 1.0)) {
    out << "ppf.peak_ratio must be in [0, 1] (got " << peak_ratio << ")";
  } else if (!(cluster_distance_fraction > 0.0)) {
    out << "ppf.cluster_distance_fraction must be > 0 (got " << cluster_distance_fraction << ")";
  } else if (!(cluster_angle_deg > 0.0 && cluster_angle_deg <= 180.0)) {
    out << "ppf.cluster_angle_deg must be in (0, 180] (got " << cluster_angle_deg << ")";
  } else if (max_poses < 0) {
    out << "ppf.max_poses must be >= 0 (got " << max_poses << ")";
  } else if (!(min_cluster_ratio >= 0.0 && min_cluster_ratio <= 1.0)) {
    out << "ppf.min_cluster_ratio must be in [0, 1] (got " << min_cluster_ratio << ")";
  } else if (!(normal_radius_steps > 0.0)) {
    out << "ppf.normal_radius_steps must be > 0 (got " << normal_radius_steps << ")";
  } else if (max_scene_points < 10) {
    out << "ppf.max_scene_points must be >= 10 (got " << max_scene_points << ")";
  }
  return out.str();
}

PpfScene MakePpfScene(const Camera& camera, const cv::Mat& depth_m, const cv::Mat& region, double step_m,
                      double normal_cluster_deg, const PpfSearchOptions& options) {
  PpfScene scene;
  if (depth_m.empty() || !(step_m > 0.0)) return scene;
  const bool whole = region.empty();
  // The region's box and median depth set the pixel stride: about two samples per step.
  cv::Rect box(0, 0, depth_m.cols, depth_m.rows);
  if (!whole) box = cv::boundingRect(region);
  if (box.area() == 0) return scene;
  std::vector<float> sampled_depths;
  for (int v = box.y; v < box.y + box.height; v += 4) {
    const float* z_row = depth_m.ptr<float>(v);
    const uint8_t* r_row = whole ? nullptr : region.ptr<uint8_t>(v);
    for (int u = box.x; u < box.x + box.width; u += 4) {
      if (z_row[u] > 0.0f && (whole || r_row[u])) sampled_depths.push_back(z_row[u]);
    }
  }
  if (sampled_depths.empty()) return scene;
  std::nth_element(sampled_depths.begin(), sampled_depths.begin() + static_cast<long>(sampled_depths.size() / 2),
                   sampled_depths.end());
  const double z_median = sampled_depths[sampled_depths.size() / 2];
  const double focal = 0.5 * (camera.fx + camera.fy);
  const double pixels_per_step = focal * step_m / z_median;
  const int stride = std::max(1, static_cast<int>(std::lround(pixels_per_step / 2.0)));
  const float radius_m = static_cast<float>(options.normal_radius_steps * step_m);
  const float radius2 = radius_m * radius_m;
  std::vector<Eigen::Vector3f> points, normals;
  auto point_at = [&](int u, int v, float z) {
    return Eigen::Vector3f(static_cast<float>((u + 0.5 - camera.cx) / camera.fx) * z,
                           static_cast<float>((v + 0.5 - camera.cy) / camera.fy) * z, z);
  };
  for (int v = box.y; v < box.y + box.height; v += stride) {
    const float* z_row = depth_m.ptr<float>(v);
    const uint8_t* r_row = whole ? nullptr : region.ptr<uint8_t>(v);
    for (int u = box.x; u < box.x + box.width; u += stride) {
      const float z = z_row[u];
      if (!(z > 0.0f) || (!whole && !r_row[u])) continue;
      const Eigen::Vector3f p = point_at(u, v, z);
      const int window = std::clamp(static_cast<int>(std::ceil(focal * radius_m / z)), 1, 6);
      const int window_step = window > 3 ? 2 : 1;
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      Eigen::Matrix3f outer = Eigen::Matrix3f::Zero();
      int count = 0;
      for (int dv = -window; dv <= window; dv += window_step) {
        const int y = v + dv;
        if (y < 0 || y >= depth_m.rows) continue;
        const float* n_row = depth_m.ptr<float>(y);
        for (int du = -window; du <= window; du += window_step) {
          const int x = u + du;
          if (x < 0 || x >= depth_m.cols || !(n_row[x] > 0.0f)) continue;
          const Eigen::Vector3f q = point_at(x, y, n_row[x]);
          const Eigen::Vector3f d = q - p;
          if (d.squaredNorm() > radius2) continue;
          sum += d;
          outer += d * d.transpose();
          ++count;
        }
      }
      if (count < 5) continue;
      const Eigen::Vector3f mean = sum / static_cast<float>(count);
      const Eigen::Matrix3f covariance = outer / static_cast<float>(count) - mean * mean.transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver;
      solver.computeDirect(covariance);
      Eigen::Vector3f n = solver.eigenvectors().col(0);
      if (!n.allFinite() || n.squaredNorm() < 0.5f) continue;
      n.normalize();
      if (n.dot(p) > 0.0f) n = -n;  // towards the camera
      points.push_back(p);
      normals.push_back(n);
    }
  }
  VoxelReduceOriented(points, normals, step_m, normal_cluster_deg, &scene.points, &scene.normals);
  if (static_cast<int>(scene.points.size()) > options.max_scene_points) {
    const double keep = static_cast<double>(options.max_scene_points) / static_cast<double>(scene.points.size());
    size_t out = 0;
    for (size_t i = 0; i < scene.points.size(); ++i) {
      if (static_cast<size_t>(std::floor(static_cast<double>(i + 1) * keep)) >
          static_cast<size_t>(std::floor(static_cast<double>(i) * keep))) {
        scene.points[out] = scene.points[i];
        scene.normals[out] = scene.normals[i];
        ++out;
      }
    }
    scene.points.resize(out);
    scene.normals.resize(out);
  }
  return scene;
}

std::vector<PpfPose> VotePpfPoses(const PpfModel& model, const PpfScene& scene, double diameter_m,
                                  const PpfSearchOptions& options, Executor* executor, PpfReport* report) {
  PpfReport local;
  PpfReport& r = report ? *report : local;
  r = PpfReport{};
  const Stopwatch watch;
  std::vector<PpfPose> poses;
  const int scene_count = static_cast<int>(scene.points.size());
  r.scene_points = scene_count;
  if (model.empty() || model.offsets.empty() || scene_count < 3 || options.max_poses == 0) return poses;
  const int model_count = static_cast<int>(model.points.size());
  const int alpha_bins = model.alpha_bins;
  const float reach = static_cast<float>(model.max_distance_m);
  const float spread = static_cast<float>(options.neighbour_spread);
  const uint32_t max_bucket = MaxBucket(model, options);
  const PointGrid grid(scene.points, std::max(reach, 1e-3f));

  std::vector<int> references;
  const int stride = std::max(options.reference_stride, (scene_count + options.max_reference_points - 1) /
                                                            std::max(1, options.max_reference_points));
  for (int i = 0; i < scene_count; i += stride) references.push_back(i);
  r.reference_points = static_cast<int>(references.size());
  constexpr int kBlock = 8;
  const int blocks = (static_cast<int>(references.size()) + kBlock - 1) / kBlock;
  std::vector<std::vector<Peak>> block_peaks(static_cast<size_t>(blocks));
  std::vector<long long> block_pairs(static_cast<size_t>(blocks), 0), block_votes(static_cast<size_t>(blocks), 0);
  executor->ParallelFor(blocks, [&](int b) {
    std::vector<uint32_t> accumulator(static_cast<size_t>(model_count) * static_cast<size_t>(alpha_bins));
    long long pairs = 0, votes = 0;
    const int end = std::min(static_cast<int>(references.size()), (b + 1) * kBlock);
    for (int k = b * kBlock; k < end; ++k) {
      const int sr = references[static_cast<size_t>(k)];
      AccumulateReference(model, scene, grid, sr, spread, max_bucket, &accumulator, &pairs, &votes);
      // The reference's peaks: the best bin, then the next best of other model points.
      std::vector<Peak> peaks;
      for (int taken = 0; taken < options.peaks_per_reference; ++taken) {
        Peak best;
        for (size_t a = 0; a < accumulator.size(); ++a) {
          if (accumulator[a] <= best.votes) continue;
          const int m = static_cast<int>(a / static_cast<size_t>(alpha_bins));
          bool used = false;
          for (const Peak& peak : peaks) used = used || peak.model_reference == m;
          if (used) continue;
          best = Peak{accumulator[a], sr, m, static_cast<int>(a % static_cast<size_t>(alpha_bins))};
        }
        if (best.votes == 0) break;
        if (!peaks.empty() && best.votes < options.peak_ratio * peaks.front().votes) break;
        peaks.push_back(best);
      }
      block_peaks[static_cast<size_t>(b)].insert(block_peaks[static_cast<size_t>(b)].end(), peaks.begin(), peaks.end());
    }
    block_pairs[static_cast<size_t>(b)] = pairs;
    block_votes[static_cast<size_t>(b)] = votes;
  });
  std::vector<Peak> peaks;
  for (int b = 0; b < blocks; ++b) {
    peaks.insert(peaks.end(), block_peaks[static_cast<size_t>(b)].begin(), block_peaks[static_cast<size_t>(b)].end());
    r.pairs += block_pairs[static_cast<size_t>(b)];
    r.votes += block_votes[static_cast<size_t>(b)];
  }
  r.peaks = static_cast<int>(peaks.size());
  std::stable_sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.votes > b.votes; });

  // Pose clustering (Drost): greedily, each pose joins the first cluster whose pose is
  // within the distance and angle, else starts one; a cluster's pose is its best member's.
  const Eigen::Vector3d centre_in_object = [&] {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3f& m : model.points) c += m.cast<double>();
    return Eigen::Vector3d(c / static_cast<double>(model_count));
  }();
  const double max_distance = options.cluster_distance_fraction * diameter_m;
  const double min_cos_half = std::cos(0.5 * options.cluster_angle_deg * kPi / 180.0);
  struct Cluster {
    Eigen::Isometry3d cam_from_object;
    Eigen::Quaterniond rotation;
    Eigen::Vector3d centre;
    double votes;
  };
  std::vector<Cluster> clusters;
  constexpr size_t kMaxClusters = 400;  // the rest of a long tail of single votes says nothing
  for (const Peak& peak : peaks) {
    const Eigen::Isometry3f& model_reference = model.reference_from_object[static_cast<size_t>(peak.model_reference)];
    const Eigen::Isometry3f scene_reference = PpfReferenceFrame(scene.points[static_cast<size_t>(peak.scene_reference)],
                                                                scene.normals[static_cast<size_t>(peak.scene_reference)]);
    const double alpha = (peak.alpha_bin + 0.5) * 2.0 * kPi / alpha_bins;
    Eigen::Isometry3d cam_from_object = scene_reference.inverse().cast<double>() *
                                        Eigen::Isometry3d(Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX())) *
                                        model_reference.cast<double>();
    // The reference frames are single precision: make the rotation orthonormal in double.
    const Eigen::Quaterniond rotation = Eigen::Quaterniond(cam_from_object.linear()).normalized();
    cam_from_object.linear() = rotation.toRotationMatrix();
    const Eigen::Vector3d centre = cam_from_object * centre_in_object;
    bool joined = false;
    for (Cluster& cluster : clusters) {
      if ((cluster.centre - centre).norm() > max_distance) continue;
      if (std::abs(cluster.rotation.dot(rotation)) < min_cos_half) continue;
      cluster.votes += peak.votes;
      joined = true;
      break;
    }
    if (!joined && clusters.size() < kMaxClusters) {
      clusters.push_back(Cluster{cam_from_object, rotation, centre, static_cast<double>(peak.votes)});
    }
  }
  r.clusters = static_cast<int>(clusters.size());
  std::stable_sort(clusters.begin(), clusters.end(), [](const Cluster& a, const Cluster& b) { return a.votes > b.votes; });
  if (!clusters.empty()) r.best_votes = clusters.front().votes;
  for (const Cluster& cluster : clusters) {
    if (static_cast<int>(poses.size()) >= options.max_poses) break;
    if (cluster.votes < options.min_cluster_ratio * r.best_votes) break;
    poses.push_back(PpfPose{cluster.cam_from_object, cluster.votes});
  }
  r.ms = watch.ElapsedMs();
  return poses;
}

std::vector<float> PpfReferenceSupport(const PpfModel& model, const PpfScene& scene, const std::vector<int>& references,
                                       const PpfSearchOptions& options, Executor* executor) {
  std::vector<float> support(references.size(), 0.0f);
  if (model.empty() || model.offsets.empty() || scene.points.size() < 3) return support;
  const size_t bins = model.points.size() * static_cast<size_t>(model.alpha_bins);
  const uint32_t max_bucket = MaxBucket(model, options);
  const PointGrid grid(scene.points, std::max(static_cast<float>(model.max_distance_m), 1e-3f));
  constexpr int kBlock = 8;
  const int blocks = (static_cast<int>(references.size()) + kBlock - 1) / kBlock;
  executor->ParallelFor(blocks, [&](int b) {
    std::vector<uint32_t> accumulator(bins);
    long long pairs = 0, votes = 0;
    const int end = std::min(static_cast<int>(references.size()), (b + 1) * kBlock);
    for (int k = b * kBlock; k < end; ++k) {
      const int sr = references[static_cast<size_t>(k)];
      if (sr < 0 || sr >= static_cast<int>(scene.points.size())) continue;
      AccumulateReference(model, scene, grid, sr, static_cast<float>(options.neighbour_spread), max_bucket, &accumulator,
                          &pairs, &votes);
      support[static_cast<size_t>(k)] = static_cast<float>(*std::max_element(accumulator.begin(), accumulator.end()));
    }
  });
  return support;
}

}  // namespace g6d
