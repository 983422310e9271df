#include "mesh/symmetry.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <limits>
#include <sstream>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
// Only geometry headers of Open3D (never Open3D.h), and only in this .cc.
#include <open3d/geometry/KDTreeFlann.h>

#include "core/error.h"
#include "core/timer.h"

namespace g6d {

namespace {

constexpr double kDegree = M_PI / 180.0;
// Two rotations closer than this are one symmetry (the de-duplication of the generators
// and of the closure), capped at a quarter of the smallest tested angle 2*pi / max_order
// so that distinct elements of a group stay apart. Larger than a degree: the generators
// come from axes refined separately on a scanned surface, a degree or so apart, and their
// products drift by a few of those.
constexpr double kSameRotationRad = 3.0 * kDegree;
// Candidate axes closer than this are tested once.
constexpr double kSameAxisRad = 1.0 * kDegree;
// Faces whose normals are closer than this belong to one flat part; a flat part holding
// this fraction of the area gives a candidate axis; at most this many parts are tracked.
constexpr double kSameNormalRad = 2.0 * kDegree;
constexpr double kFlatAreaFraction = 0.1;
constexpr size_t kMaxNormalClusters = 32;
// A revolution must pass rotations by all of these angles: pairwise non-commensurate up to
// high orders, so no n-fold symmetry with n <= 8 passes them all (90 degrees catches a
// shape that is merely close to round in a least-squares sense but 4-fold in detail).
constexpr double kRevolutionAnglesDeg[] = {37.0, 13.0, 90.0, 137.0};
// The revolution axis is refined at this angle (generic: not a multiple of 2*pi/n, n <= 8).
constexpr double kRevolutionRefineAngleDeg = 137.0;
// Every candidate is first measured on this many of the samples (they are independent, so
// a prefix is a random subset); only when that mean error is below kRefineGate mean
// tolerances is it measured on all samples. Most candidates fail by far at this stage.
constexpr int kScreenSamples = 256;
// A candidate whose unrefined mean error is below this many mean tolerances is refined
// before its final test: axes from principal components or the bounding box of a scanned
// mesh can be off by a degree or so, which costs up to about 1% of the diameter for a
// flip (the far ends move by diameter * tilt).
constexpr double kRefineGate = 2.5;
// Samples and iterations of the axis refinement (it converges in 3-5 for a true symmetry).
constexpr int kRefineSamples = 512;
constexpr int kRefineIterations = 6;
// The refinement stops when the axis moves less than this (radians).
constexpr double kRefineConvergedRad = 1e-5;
// Fraction of the correspondences kept in each refinement step (the rest, the largest
// distances, are parts that do not map onto themselves, e.g. a handle).
constexpr double kRefineKeepFraction = 0.8;
// Reference points (for finding the nearest faces) per tested sample point; every face
// with positive area gets at least one.
constexpr int kReferencePointsPerSample = 4;
// Faces of this many nearest reference points are searched for the closest surface point.
constexpr int kNearestReferences = 4;
// Percentile of the point-to-surface distances compared against max_tolerance.
constexpr double kMaxPercentile = 0.95;
// Largest closure: the largest finite rotation groups with orders <= 64 have 128 elements
// (dihedral); a longer closure means inconsistent generators.
constexpr size_t kMaxGroupSize = 256;
// Grid step and final precision of the revolution angle in SymmetricPoseDistance().

// Closest point to `p` on the triangle (a, b, c) (Ericson, Real-Time Collision Detection,
// Sec. 5.1.5). The triangle must have positive area.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denominator = 1.0 / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

// Closest points on the mesh surface. The faces near a query are found through a KD-tree
// of reference points spread over every face (a barycentric grid, no randomness); the
// answer is exact unless the closest face holds none of the nearest references, and then
// it is still within the distance to the nearest reference point.
class SurfaceIndex {
 public:
  SurfaceIndex(const Mesh& mesh, double total_area_m2, int reference_points) {
    vertices_.reserve(mesh.vertices.size());
    for (const Eigen::Vector3f& v : mesh.vertices) vertices_.push_back(v.cast<double>());
    const double area_per_point = total_area_m2 / std::max(1, reference_points);
    std::vector<Eigen::Vector3d> points;
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
      const Eigen::Vector3i& face = mesh.faces[f];
      const Eigen::Vector3d& a = vertices_[face[0]];
      const Eigen::Vector3d& b = vertices_[face[1]];
      const Eigen::Vector3d& c = vertices_[face[2]];
      const double area = 0.5 * (b - a).cross(c - a).norm();
      if (!(area > 0.0)) continue;  // no surface, and the closest-point formula divides by it
      const int face_index = static_cast<int>(faces_.size());
      faces_.push_back(face);
      // Centroids of the m * m sub-triangles of an m-subdivision, m^2 ~ area / spacing.
      const int m = std::max(1, static_cast<int>(std::ceil(std::sqrt(area / area_per_point))));
      for (int i = 0; i < m; ++i) {
        for (int j = 0; i + j < m; ++j) {
          const double u_up = (i + 1.0 / 3.0) / m, v_up = (j + 1.0 / 3.0) / m;
          points.push_back(a + u_up * (b - a) + v_up * (c - a));
          reference_faces_.push_back(face_index);
          if (i + j + 1 < m) {
            const double u_down = (i + 2.0 / 3.0) / m, v_down = (j + 2.0 / 3.0) / m;
            points.push_back(a + u_down * (b - a) + v_down * (c - a));
            reference_faces_.push_back(face_index);
          }
        }
      }
    }
    G6D_CHECK(!points.empty());
    data_.resize(3, static_cast<Eigen::Index>(points.size()));
    for (size_t i = 0; i < points.size(); ++i) data_.col(static_cast<Eigen::Index>(i)) = points[i];
    tree_.SetMatrixData(data_);
    indices_.resize(kNearestReferences);
    squared_distances_.resize(kNearestReferences);
  }

  // Distance from `query` to the surface; the closest point in *closest when not null.
  double Closest(const Eigen::Vector3d& query, Eigen::Vector3d* closest) {
    const int found = tree_.SearchKNN(query, kNearestReferences, indices_, squared_distances_);
    double best_squared = std::numeric_limits<double>::infinity();
    Eigen::Vector3d best = query;
    int previous_face = -1;
    for (int k = 0; k < found; ++k) {
      const int face_index = reference_faces_[indices_[k]];
      if (face_index == previous_face) continue;  // neighbours often share a face
      previous_face = face_index;
      const Eigen::Vector3i& face = faces_[face_index];
      const Eigen::Vector3d point =
          ClosestPointOnTriangle(query, vertices_[face[0]], vertices_[face[1]], vertices_[face[2]]);
      const double squared = (point - query).squaredNorm();
      if (squared < best_squared) {
        best_squared = squared;
        best = point;
      }
    }
    if (closest != nullptr) *closest = best;
    return std::sqrt(best_squared);
  }

 private:
  std::vector<Eigen::Vector3d> vertices_;
  std::vector<Eigen::Vector3i> faces_;  // faces with positive area only
  std::vector<int> reference_faces_;    // face of each reference point
  Eigen::MatrixXd data_;                // 3 x references, referenced by the tree
  open3d::geometry::KDTreeFlann tree_;
  std::vector<int> indices_;  // search buffers, reused for every query
  std::vector<double> squared_distances_;
};

// Area-weighted centroid and second moment (about that centroid) of the surface, exact
// per triangle: E[x x^T] over a triangle = (sum_i v_i v_i^T + s s^T) / 12, s = sum_i v_i.
void SurfaceMoments(const Mesh& mesh, Eigen::Vector3d* centroid, Eigen::Matrix3d* covariance) {
  double total_area = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3i& face : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[face[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[face[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[face[2]].cast<double>();
    const double area = 0.5 * (b - a).cross(c - a).norm();
    const Eigen::Vector3d sum = a + b + c;
    total_area += area;
    first += area * sum / 3.0;
    second += area / 12.0 *
              (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose());
  }
  G6D_CHECK(total_area > 0.0);
  *centroid = first / total_area;
  *covariance = second / total_area - *centroid * centroid->transpose();
}

// Normals of the large flat parts of the surface (planes holding at least
// kFlatAreaFraction of the area; at most three, largest first), sign-free. Faces are
// clustered greedily, largest first, into at most kMaxNormalClusters directions.
std::vector<Eigen::Vector3d> FlatPartNormals(const Mesh& mesh, double total_area_m2) {
  struct Face {
    double area;
    Eigen::Vector3d normal;
  };
  std::vector<Face> faces;
  faces.reserve(mesh.faces.size());
  for (const Eigen::Vector3i& face : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[face[0]].cast<double>();
    const Eigen::Vector3d cross = (mesh.vertices[face[1]].cast<double>() - a)
                                      .cross(mesh.vertices[face[2]].cast<double>() - a);
    if (cross.norm() > 0.0) faces.push_back({0.5 * cross.norm(), cross.normalized()});
  }
  std::stable_sort(faces.begin(), faces.end(),
                   [](const Face& a, const Face& b) { return a.area > b.area; });
  std::vector<Eigen::Vector3d> sums;  // area-weighted normal sums, aligned with the seed
  std::vector<double> areas;
  for (const Face& face : faces) {
    bool merged = false;
    for (size_t c = 0; c < sums.size() && !merged; ++c) {
      const double cosine = sums[c].normalized().dot(face.normal);
      if (std::abs(cosine) > std::cos(kSameNormalRad)) {
        sums[c] += (cosine > 0.0 ? face.area : -face.area) * face.normal;
        areas[c] += face.area;
        merged = true;
      }
    }
    if (!merged && sums.size() < kMaxNormalClusters) {
      sums.push_back(face.area * face.normal);
      areas.push_back(face.area);
    }
  }
  std::vector<size_t> order(sums.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&areas](size_t a, size_t b) { return areas[a] > areas[b]; });
  std::vector<Eigen::Vector3d> normals;
  for (size_t i : order) {
    if (normals.size() == 3 || areas[i] < kFlatAreaFraction * total_area_m2) break;
    normals.push_back(sums[i].normalized());
  }
  return normals;
}

// Candidate axes: principal axes of the surface, the bounding-box (object frame) axes,
// and the normals of large flat parts, near-parallel ones dropped. The axis of any n-fold
// symmetry is a principal axis; the other two are for shapes whose principal moments
// coincide (a cube, a square prism), where the principal axes are arbitrary: the box axes
// when the model is aligned with its frame, the face normals when it is a polyhedron.
std::vector<Eigen::Vector3d> CandidateAxes(const Eigen::Matrix3d& covariance,
                                           const std::vector<Eigen::Vector3d>& flat_normals) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  std::vector<Eigen::Vector3d> axes;
  auto add = [&axes](const Eigen::Vector3d& axis) {
    for (const Eigen::Vector3d& existing : axes) {
      if (std::abs(existing.dot(axis)) > std::cos(kSameAxisRad)) return;
    }
    axes.push_back(axis.normalized());
  };
  for (int i = 2; i >= 0; --i) add(solver.eigenvectors().col(i));
  add(Eigen::Vector3d::UnitX());
  add(Eigen::Vector3d::UnitY());
  add(Eigen::Vector3d::UnitZ());
  for (const Eigen::Vector3d& normal : flat_normals) add(normal);
  return axes;
}

// Angle of the rotation taking `a` to `b`, radians.
double RotationAngleBetween(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double cosine = std::clamp(((a.transpose() * b).trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(cosine);
}

// A unit vector perpendicular to `axis`.
Eigen::Vector3d AnyPerpendicular(const Eigen::Vector3d& axis) {
  const Eigen::Vector3d helper =
      std::abs(axis.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return axis.cross(helper).normalized();
}

// Rotation R about the line through `point` as an object_from_object isometry.
Eigen::Isometry3d AboutPoint(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& point) {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = rotation;
  transform.translation() = point - rotation * point;
  return transform;
}

// The state of one FindSymmetries() call: the samples, the surface index and the
// tolerances; measures and refines candidate rotations about the centroid.
class SymmetryTester {
 public:
  SymmetryTester(const SymmetryOptions& options, std::vector<Eigen::Vector3d> centred_samples,
                 SurfaceIndex* surface, const Eigen::Vector3d& centroid, double diameter_m)
      : options_(options),
        samples_(std::move(centred_samples)),
        surface_(surface),
        centroid_(centroid),
        diameter_m_(diameter_m) {}

  // Symmetric point-to-surface error of the rotation about the centroid: the samples
  // moved by R and by R^T (the inverse maps the surface onto the moved surface), each
  // measured against the unmoved surface. Uses the first `sample_count` samples (all
  // when there are fewer).
  SymmetryTest Measure(const Eigen::Vector3d& axis, double angle_rad,
                       int sample_count = std::numeric_limits<int>::max()) {
    const Eigen::Matrix3d rotation = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix();
    const size_t count = std::min(samples_.size(), static_cast<size_t>(sample_count));
    distances_.clear();
    for (size_t i = 0; i < count; ++i) {
      const Eigen::Vector3d& x = samples_[i];
      distances_.push_back(surface_->Closest(centroid_ + rotation * x, nullptr));
      distances_.push_back(surface_->Closest(centroid_ + rotation.transpose() * x, nullptr));
    }
    SymmetryTest test;
    test.axis = axis;
    test.angle_rad = angle_rad;
    test.sample_points = static_cast<int>(count);
    double sum = 0.0;
    for (double d : distances_) sum += d;
    test.mean_error = sum / static_cast<double>(distances_.size()) / diameter_m_;
    const size_t rank =
        static_cast<size_t>(kMaxPercentile * static_cast<double>(distances_.size() - 1));
    std::nth_element(distances_.begin(), distances_.begin() + static_cast<std::ptrdiff_t>(rank),
                     distances_.end());
    test.p95_error = distances_[rank] / diameter_m_;
    test.accepted =
        test.mean_error < options_.mean_tolerance && test.p95_error < options_.max_tolerance;
    return test;
  }

  // True when the unrefined error is small enough for the refinement to be worth it.
  bool WorthRefining(const SymmetryTest& test) const {
    return test.mean_error < kRefineGate * options_.mean_tolerance;
  }

  // The axis refined for a rotation by the fixed `angle_rad` about the centroid:
  // trimmed point-to-surface ICP over the rotation (both directions, as in Measure()),
  // each step's Kabsch rotation reduced to its axis.
  Eigen::Vector3d RefineAxis(const Eigen::Vector3d& initial_axis, double angle_rad) {
    Eigen::Vector3d axis = initial_axis;
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> pairs;  // want R * first = second
    std::vector<double> pair_distances;
    for (int iteration = 0; iteration < kRefineIterations; ++iteration) {
      const Eigen::Matrix3d rotation = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix();
      pairs.clear();
      pair_distances.clear();
      Eigen::Vector3d closest;
      const size_t count = std::min(samples_.size(), static_cast<size_t>(kRefineSamples));
      for (size_t i = 0; i < count; ++i) {
        const Eigen::Vector3d& x = samples_[i];
        // R x should lie on the surface: pair (x, closest(R x)).
        pair_distances.push_back(surface_->Closest(centroid_ + rotation * x, &closest));
        pairs.emplace_back(x, closest - centroid_);
        // R^T x should lie on the surface: pair (closest(R^T x), x).
        pair_distances.push_back(surface_->Closest(centroid_ + rotation.transpose() * x, &closest));
        pairs.emplace_back(closest - centroid_, x);
      }
      std::vector<double> sorted = pair_distances;
      const size_t keep_rank = static_cast<size_t>(kRefineKeepFraction * (sorted.size() - 1));
      std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(keep_rank),
                       sorted.end());
      const double keep_below = sorted[keep_rank];
      // Kabsch without translation (the centroid is fixed): maximize sum second^T R first.
      Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
      for (size_t i = 0; i < pairs.size(); ++i) {
        if (pair_distances[i] <= keep_below) {
          covariance += pairs[i].first * pairs[i].second.transpose();
        }
      }
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance,
                                                  Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d sign = Eigen::Matrix3d::Identity();
      sign(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
      const Eigen::Matrix3d fitted = svd.matrixV() * sign * svd.matrixU().transpose();
      const Eigen::AngleAxisd fitted_angle_axis(fitted);
      // A fit that slid far from the tested angle has no meaningful axis for it.
      if (std::abs(fitted_angle_axis.angle() - angle_rad) > 0.5 * angle_rad) break;
      Eigen::Vector3d new_axis = fitted_angle_axis.axis().normalized();
      if (new_axis.dot(axis) < 0.0) new_axis = -new_axis;
      const double change = (new_axis - axis).norm();
      axis = new_axis;
      if (change < kRefineConvergedRad) break;
    }
    return axis;
  }

 private:
  const SymmetryOptions& options_;
  const std::vector<Eigen::Vector3d> samples_;  // surface samples minus the centroid
  SurfaceIndex* surface_;
  const Eigen::Vector3d centroid_;
  const double diameter_m_;
  std::vector<double> distances_;  // buffer of Measure()
};

// An accepted rotation and its mean error, an input of the closure.
struct Generator {
  Eigen::Matrix3d rotation;
  double mean_error;
};

// The group generated by `generators`, without the identity, in breadth-first order;
// rotations within `same_rad` are one. Returns false (and a partial group) when the
// generators are inconsistent: a product comes within `min_angle_rad` of the identity
// without being within `same_rad` of it (the products of slightly misaligned axes drift
// instead of closing), or the group grows past kMaxGroupSize.
bool CloseGroup(const std::vector<Generator>& generators, double same_rad, double min_angle_rad,
                std::vector<Eigen::Matrix3d>* elements) {
  std::vector<Eigen::Matrix3d> group = {Eigen::Matrix3d::Identity()};
  for (size_t next = 0; next < group.size(); ++next) {
    for (const Generator& generator : generators) {
      const Eigen::Matrix3d product = generator.rotation * group[next];
      const bool known = std::any_of(group.begin(), group.end(), [&](const Eigen::Matrix3d& g) {
        return RotationAngleBetween(g, product) < same_rad;
      });
      if (known) continue;
      if (Eigen::AngleAxisd(product).angle() < min_angle_rad || group.size() == kMaxGroupSize) {
        elements->assign(group.begin() + 1, group.end());
        return false;
      }
      group.push_back(product);
    }
  }
  elements->assign(group.begin() + 1, group.end());
  return true;
}

// The symmetry group from the accepted rotations: near-duplicates are dropped (the one
// with the smaller error is kept), then the rest closed under composition; while that is
// inconsistent, the generator with the largest error is dropped and the closure redone.
std::vector<Eigen::Matrix3d> SymmetryGroup(std::vector<Generator> generators, int max_order) {
  const double smallest_angle_rad = 2.0 * M_PI / max_order;
  const double same_rad = std::min(kSameRotationRad, 0.25 * smallest_angle_rad);
  std::stable_sort(
      generators.begin(), generators.end(),
      [](const Generator& a, const Generator& b) { return a.mean_error < b.mean_error; });
  std::vector<Generator> unique;
  for (const Generator& generator : generators) {
    const bool duplicate = std::any_of(unique.begin(), unique.end(), [&](const Generator& kept) {
      return RotationAngleBetween(kept.rotation, generator.rotation) < same_rad;
    });
    if (!duplicate) unique.push_back(generator);
  }
  std::vector<Eigen::Matrix3d> elements;
  while (!CloseGroup(unique, same_rad, 0.5 * smallest_angle_rad, &elements)) unique.pop_back();
  return elements;
}

// "(0.00, 0.00, 1.00)" with negative zeros printed as zeros.
std::string FormatVector(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << "(";
  for (int i = 0; i < 3; ++i) {
    const double value = std::abs(v[i]) < 0.005 ? 0.0 : v[i];
    out << (i > 0 ? ", " : "") << value;
  }
  out << ")";
  return out.str();
}

}  // namespace

std::string SymmetryOptions::Check() const {
  std::ostringstream out;
  if (sample_points < 10) {
    out << "SymmetryOptions.sample_points must be >= 10 (got " << sample_points << ")";
  } else if (!(mean_tolerance > 0.0 && mean_tolerance <= 1.0)) {
    out << "SymmetryOptions.mean_tolerance must be in (0, 1] (got " << mean_tolerance << ")";
  } else if (!(max_tolerance > 0.0 && max_tolerance <= 1.0)) {
    out << "SymmetryOptions.max_tolerance must be in (0, 1] (got " << max_tolerance << ")";
  } else if (mean_tolerance > max_tolerance) {
    out << "SymmetryOptions.mean_tolerance (" << mean_tolerance
        << ") must not exceed max_tolerance (" << max_tolerance << ")";
  } else if (max_order < 2 || max_order > 64) {
    out << "SymmetryOptions.max_order must be in [2, 64] (got " << max_order << ")";
  }
  return out.str();
}

std::string MeshSymmetries::Describe() const {
  std::ostringstream out;
  if (Empty()) return "none";
  if (revolution) out << "revolution about " << FormatVector(axis);
  if (!discrete.empty()) {
    if (revolution) out << " + ";
    out << discrete.size() << " discrete (";
    for (size_t i = 0; i < discrete.size(); ++i) {
      const Eigen::AngleAxisd angle_axis(discrete[i].linear());
      out << (i > 0 ? ", " : "") << static_cast<int>(std::lround(angle_axis.angle() / kDegree))
          << " deg about " << FormatVector(angle_axis.axis());
    }
    out << ")";
  }
  return out.str();
}

MeshSymmetries FindSymmetries(const Mesh& mesh, const SymmetryOptions& options) {
  const Stopwatch watch;
  const std::string problem = options.Check();
  if (!problem.empty()) G6D_THROW("FindSymmetries: " << problem);
  const double total_area_m2 = ComputeSurfaceArea(mesh);  // throws on bad face indices
  if (!(total_area_m2 > 0.0)) G6D_THROW("FindSymmetries: the mesh has no face with positive area");

  MeshSymmetries result;
  result.diameter_m = ComputeDiameter(mesh);
  Eigen::Matrix3d covariance;
  SurfaceMoments(mesh, &result.point, &covariance);
  const Eigen::Vector3d centroid = result.point;

  std::vector<Eigen::Vector3d> centred_samples;
  for (const Eigen::Vector3f& p : SampleSurface(mesh, options.sample_points, options.seed)) {
    centred_samples.push_back(p.cast<double>() - centroid);
  }
  SurfaceIndex surface(mesh, total_area_m2, kReferencePointsPerSample * options.sample_points);
  SymmetryTester tester(options, std::move(centred_samples), &surface, centroid, result.diameter_m);
  const std::vector<Eigen::Vector3d> axes =
      CandidateAxes(covariance, FlatPartNormals(mesh, total_area_m2));

  // Measures the rotation by `angle_rad` about `axis`: screened on a few samples, then on
  // all, refining the axis first when the unrefined rotation is close but not accepted.
  // Records the tests and returns the last one.
  auto measure_refined = [&](const Eigen::Vector3d& axis, double angle_rad) {
    SymmetryTest test = tester.Measure(axis, angle_rad, kScreenSamples);
    result.tests.push_back(test);
    if (!tester.WorthRefining(test)) return test;
    test = tester.Measure(axis, angle_rad);
    result.tests.push_back(test);
    if (test.accepted || !tester.WorthRefining(test)) return test;
    test = tester.Measure(tester.RefineAxis(axis, angle_rad), angle_rad);
    result.tests.push_back(test);
    return test;
  };
  auto note_accepted = [&result](const SymmetryTest& test) {
    result.worst_error = std::max(result.worst_error, test.mean_error);
    result.worst_p95_error = std::max(result.worst_p95_error, test.p95_error);
  };

  // A revolution: refine the axis at a generic angle, then every test angle must pass.
  for (const Eigen::Vector3d& candidate : axes) {
    const SymmetryTest first =
        tester.Measure(candidate, kRevolutionAnglesDeg[0] * kDegree, kScreenSamples);
    result.tests.push_back(first);
    if (!tester.WorthRefining(first)) continue;
    const Eigen::Vector3d axis = tester.RefineAxis(candidate, kRevolutionRefineAngleDeg * kDegree);
    std::vector<SymmetryTest> passed;
    for (double angle_deg : kRevolutionAnglesDeg) {
      const SymmetryTest test = tester.Measure(axis, angle_deg * kDegree);
      result.tests.push_back(test);
      if (!test.accepted) break;
      passed.push_back(test);
    }
    if (passed.size() != std::size(kRevolutionAnglesDeg)) continue;
    result.revolution = true;
    result.axis = axis;
    for (const SymmetryTest& test : passed) note_accepted(test);
    break;
  }

  if (result.revolution) {
    // The only other proper symmetry of a surface of revolution (not a sphere) is a
    // 180-degree flip about any axis perpendicular to the revolution axis through the
    // centroid; they are all one modulo the revolution, so the first that passes is kept.
    std::vector<Eigen::Vector3d> flip_axes;
    for (const Eigen::Vector3d& candidate : axes) {
      const Eigen::Vector3d perpendicular = candidate - candidate.dot(result.axis) * result.axis;
      if (perpendicular.norm() > 0.5) flip_axes.push_back(perpendicular.normalized());
    }
    if (flip_axes.empty()) flip_axes.push_back(AnyPerpendicular(result.axis));
    for (const Eigen::Vector3d& flip_axis : flip_axes) {
      const SymmetryTest test = measure_refined(flip_axis, M_PI);
      if (!test.accepted) continue;
      // Refinement may tilt the flip axis a little; it must stay perpendicular.
      const Eigen::Vector3d axis =
          (test.axis - test.axis.dot(result.axis) * result.axis).normalized();
      result.discrete.push_back(
          AboutPoint(Eigen::AngleAxisd(M_PI, axis).toRotationMatrix(), centroid));
      note_accepted(test);
      break;
    }
  } else {
    std::vector<Generator> generators;
    for (const Eigen::Vector3d& candidate : axes) {
      for (int order = 2; order <= options.max_order; ++order) {
        const double angle_rad = 2.0 * M_PI / order;
        const SymmetryTest test = measure_refined(candidate, angle_rad);
        if (test.accepted) {
          generators.push_back(
              {Eigen::AngleAxisd(angle_rad, test.axis).toRotationMatrix(), test.mean_error});
        }
      }
    }
    // Compositions are measured too, so that worst_error covers every listed element.
    for (const Eigen::Matrix3d& rotation : SymmetryGroup(generators, options.max_order)) {
      const Eigen::AngleAxisd angle_axis(rotation);
      note_accepted(tester.Measure(angle_axis.axis(), angle_axis.angle()));
      result.discrete.push_back(AboutPoint(rotation, centroid));
    }
  }
  result.time_ms = watch.ElapsedMs();
  return result;
}

double SymmetricPoseDistance(const MeshSymmetries& symmetries,
                             const std::vector<Eigen::Vector3d>& model_points_m,
                             const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  if (model_points_m.empty()) G6D_THROW("SymmetricPoseDistance: model_points_m is empty");
  std::vector<Eigen::Vector3d> a_points;
  a_points.reserve(model_points_m.size());
  for (const Eigen::Vector3d& x : model_points_m) a_points.push_back(a * x);
  // Mean of |a x - b g x| over the points.
  auto mean_distance = [&](const Eigen::Isometry3d& g) {
    const Eigen::Isometry3d b_g = b * g;
    double sum = 0.0;
    for (size_t i = 0; i < model_points_m.size(); ++i) {
      sum += (a_points[i] - b_g * model_points_m[i]).norm();
    }
    return sum / static_cast<double>(model_points_m.size());
  };
  std::vector<Eigen::Isometry3d> elements = {Eigen::Isometry3d::Identity()};
  elements.insert(elements.end(), symmetries.discrete.begin(), symmetries.discrete.end());
  double best = std::numeric_limits<double>::infinity();
  if (!symmetries.revolution) {
    for (const Eigen::Isometry3d& g : elements) best = std::min(best, mean_distance(g));
    return best;
  }
  // The rotation about the axis that best aligns a's points with b g's is found in closed
  // form (least squares in the plane normal to the axis, a 2D Procrustes problem): exact
  // for poses related by a revolution and cheap enough to compare every pair of solver
  // hypotheses. The unrotated element is measured too, so this never exceeds plain ADD.
  const Eigen::Vector3d axis = symmetries.axis.normalized();
  const Eigen::Vector3d& centre = symmetries.point;
  for (const Eigen::Isometry3d& g : elements) {
    const Eigen::Isometry3d object_from_b_g = (b * g).inverse();
    double cos_sum = 0.0, sin_sum = 0.0;
    for (size_t i = 0; i < model_points_m.size(); ++i) {
      // a x in b g's object frame against x, relative to the axis: a x = b g R x for the
      // rotation R about the axis that the sums below determine.
      const Eigen::Vector3d p = object_from_b_g * a_points[i] - centre, q = model_points_m[i] - centre;
      const Eigen::Vector3d p_perp = p - p.dot(axis) * axis, q_perp = q - q.dot(axis) * axis;
      cos_sum += q_perp.dot(p_perp);
      sin_sum += axis.dot(q_perp.cross(p_perp));
    }
    const double angle = std::atan2(sin_sum, cos_sum);
    best = std::min({best, mean_distance(g),
                     mean_distance(g * AboutPoint(Eigen::AngleAxisd(angle, axis).toRotationMatrix(), centre))});
  }
  return best;
}

}  // namespace g6d
