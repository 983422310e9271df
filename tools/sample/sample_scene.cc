#include "sample/sample_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "core/hash.h"
#include "core/se3.h"
#include "core/timer.h"
#include "eval/bop.h"
#include "render/gl_renderer.h"
#include "render/raster.h"
#include "templates/cache.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// Gutter between atlas tiles, pixels: linear texture filtering near a tile edge reads
// the gutter, which carries the tile's own print (each print is drawn over its gutter).
constexpr int kAtlasGutterPx = 4;
constexpr int kAtlasMinWidthPx = 1024;
// Objects count as occluded in the report below this visible fraction.
constexpr double kOccludedReportFraction = 0.98;
// BOP'19 targets: instances at least this visible.
constexpr double kBopTargetMinVisibFract = 0.1;

// ---------------------------------------------------------------------------------------
// Procedural prints.

cv::Scalar HsvColour(double hue_deg, double saturation, double value) {
  cv::Mat hsv(1, 1, CV_32FC3, cv::Scalar(hue_deg, saturation, value));
  cv::Mat rgb;
  cv::cvtColor(hsv, rgb, cv::COLOR_HSV2RGB);
  const cv::Vec3f c = rgb.at<cv::Vec3f>(0, 0);
  return cv::Scalar(255.0 * c[0], 255.0 * c[1], 255.0 * c[2]);
}

cv::Scalar RandomColour(cv::RNG* rng) {
  return HsvColour(rng->uniform(0.0, 360.0), rng->uniform(0.35, 1.0), rng->uniform(0.25, 1.0));
}

// A colour far in brightness from `reference`, so prints keep contrast for ORB.
cv::Scalar ContrastingColour(const cv::Scalar& reference, cv::RNG* rng) {
  const double brightness = (reference[0] + reference[1] + reference[2]) / 3.0;
  const double value = brightness > 128 ? rng->uniform(0.05, 0.35) : rng->uniform(0.75, 1.0);
  return HsvColour(rng->uniform(0.0, 360.0), rng->uniform(0.3, 1.0), value);
}

std::string RandomWord(cv::RNG* rng) {
  static const char kLetters[] = "ABCDEFGHJKLMNPRSTUVWXYZ0123456789";
  const int length = rng->uniform(3, 8);
  std::string word;
  for (int i = 0; i < length; ++i)
    word += kLetters[rng->uniform(0, static_cast<int>(sizeof(kLetters)) - 1)];
  return word;
}

// Packaging-like print on `tile` (RGB): a two-colour gradient, a band, shapes, words and
// maybe a barcode, all random. The amount of detail scales with the area.
void DrawPrint(cv::Mat tile, cv::RNG* rng) {
  const int w = tile.cols, h = tile.rows;
  const double area = static_cast<double>(w) * h;
  const int short_side = std::min(w, h);
  const cv::Scalar top = RandomColour(rng), bottom = RandomColour(rng);
  for (int y = 0; y < h; ++y) {
    const double t = h > 1 ? static_cast<double>(y) / (h - 1) : 0.0;
    tile.row(y).setTo(top * (1.0 - t) + bottom * t);
  }
  const cv::Scalar base = (top + bottom) * 0.5;
  // A band across the face.
  const int band_height = std::max(2, static_cast<int>(h * rng->uniform(0.12, 0.3)));
  const int band_y = rng->uniform(0, std::max(1, h - band_height));
  cv::rectangle(tile, cv::Rect(0, band_y, w, band_height), RandomColour(rng), cv::FILLED);

  const int shapes = std::max(8, static_cast<int>(area / 2200.0));
  for (int i = 0; i < shapes; ++i) {
    const cv::Scalar colour =
        rng->uniform(0, 2) == 0 ? RandomColour(rng) : ContrastingColour(base, rng);
    const cv::Point centre(rng->uniform(0, w), rng->uniform(0, h));
    const int size = std::max(3, static_cast<int>(short_side * rng->uniform(0.03, 0.14)));
    switch (rng->uniform(0, 5)) {
      case 0:
        cv::circle(tile, centre, size, colour, cv::FILLED, cv::LINE_AA);
        break;
      case 1:
        cv::rectangle(tile, cv::Rect(centre.x, centre.y, size, size * rng->uniform(1, 3) / 2 + 1),
                      colour, cv::FILLED);
        break;
      case 2: {
        const cv::Point points[3] = {centre, centre + cv::Point(size, rng->uniform(-size, size)),
                                     centre + cv::Point(rng->uniform(-size, size), size)};
        cv::fillConvexPoly(tile, points, 3, colour, cv::LINE_AA);
        break;
      }
      case 3:
        cv::circle(tile, centre, size, colour, std::max(2, size / 4), cv::LINE_AA);
        break;
      default:
        cv::line(tile, centre,
                 centre + cv::Point(rng->uniform(-2 * size, 2 * size), rng->uniform(-size, size)),
                 colour, std::max(2, size / 5), cv::LINE_AA);
        break;
    }
  }

  const int fonts[4] = {cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX, cv::FONT_HERSHEY_TRIPLEX,
                        cv::FONT_HERSHEY_COMPLEX};
  const int words = std::max(2, static_cast<int>(area / 9000.0));
  for (int i = 0; i < words; ++i) {
    const int font = fonts[rng->uniform(0, 4)];
    const double text_height = short_side * rng->uniform(0.07, 0.2);
    const double scale = std::max(0.3, text_height / 22.0);  // Hershey glyphs are ~22 px at scale 1
    const int thickness = std::max(1, static_cast<int>(scale * rng->uniform(1.0, 2.5)));
    const cv::Point origin(rng->uniform(-w / 8, w),
                           rng->uniform(static_cast<int>(text_height), h + 1));
    cv::putText(tile, RandomWord(rng), origin, font, scale, ContrastingColour(base, rng), thickness,
                cv::LINE_AA);
  }

  if (area > 20000 && rng->uniform(0, 2) == 0) {
    const cv::Rect code(rng->uniform(0, std::max(1, w - w / 3)),
                        rng->uniform(0, std::max(1, h - h / 5)), std::max(8, w / 3),
                        std::max(6, h / 5));
    cv::rectangle(tile, code, cv::Scalar(245, 245, 240), cv::FILLED);
    for (int x = code.x + 3; x < code.x + code.width - 3;) {
      const int bar = rng->uniform(1, 4);
      if (rng->uniform(0, 2) == 0) {
        cv::rectangle(tile, cv::Rect(x, code.y + 2, bar, std::max(1, code.height - 4)),
                      cv::Scalar(15, 15, 15), cv::FILLED);
      }
      x += bar + rng->uniform(1, 3);
    }
  }
  cv::rectangle(tile, cv::Rect(0, 0, w, h), ContrastingColour(base, rng),
                std::max(2, short_side / 60));
}

// ---------------------------------------------------------------------------------------
// Meshes from textured patches.

// One planar face or strip with its own tile of the texture atlas.
struct Patch {
  cv::Size tile_px;                        // tile size in the atlas
  std::vector<Eigen::Vector3f> positions;  // metres
  std::vector<Eigen::Vector3f> normals;    // unit, outward
  std::vector<Eigen::Vector2f> local_uv;   // in [0, 1]^2 inside the tile, (right, up)
  std::vector<Eigen::Vector3i> triangles;  // indices into this patch's vertices
};

cv::Size TileSize(double width_m, double height_m, double px_per_mm) {
  return {std::max(8, static_cast<int>(std::lround(width_m * 1000.0 * px_per_mm))),
          std::max(8, static_cast<int>(std::lround(height_m * 1000.0 * px_per_mm)))};
}

// Makes every triangle counter-clockwise seen from the side its vertex normals point to.
void OrientTriangles(Patch* patch) {
  for (Eigen::Vector3i& t : patch->triangles) {
    const Eigen::Vector3f face_normal = (patch->positions[t[1]] - patch->positions[t[0]])
                                            .cross(patch->positions[t[2]] - patch->positions[t[0]]);
    const Eigen::Vector3f outward =
        patch->normals[t[0]] + patch->normals[t[1]] + patch->normals[t[2]];
    if (face_normal.dot(outward) < 0.0f) std::swap(t[1], t[2]);
  }
}

// A parallelogram face: corner, corner + u (right), corner + v (up) as seen from outside,
// `outward` says which side that is (the edges are swapped when they disagree, keeping the
// print unmirrored).
Patch QuadPatch(Eigen::Vector3f corner, Eigen::Vector3f u, const Eigen::Vector3f& v,
                const Eigen::Vector3f& outward, double px_per_mm) {
  if (u.cross(v).dot(outward) < 0.0f) {
    corner += u;
    u = -u;
  }
  Patch patch;
  patch.tile_px = TileSize(u.norm(), v.norm(), px_per_mm);
  const Eigen::Vector3f normal = u.cross(v).normalized();
  patch.positions = {corner, corner + u, corner + u + v, corner + v};
  patch.normals.assign(4, normal);
  patch.local_uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  patch.triangles = {{0, 1, 2}, {0, 2, 3}};
  OrientTriangles(&patch);
  return patch;
}

// A convex planar polygon (points in order around it, either direction) facing `outward`.
Patch PolygonPatch(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& outward,
                   double px_per_mm) {
  Patch patch;
  const Eigen::Vector3f normal = outward.normalized();
  const Eigen::Vector3f e1 = (points[1] - points[0]).normalized();
  const Eigen::Vector3f e2 = normal.cross(e1);
  Eigen::Vector2f low(std::numeric_limits<float>::max(), std::numeric_limits<float>::max());
  Eigen::Vector2f high = -low;
  std::vector<Eigen::Vector2f> local;
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector2f q((p - points[0]).dot(e1), (p - points[0]).dot(e2));
    low = low.cwiseMin(q);
    high = high.cwiseMax(q);
    local.push_back(q);
  }
  const Eigen::Vector2f extent = high - low;
  patch.tile_px = TileSize(extent.x(), extent.y(), px_per_mm);
  for (size_t i = 0; i < points.size(); ++i) {
    patch.positions.push_back(points[i]);
    patch.normals.push_back(normal);
    patch.local_uv.push_back((local[i] - low).cwiseQuotient(extent));
  }
  for (int i = 1; i + 1 < static_cast<int>(points.size()); ++i)
    patch.triangles.emplace_back(0, i, i + 1);
  OrientTriangles(&patch);
  return patch;
}

// Packs the tiles into one atlas (rows left to right), draws a print per tile and
// assembles the mesh with UVs into it.
Mesh AssembleTexturedMesh(const std::vector<Patch>& patches, cv::RNG* rng) {
  int atlas_width = kAtlasMinWidthPx;
  for (const Patch& p : patches)
    atlas_width = std::max(atlas_width, p.tile_px.width + 2 * kAtlasGutterPx);
  std::vector<cv::Rect> tiles;
  int x = kAtlasGutterPx, y = kAtlasGutterPx, row_height = 0;
  for (const Patch& p : patches) {
    if (x + p.tile_px.width + kAtlasGutterPx > atlas_width) {
      x = kAtlasGutterPx;
      y += row_height + 2 * kAtlasGutterPx;
      row_height = 0;
    }
    tiles.emplace_back(x, y, p.tile_px.width, p.tile_px.height);
    x += p.tile_px.width + 2 * kAtlasGutterPx;
    row_height = std::max(row_height, p.tile_px.height);
  }
  const int atlas_height = (y + row_height + kAtlasGutterPx + 3) / 4 * 4;

  Mesh mesh;
  mesh.texture = cv::Mat(atlas_height, atlas_width, CV_8UC3, cv::Scalar(128, 128, 128));
  const cv::Rect whole(0, 0, atlas_width, atlas_height);
  for (size_t i = 0; i < patches.size(); ++i) {
    const cv::Rect& tile = tiles[i];
    // Drawn over the gutter too; the UVs below stay inside the tile.
    const cv::Rect with_gutter =
        cv::Rect(tile.x - kAtlasGutterPx / 2, tile.y - kAtlasGutterPx / 2,
                 tile.width + kAtlasGutterPx, tile.height + kAtlasGutterPx) &
        whole;
    DrawPrint(mesh.texture(with_gutter), rng);
    const Patch& patch = patches[i];
    const int base = static_cast<int>(mesh.vertices.size());
    for (size_t k = 0; k < patch.positions.size(); ++k) {
      mesh.vertices.push_back(patch.positions[k]);
      mesh.normals.push_back(patch.normals[k]);
      // Texel centres of the tile's first and last columns / rows at local 0 and 1;
      // texture row 0 is the top (v = 1).
      const double column = tile.x + 0.5 + patch.local_uv[k].x() * (tile.width - 1);
      const double row = tile.y + 0.5 + (1.0 - patch.local_uv[k].y()) * (tile.height - 1);
      mesh.uvs.emplace_back(static_cast<float>(column / atlas_width),
                            static_cast<float>(1.0 - row / atlas_height));
    }
    for (const Eigen::Vector3i& t : patch.triangles)
      mesh.faces.push_back(t + Eigen::Vector3i::Constant(base));
  }
  return mesh;
}

Eigen::Matrix3d RotationTaking(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  return Eigen::Quaterniond::FromTwoVectors(from, to).toRotationMatrix();
}

// Rest on the face with this outward normal (object frame).
SampleRest RestOnFace(const Eigen::Vector3d& outward_normal) {
  SampleRest rest;
  rest.table_from_object = RotationTaking(outward_normal.normalized(), -Eigen::Vector3d::UnitZ());
  return rest;
}

SampleObject MakeBox(double sx, double sy, double sz, double px_per_mm, cv::RNG* rng) {
  const float a = static_cast<float>(sx / 2), b = static_cast<float>(sy / 2),
              c = static_cast<float>(sz / 2);
  const Eigen::Vector3f ex = Eigen::Vector3f::UnitX(), ey = Eigen::Vector3f::UnitY(),
                        ez = Eigen::Vector3f::UnitZ();
  std::vector<Patch> patches = {
      QuadPatch({a, -b, -c}, 2 * b * ey, 2 * c * ez, ex, px_per_mm),
      QuadPatch({-a, b, -c}, -2 * b * ey, 2 * c * ez, -ex, px_per_mm),
      QuadPatch({a, b, -c}, -2 * a * ex, 2 * c * ez, ey, px_per_mm),
      QuadPatch({-a, -b, -c}, 2 * a * ex, 2 * c * ez, -ey, px_per_mm),
      QuadPatch({-a, -b, c}, 2 * a * ex, 2 * b * ey, ez, px_per_mm),
      QuadPatch({-a, b, -c}, 2 * a * ex, -2 * b * ey, -ez, px_per_mm),
  };
  SampleObject object;
  object.kind = "box";
  char text[96];
  std::snprintf(text, sizeof(text), "box %.0f x %.0f x %.0f mm", sx * 1000, sy * 1000, sz * 1000);
  object.dimensions = text;
  object.mesh = AssembleTexturedMesh(patches, rng);
  for (const Eigen::Vector3d& n :
       {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, 1, 0),
        Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1)}) {
    object.rests.push_back(RestOnFace(n));
  }
  return object;
}

SampleObject MakeCylinder(double radius, double height, int segments, double px_per_mm,
                          cv::RNG* rng) {
  const float r = static_cast<float>(radius), half = static_cast<float>(height / 2);
  Patch side;
  side.tile_px = TileSize(2 * M_PI * radius, height, px_per_mm);
  for (int j = 0; j <= segments; ++j) {
    // The seam column j = segments repeats j = 0 with u = 1.
    const double angle = 2 * M_PI * (j % segments) / segments;
    const Eigen::Vector3f radial(static_cast<float>(std::cos(angle)),
                                 static_cast<float>(std::sin(angle)), 0.0f);
    const float u = static_cast<float>(j) / segments;
    side.positions.push_back(r * radial - half * Eigen::Vector3f::UnitZ());
    side.positions.push_back(r * radial + half * Eigen::Vector3f::UnitZ());
    side.normals.push_back(radial);
    side.normals.push_back(radial);
    side.local_uv.emplace_back(u, 0.0f);
    side.local_uv.emplace_back(u, 1.0f);
  }
  for (int j = 0; j < segments; ++j) {
    const int b0 = 2 * j, t0 = 2 * j + 1, b1 = 2 * j + 2, t1 = 2 * j + 3;
    side.triangles.emplace_back(b0, b1, t1);
    side.triangles.emplace_back(b0, t1, t0);
  }
  OrientTriangles(&side);
  std::vector<Eigen::Vector3f> top, bottom;
  for (int j = 0; j < segments; ++j) {
    const double angle = 2 * M_PI * j / segments;
    const Eigen::Vector3f radial(static_cast<float>(std::cos(angle)),
                                 static_cast<float>(std::sin(angle)), 0.0f);
    top.push_back(r * radial + half * Eigen::Vector3f::UnitZ());
    bottom.push_back(r * radial - half * Eigen::Vector3f::UnitZ());
  }
  std::vector<Patch> patches = {side, PolygonPatch(top, Eigen::Vector3f::UnitZ(), px_per_mm),
                                PolygonPatch(bottom, -Eigen::Vector3f::UnitZ(), px_per_mm)};
  SampleObject object;
  object.kind = "cylinder";
  char text[96];
  std::snprintf(text, sizeof(text), "cylinder radius %.0f mm, height %.0f mm", radius * 1000,
                height * 1000);
  object.dimensions = text;
  object.mesh = AssembleTexturedMesh(patches, rng);
  object.rests.push_back(RestOnFace(-Eigen::Vector3d::UnitZ()));
  object.rests.push_back(RestOnFace(Eigen::Vector3d::UnitZ()));
  SampleRest lying;
  lying.table_from_object = RotationTaking(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX());
  lying.free_roll_about_object_z = true;
  object.rests.push_back(lying);
  return object;
}

// A prism along x whose cross-section is an equilateral triangle with a horizontal base
// edge, centred on its bounding box.
SampleObject MakeTriangularPrism(double side, double length, double px_per_mm, cv::RNG* rng) {
  const float s = static_cast<float>(side), half_length = static_cast<float>(length / 2);
  const float height = s * std::sqrt(3.0f) / 2;
  // Cross-section corners (y, z).
  const Eigen::Vector2f corners[3] = {
      {-s / 2, -height / 2}, {s / 2, -height / 2}, {0.0f, height / 2}};
  const Eigen::Vector2f centroid = (corners[0] + corners[1] + corners[2]) / 3.0f;
  std::vector<Patch> patches;
  SampleObject object;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2f p = corners[i], q = corners[(i + 1) % 3];
    const Eigen::Vector2f middle = (p + q) / 2 - centroid;
    const Eigen::Vector3f outward(0.0f, middle.x(), middle.y());
    patches.push_back(QuadPatch({-half_length, p.x(), p.y()}, {2 * half_length, 0, 0},
                                {0, q.x() - p.x(), q.y() - p.y()}, outward, px_per_mm));
    object.rests.push_back(RestOnFace(outward.cast<double>()));
  }
  for (const float sign : {1.0f, -1.0f}) {
    std::vector<Eigen::Vector3f> end;
    for (const Eigen::Vector2f& c : corners) end.emplace_back(sign * half_length, c.x(), c.y());
    patches.push_back(PolygonPatch(end, sign * Eigen::Vector3f::UnitX(), px_per_mm));
    object.rests.push_back(RestOnFace(sign * Eigen::Vector3d::UnitX()));
  }
  object.kind = "prism";
  char text[96];
  std::snprintf(text, sizeof(text), "triangular prism, side %.0f mm, length %.0f mm", side * 1000,
                length * 1000);
  object.dimensions = text;
  object.mesh = AssembleTexturedMesh(patches, rng);
  return object;
}

// A periodic wood-like texture (tiles seamlessly under GL_REPEAT): grain from sinusoids of
// integer frequencies, plus per-pixel noise.
cv::Mat MakeWoodTexture(int size_px, cv::RNG* rng) {
  struct Wave {
    int fx, fy;
    double amplitude, phase;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 6; ++i) {
    waves.push_back({rng->uniform(1, 4), rng->uniform(-2, 3), rng->uniform(0.004, 0.015),
                     rng->uniform(0.0, 2 * M_PI)});
  }
  const int grain_frequency = rng->uniform(10, 16);
  const cv::Vec3d light(200, 162, 118), dark(168, 124, 84);
  cv::Mat texture(size_px, size_px, CV_8UC3);
  for (int y = 0; y < size_px; ++y) {
    for (int x = 0; x < size_px; ++x) {
      const double u = static_cast<double>(x) / size_px, v = static_cast<double>(y) / size_px;
      double warp = 0.0;
      for (const Wave& w : waves)
        warp += w.amplitude * std::sin(2 * M_PI * (w.fx * u + w.fy * v) + w.phase);
      const double grain = 0.5 + 0.5 * std::sin(2 * M_PI * (grain_frequency * (v + warp)));
      const double t = std::pow(grain, 3.0) * 0.85 + rng->uniform(0.0, 0.15);
      const cv::Vec3d c = light * (1.0 - t) + dark * t;
      texture.at<cv::Vec3b>(y, x) =
          cv::Vec3b(cv::saturate_cast<uint8_t>(c[0]), cv::saturate_cast<uint8_t>(c[1]),
                    cv::saturate_cast<uint8_t>(c[2]));
    }
  }
  return texture;
}

// ---------------------------------------------------------------------------------------
// Arrangements.

// One object placed on the table.
struct Placement {
  Eigen::Isometry3d world_from_object = Eigen::Isometry3d::Identity();
  std::vector<cv::Point2f> footprint;  // convex hull of the vertices seen from above, metres
};

// The convex hull of the object's vertices projected on the table plane, at `world_from_object`.
std::vector<cv::Point2f> Footprint(const Mesh& mesh, const Eigen::Isometry3d& world_from_object,
                                   double margin_m) {
  std::vector<cv::Point2f> points;
  Eigen::Vector2d centre = world_from_object.translation().head<2>();
  for (const Eigen::Vector3f& v : mesh.vertices) {
    const Eigen::Vector3d p = world_from_object * v.cast<double>();
    // Grow away from the centre by the margin (conservative for a convex footprint).
    const Eigen::Vector2d offset = p.head<2>() - centre;
    const double length = offset.norm();
    const Eigen::Vector2d grown =
        length > 0 ? centre + offset * ((length + margin_m / 2) / length) : centre;
    points.emplace_back(static_cast<float>(grown.x()), static_cast<float>(grown.y()));
  }
  std::vector<cv::Point2f> hull;
  cv::convexHull(points, hull);
  return hull;
}

bool FootprintsOverlap(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  std::vector<cv::Point2f> intersection;
  return cv::intersectConvexConvex(a, b, intersection, true) > 0.0f;
}

double Uniform(cv::RNG* rng, double low, double high) {
  return low + (high - low) * rng->uniform(0.0, 1.0);
}

// Places every object at a random rest, yaw and position without overlapping footprints.
// False when some object found no free spot.
bool DrawPlacements(const SampleOptions& options, const std::vector<SampleObject>& objects,
                    cv::RNG* rng, std::vector<Placement>* placements) {
  placements->clear();
  constexpr int kSpotTries = 60;
  for (const SampleObject& object : objects) {
    const SampleRest& rest = object.rests[rng->uniform(0, static_cast<int>(object.rests.size()))];
    Eigen::Matrix3d table_from_object = rest.table_from_object;
    if (rest.free_roll_about_object_z) {
      table_from_object = table_from_object *
                          Eigen::AngleAxisd(Uniform(rng, 0, 2 * M_PI), Eigen::Vector3d::UnitZ());
    }
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(Uniform(rng, 0, 2 * M_PI), Eigen::Vector3d::UnitZ()).toRotationMatrix() *
        table_from_object;
    double lowest = std::numeric_limits<double>::max();
    for (const Eigen::Vector3f& v : object.mesh.vertices)
      lowest = std::min(lowest, (rotation * v.cast<double>()).z());
    bool placed = false;
    for (int attempt = 0; attempt < kSpotTries && !placed; ++attempt) {
      // Uniform in the disc.
      const double radius = options.cluster_radius_m * std::sqrt(rng->uniform(0.0, 1.0));
      const double angle = Uniform(rng, 0, 2 * M_PI);
      Placement placement;
      placement.world_from_object = MakePose(
          rotation,
          {radius * std::cos(angle), radius * std::sin(angle), -lowest + options.contact_gap_m});
      placement.footprint =
          Footprint(object.mesh, placement.world_from_object, options.footprint_margin_m);
      placed = std::none_of(placements->begin(), placements->end(), [&](const Placement& other) {
        return FootprintsOverlap(placement.footprint, other.footprint);
      });
      if (placed) placements->push_back(placement);
    }
    if (!placed) return false;
  }
  return true;
}

Eigen::Isometry3d DrawCamera(const SampleOptions& options, const std::vector<Placement>& placements,
                             cv::RNG* rng) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Placement& p : placements) centroid += p.world_from_object.translation();
  centroid /= static_cast<double>(placements.size());
  const Eigen::Vector3d jitter(Uniform(rng, -1, 1), Uniform(rng, -1, 1), Uniform(rng, -1, 1));
  const Eigen::Vector3d target = centroid + options.look_at_jitter_m * jitter;
  const double azimuth = Uniform(rng, 0, 2 * M_PI);
  const double elevation =
      Uniform(rng, options.min_elevation_deg, options.max_elevation_deg) * M_PI / 180.0;
  const double distance = Uniform(rng, options.min_distance_m, options.max_distance_m);
  const Eigen::Vector3d eye =
      target + distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                          std::cos(elevation) * std::sin(azimuth),
                                          std::sin(elevation));
  return LookAt(eye, target, Eigen::Vector3d::UnitZ());
}

RasterOptions DepthOnlyRaster() {
  RasterOptions options;
  options.want_face_id = false;
  return options;
}

// Per-instance counts and boxes from the full silhouettes and the nearest-surface index.
void MeasureInstances(const std::vector<cv::Mat>& full_masks, const cv::Mat& nearest_index,
                      std::vector<SampleInstance>* instances) {
  for (size_t k = 0; k < full_masks.size(); ++k) {
    SampleInstance& instance = (*instances)[k];
    const cv::Mat visible = nearest_index == static_cast<int>(k);
    instance.px_count_all = cv::countNonZero(full_masks[k]);
    instance.px_count_visib = cv::countNonZero(visible);
    instance.visib_fract =
        instance.px_count_all > 0
            ? static_cast<double>(instance.px_count_visib) / instance.px_count_all
            : 0.0;
    instance.bbox_obj = cv::boundingRect(full_masks[k]);
    instance.bbox_visib = cv::boundingRect(visible);
  }
}

// OSMesa renderers of the objects and the table, created once per dataset.
struct SampleRenderers {
  std::vector<std::unique_ptr<GlRenderer>> objects;
  std::unique_ptr<GlRenderer> table;

  SampleRenderers(const std::vector<SampleObject>& sample_objects, const Mesh& table_mesh) {
    for (const SampleObject& object : sample_objects)
      objects.push_back(std::make_unique<GlRenderer>(object.mesh));
    table = std::make_unique<GlRenderer>(table_mesh);
  }
};

// The colour of pixel (x, y) of `image`, or, when the render does not cover it (its
// coverage can differ from the rasterizer's by a pixel along edges), the mean of the
// covered pixels around it.
cv::Vec3b CoveredColour(const GlImage& image, int x, int y, const cv::Vec3b& fallback) {
  if (image.mask.at<uint8_t>(y, x) != 0) return image.rgb.at<cv::Vec3b>(y, x);
  for (int radius = 1; radius <= 3; ++radius) {
    cv::Vec3d sum(0, 0, 0);
    int count = 0;
    for (int dy = -radius; dy <= radius; ++dy) {
      for (int dx = -radius; dx <= radius; ++dx) {
        const int u = x + dx, v = y + dy;
        if (u < 0 || v < 0 || u >= image.mask.cols || v >= image.mask.rows ||
            image.mask.at<uint8_t>(v, u) == 0) {
          continue;
        }
        sum += cv::Vec3d(image.rgb.at<cv::Vec3b>(v, u));
        ++count;
      }
    }
    if (count > 0)
      return cv::Vec3b(cv::saturate_cast<uint8_t>(sum[0] / count),
                       cv::saturate_cast<uint8_t>(sum[1] / count),
                       cv::saturate_cast<uint8_t>(sum[2] / count));
  }
  return fallback;
}

// Places `objects` at `world_from_object` before the camera at frame->cam_from_world and
// fills frame->instances (poses; counts, boxes and visibility among the objects alone) and
// frame->masks. False as soon as an object is not wholly inside the image with the border
// margin; the frame is then incomplete.
bool MeasureArrangement(const SampleOptions& options, const std::vector<SampleObject>& objects,
                        const std::vector<Eigen::Isometry3d>& world_from_object,
                        SampleFrame* frame) {
  const Camera& camera = options.camera;
  const int n = static_cast<int>(objects.size());
  frame->instances.clear();
  frame->masks.clear();
  std::vector<const Mesh*> meshes;
  std::vector<Eigen::Isometry3d> poses;
  RasterImage raster;
  for (int k = 0; k < n; ++k) {
    SampleInstance instance;
    instance.obj_id = objects[k].obj_id;
    instance.cam_from_object = frame->cam_from_world * world_from_object[k];
    meshes.push_back(&objects[k].mesh);
    poses.push_back(instance.cam_from_object);
    Rasterize(objects[k].mesh, camera, instance.cam_from_object, DepthOnlyRaster(), &raster);
    const cv::Mat mask = raster.Mask();
    const cv::Rect box = cv::boundingRect(mask);
    const int m = options.border_margin_px;
    const bool inside = raster.pixel_count > 0 && box.x >= m && box.y >= m &&
                        box.x + box.width <= camera.width - m &&
                        box.y + box.height <= camera.height - m;
    frame->instances.push_back(instance);
    frame->masks.push_back(mask);
    if (!inside) return false;
  }
  cv::Mat nearest, depth;
  ComposeSampleDepth(meshes, poses, nullptr, Eigen::Isometry3d::Identity(), camera, &nearest,
                     &depth);
  MeasureInstances(frame->masks, nearest, &frame->instances);
  return true;
}

double LeastVisible(const std::vector<SampleInstance>& instances) {
  double least_visible = 1.0;
  for (const SampleInstance& instance : instances)
    least_visible = std::min(least_visible, instance.visib_fract);
  return least_visible;
}

// Depth, visible masks and colour of a frame whose camera, instance poses and full masks
// are set; `rng` draws the noise.
void ShadeFrame(const SampleOptions& options, const std::vector<SampleObject>& objects,
                const Mesh& table, SampleRenderers* renderers, cv::RNG* rng, SampleFrame* frame) {
  const Camera& camera = options.camera;
  const int n = static_cast<int>(objects.size());
  std::vector<const Mesh*> meshes;
  for (const SampleObject& object : objects) meshes.push_back(&object.mesh);
  std::vector<Eigen::Isometry3d> poses;
  for (const SampleInstance& instance : frame->instances) poses.push_back(instance.cam_from_object);

  // 1. Depth and visible masks: objects and table by z-buffer, at the camera's resolution.
  cv::Mat nearest;
  ComposeSampleDepth(meshes, poses, &table, frame->cam_from_world, camera, &nearest,
                     &frame->depth_m);
  MeasureInstances(frame->masks, nearest, &frame->instances);
  frame->masks_visib.clear();
  for (int k = 0; k < n; ++k) frame->masks_visib.push_back(nearest == k);
  const double range_m = 65535.0 * options.depth_scale_mm / 1000.0;
  for (int y = 0; y < frame->depth_m.rows; ++y) {
    float* row = frame->depth_m.ptr<float>(y);
    for (int x = 0; x < frame->depth_m.cols; ++x) {
      if (row[x] <= 0.0f) continue;
      row[x] += static_cast<float>(rng->gaussian(options.depth_noise_m));
      if (row[x] <= 0.0f || row[x] >= range_m) row[x] = 0.0f;  // out of the sensor's range
    }
  }

  // 2. Colour: OSMesa renders composed with the same z-buffer at `supersampling` times the
  //    resolution, area-downsampled, plus noise.
  const Camera fine = camera.Scaled(options.supersampling);
  cv::Mat fine_nearest, fine_depth;
  ComposeSampleDepth(meshes, poses, &table, frame->cam_from_world, fine, &fine_nearest,
                     &fine_depth);
  std::vector<GlImage> images;
  for (int k = 0; k < n; ++k) images.push_back(renderers->objects[k]->Render(fine, poses[k]));
  images.push_back(renderers->table->Render(fine, frame->cam_from_world));
  std::vector<cv::Vec3b> mean_colours;
  for (const GlImage& image : images) {
    const cv::Scalar mean = cv::mean(image.rgb, image.mask);
    mean_colours.emplace_back(cv::saturate_cast<uint8_t>(mean[0]),
                              cv::saturate_cast<uint8_t>(mean[1]),
                              cv::saturate_cast<uint8_t>(mean[2]));
  }
  cv::Mat fine_rgb(fine.height, fine.width, CV_8UC3);
  for (int y = 0; y < fine.height; ++y) {
    for (int x = 0; x < fine.width; ++x) {
      const int index = fine_nearest.at<int>(y, x);
      if (index < 0) {
        // Nothing within range: a dim wall, brighter towards the top.
        const uint8_t level =
            static_cast<uint8_t>(70 + 50 * (1.0 - static_cast<double>(y) / fine.height));
        fine_rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(level, level, static_cast<uint8_t>(level + 8));
      } else {
        fine_rgb.at<cv::Vec3b>(y, x) = CoveredColour(images[index], x, y, mean_colours[index]);
      }
    }
  }
  cv::resize(fine_rgb, frame->rgb, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_AREA);
  cv::Mat noise(frame->rgb.size(), CV_32FC3);
  rng->fill(noise, cv::RNG::NORMAL, 0.0, options.color_noise);
  cv::Mat noisy;
  frame->rgb.convertTo(noisy, CV_32FC3);
  noisy += noise;
  noisy.convertTo(frame->rgb, CV_8UC3);  // saturating
}

SampleFrame RenderFrameWith(const SampleOptions& options, const std::vector<SampleObject>& objects,
                            const Mesh& table, uint64_t frame_seed, SampleRenderers* renderers) {
  cv::RNG rng(frame_seed);
  const int n = static_cast<int>(objects.size());

  // Arrangements until one is valid and shows mutual occlusion.
  SampleFrame best;
  bool have_valid = false;
  int tries = 0;
  for (; tries < options.max_tries; ++tries) {
    std::vector<Placement> placements;
    if (!DrawPlacements(options, objects, &rng, &placements)) continue;
    SampleFrame frame;
    frame.cam_from_world = DrawCamera(options, placements, &rng);
    std::vector<Eigen::Isometry3d> world_from_object;
    for (const Placement& placement : placements)
      world_from_object.push_back(placement.world_from_object);
    if (!MeasureArrangement(options, objects, world_from_object, &frame)) continue;
    const double least_visible = LeastVisible(frame.instances);
    if (least_visible < options.min_visible_fraction) continue;
    if (!have_valid || least_visible < options.occlusion_below_fraction) {
      best = std::move(frame);
      have_valid = true;
    }
    if (least_visible < options.occlusion_below_fraction) break;
  }
  if (!have_valid) {
    G6D_THROW("no valid arrangement of "
              << n << " objects in " << options.max_tries
              << " tries (every object inside the image and at least "
              << options.min_visible_fraction
              << " visible): relax min_visible_fraction or the camera distances");
  }
  SampleFrame frame = std::move(best);
  frame.tries = std::min(tries + 1, options.max_tries);
  ShadeFrame(options, objects, table, renderers, &rng, &frame);
  return frame;
}

// ---------------------------------------------------------------------------------------
// Files.

std::string ImageName(int im_id, const char* suffix = ".png") {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d%s", im_id, suffix);
  return name;
}

std::string MaskName(int im_id, int gt_idx) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d_%06d.png", im_id, gt_idx);
  return name;
}

void WriteImage(const fs::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) G6D_THROW("cannot write image '" << path.string() << "'");
}

void WriteJson(const fs::path& path, const Json& json) {
  std::ofstream out(path);
  out << json.dump(1) << "\n";
  out.close();
  if (!out) G6D_THROW("cannot write '" << path.string() << "'");
}

Json BoxJson(const cv::Rect& box) {
  if (box.area() == 0) return Json::array({-1, -1, -1, -1});
  return Json::array({box.x, box.y, box.width, box.height});
}

Json RotationJson(const Eigen::Matrix3d& r) {
  return Json::array(
      {r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2)});
}

Json TranslationMmJson(const Eigen::Vector3d& t_m) {
  return Json::array({t_m.x() * 1000.0, t_m.y() * 1000.0, t_m.z() * 1000.0});
}

// Seeds of the parts, derived from the one seed so that changing e.g. the number of frames
// leaves the objects and the first images unchanged.
uint64_t DerivedSeed(uint64_t seed, uint64_t part) {
  return Fnv1a64(&part, sizeof(part), Fnv1a64(&seed, sizeof(seed)));
}
constexpr uint64_t kObjectsPart = 1, kTablePart = 2, kSequencePart = 3, kFramePartBase = 1000;

// ---------------------------------------------------------------------------------------
// Sequences.

// The camera path of a sequence before any slow-down: at s in [0, 1] the camera looks at
// target + (s - 1/2) drift from azimuth azimuth_mid + (s - 1/2) sweep, elevation
// elevation_mid + elevation_amplitude sin(2 pi s + elevation_phase) and distance likewise.
struct CameraPath {
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  // metres, world
  Eigen::Vector3d drift = Eigen::Vector3d::Zero();   // metres, horizontal
  double azimuth_mid = 0.0, sweep = 0.0;             // radians
  double elevation_mid = 0.0, elevation_amplitude = 0.0, elevation_phase = 0.0;  // radians
  double distance_mid = 0.0, distance_amplitude = 0.0, distance_phase = 0.0;     // metres
};

// A value in [low, high] and its amplitude in [min_amplitude, max_amplitude] such that
// value +- amplitude stays in [low, high].
void DrawWobble(double low, double high, double min_amplitude, double max_amplitude, cv::RNG* rng,
                double* mid, double* amplitude) {
  *amplitude = std::min(Uniform(rng, min_amplitude, max_amplitude), (high - low) / 2);
  *mid = Uniform(rng, low + *amplitude, high - *amplitude);
}

CameraPath DrawCameraPath(const SampleOptions& options, const std::vector<Placement>& placements,
                          cv::RNG* rng) {
  const SampleSequenceOptions& sequence = options.sequence;
  CameraPath path;
  for (const Placement& p : placements) path.target += p.world_from_object.translation();
  path.target /= static_cast<double>(placements.size());
  const Eigen::Vector3d jitter(Uniform(rng, -1, 1), Uniform(rng, -1, 1), Uniform(rng, -1, 1));
  path.target += options.look_at_jitter_m * jitter;
  const double drift_angle = Uniform(rng, 0, 2 * M_PI);
  path.drift =
      sequence.look_at_drift_m * Eigen::Vector3d(std::cos(drift_angle), std::sin(drift_angle), 0);
  path.azimuth_mid = Uniform(rng, 0, 2 * M_PI);
  const double direction = rng->uniform(0, 2) == 0 ? 1.0 : -1.0;
  path.sweep =
      direction * Uniform(rng, sequence.min_sweep_deg, sequence.max_sweep_deg) * M_PI / 180.0;
  constexpr double kRadiansPerDegree = M_PI / 180.0;
  DrawWobble(options.min_elevation_deg * kRadiansPerDegree,
             options.max_elevation_deg * kRadiansPerDegree,
             sequence.min_elevation_wobble_deg * kRadiansPerDegree,
             sequence.max_elevation_wobble_deg * kRadiansPerDegree, rng, &path.elevation_mid,
             &path.elevation_amplitude);
  path.elevation_phase = Uniform(rng, 0, 2 * M_PI);
  DrawWobble(options.min_distance_m, options.max_distance_m, sequence.min_distance_wobble_m,
             sequence.max_distance_wobble_m, rng, &path.distance_mid, &path.distance_amplitude);
  path.distance_phase = Uniform(rng, 0, 2 * M_PI);
  return path;
}

// cam_from_world at s in [0, 1] of `path` with every motion scaled by `scale` in [0, 1]
// (which keeps elevation and distance inside their ranges).
Eigen::Isometry3d CameraOnPath(const CameraPath& path, double scale, double s) {
  const double centred = s - 0.5;
  const Eigen::Vector3d target = path.target + scale * centred * path.drift;
  const double azimuth = path.azimuth_mid + scale * centred * path.sweep;
  const double elevation = path.elevation_mid + scale * path.elevation_amplitude *
                                                    std::sin(2 * M_PI * s + path.elevation_phase);
  const double distance = path.distance_mid + scale * path.distance_amplitude *
                                                  std::sin(2 * M_PI * s + path.distance_phase);
  const Eigen::Vector3d eye =
      target + distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                          std::cos(elevation) * std::sin(azimuth),
                                          std::sin(elevation));
  return LookAt(eye, target, Eigen::Vector3d::UnitZ());
}

// Largest camera centre move (metres) and rotation (degrees) between consecutive poses.
void LargestSteps(const std::vector<Eigen::Isometry3d>& cam_from_world, double* step_m,
                  double* step_deg) {
  *step_m = 0.0;
  *step_deg = 0.0;
  for (size_t i = 1; i < cam_from_world.size(); ++i) {
    const Eigen::Isometry3d a = cam_from_world[i - 1].inverse(), b = cam_from_world[i].inverse();
    *step_m = std::max(*step_m, (a.translation() - b.translation()).norm());
    *step_deg = std::max(*step_deg, RotationErrorDeg(a.linear(), b.linear()));
  }
}

// The poses of `path` at the images of the sequence, slowed down (every motion scaled
// alike) until the camera keeps to the speed and rotation-rate bounds. Returns the scale.
double SampleCameraPath(const SampleOptions& options, const CameraPath& path,
                        std::vector<Eigen::Isometry3d>* cam_from_world) {
  const SampleSequenceOptions& sequence = options.sequence;
  const int frames = options.num_frames;
  // A bound per image step: the motion between images at `fps`.
  const double bound_m = sequence.max_camera_speed_m_s / sequence.fps;
  const double bound_deg = sequence.max_rotation_deg_s / sequence.fps;
  double scale = 1.0;
  // Steps shrink about linearly with the scale (and vanish at 0), so a few rounds settle.
  constexpr int kMaxRounds = 60;
  for (int round = 0; round < kMaxRounds; ++round) {
    cam_from_world->clear();
    for (int i = 0; i < frames; ++i) {
      const double s = frames > 1 ? static_cast<double>(i) / (frames - 1) : 0.0;
      cam_from_world->push_back(CameraOnPath(path, scale, s));
    }
    double step_m = 0.0, step_deg = 0.0;
    LargestSteps(*cam_from_world, &step_m, &step_deg);
    const double excess = std::max(step_m / bound_m, step_deg / bound_deg);
    if (excess <= 1.0) return scale;
    // 2% below the bound, so that the next round lands inside it.
    scale *= 0.98 / excess;
  }
  G6D_THROW("the camera path cannot keep to " << sequence.max_camera_speed_m_s << " m/s and "
                                              << sequence.max_rotation_deg_s << " deg/s at "
                                              << sequence.fps << " fps");
}

// The new place of object k: moved by min_jump_m..max_jump_m in a random direction on the
// table and turned by min_jump_turn_deg..max_jump_turn_deg either way about the vertical
// through its centre, clear of the other footprints. False when no free spot was found.
bool DrawJump(const SampleOptions& options, const std::vector<SampleObject>& objects,
              const std::vector<Placement>& placements, int k, cv::RNG* rng, Placement* jumped,
              double* jump_m, double* turn_deg) {
  const SampleSequenceOptions& sequence = options.sequence;
  constexpr int kSpotTries = 60;
  const Eigen::Isometry3d& before = placements[k].world_from_object;
  for (int attempt = 0; attempt < kSpotTries; ++attempt) {
    const double direction = rng->uniform(0, 2) == 0 ? 1.0 : -1.0;
    *turn_deg = direction * Uniform(rng, sequence.min_jump_turn_deg, sequence.max_jump_turn_deg);
    *jump_m = Uniform(rng, sequence.min_jump_m, sequence.max_jump_m);
    const double angle = Uniform(rng, 0, 2 * M_PI);
    jumped->world_from_object = MakePose(
        Eigen::AngleAxisd(*turn_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
            before.linear(),
        before.translation() + *jump_m * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0));
    jumped->footprint =
        Footprint(objects[k].mesh, jumped->world_from_object, options.footprint_margin_m);
    bool free = true;
    for (int j = 0; j < static_cast<int>(placements.size()) && free; ++j)
      free = j == k || !FootprintsOverlap(jumped->footprint, placements[j].footprint);
    if (free) return true;
  }
  return false;
}

// The images in the order a candidate is checked: those around the jump and the ends
// first, then ever finer strides, so that an invalid candidate fails early.
std::vector<int> CheckOrder(int frames, int abrupt_frame) {
  std::vector<int> order;
  std::vector<bool> taken(frames, false);
  auto take = [&](int i) {
    if (i >= 0 && i < frames && !taken[i]) {
      taken[i] = true;
      order.push_back(i);
    }
  };
  take(abrupt_frame);
  take(abrupt_frame - 1);
  take(0);
  take(frames - 1);
  for (const int stride : {16, 4, 1}) {
    for (int i = 0; i < frames; i += stride) take(i);
  }
  return order;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Public functions.

Eigen::Isometry3d SampleSequencePlan::WorldFromObject(int im_id, int k) const {
  if (k == abrupt_object && abrupt_frame >= 0 && im_id >= abrupt_frame)
    return jumped_world_from_object;
  return world_from_object[k];
}

SampleSequencePlan PlanSampleSequence(const SampleOptions& options,
                                      const std::vector<SampleObject>& objects) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad sample option: " << bad);
  if (static_cast<int>(objects.size()) != options.num_objects)
    G6D_THROW("PlanSampleSequence: " << objects.size() << " objects for num_objects "
                                     << options.num_objects);
  const SampleSequenceOptions& sequence = options.sequence;
  const int n = static_cast<int>(objects.size());
  const int frames = options.num_frames;
  const int abrupt_object =
      sequence.abrupt_frame >= 0 ? std::min(sequence.abrupt_object, n - 1) : -1;
  const std::vector<int> order = CheckOrder(frames, sequence.abrupt_frame);
  cv::RNG rng(DerivedSeed(options.seed, kSequencePart));

  // A single object cannot be hidden by another.
  const bool want_occlusion = n >= 2;
  SampleSequencePlan best;
  int valid_candidates = 0;
  int tries = 0;
  for (; tries < options.max_tries; ++tries) {
    std::vector<Placement> placements;
    if (!DrawPlacements(options, objects, &rng, &placements)) continue;
    SampleSequencePlan plan;
    plan.abrupt_frame = sequence.abrupt_frame;
    plan.abrupt_object = abrupt_object;
    for (const Placement& placement : placements)
      plan.world_from_object.push_back(placement.world_from_object);
    if (abrupt_object >= 0) {
      Placement jumped;
      if (!DrawJump(options, objects, placements, abrupt_object, &rng, &jumped, &plan.jump_m,
                    &plan.jump_turn_deg)) {
        continue;
      }
      plan.jumped_world_from_object = jumped.world_from_object;
    }
    const CameraPath path = DrawCameraPath(options, placements, &rng);
    const double scale = SampleCameraPath(options, path, &plan.cam_from_world);
    plan.sweep_deg = scale * path.sweep * 180.0 / M_PI;
    LargestSteps(plan.cam_from_world, &plan.max_step_m, &plan.max_step_deg);

    bool valid = true;
    for (const int im_id : order) {
      SampleFrame frame;
      frame.cam_from_world = plan.cam_from_world[im_id];
      std::vector<Eigen::Isometry3d> world_from_object;
      for (int k = 0; k < n; ++k) world_from_object.push_back(plan.WorldFromObject(im_id, k));
      const double least_visible = MeasureArrangement(options, objects, world_from_object, &frame)
                                       ? LeastVisible(frame.instances)
                                       : -1.0;
      if (least_visible < options.min_visible_fraction) {
        valid = false;
        break;
      }
      plan.min_visib_fract = std::min(plan.min_visib_fract, least_visible);
    }
    if (!valid) continue;
    plan.occluded = plan.min_visib_fract < options.occlusion_below_fraction;
    if (valid_candidates == 0 || plan.occluded) best = std::move(plan);
    ++valid_candidates;
    if (best.occluded || !want_occlusion || valid_candidates >= sequence.max_valid_candidates)
      break;
  }
  if (valid_candidates == 0) {
    G6D_THROW("no valid sequence of "
              << n << " objects in " << options.max_tries
              << " tries (every object inside the image and at least "
              << options.min_visible_fraction
              << " visible in every image, also after the jump): relax min_visible_fraction, "
                 "the camera distances or the jump");
  }
  best.tries = std::min(tries + 1, options.max_tries);
  return best;
}

std::vector<SampleObject> MakeSampleObjects(int count, uint64_t seed, double texture_px_per_mm) {
  if (count < 1 || count > 3) G6D_THROW("the sample has 1 to 3 objects (got " << count << ")");
  if (!(texture_px_per_mm > 0.0 && texture_px_per_mm <= 20.0)) {
    G6D_THROW("texture_px_per_mm must be in (0, 20] (got " << texture_px_per_mm << ")");
  }
  cv::RNG rng(seed);
  std::vector<SampleObject> objects;
  // Drawn in a fixed order, so object k does not depend on how many follow it.
  objects.push_back(MakeBox(0.120, 0.080, 0.045, texture_px_per_mm, &rng));
  if (count >= 2) objects.push_back(MakeCylinder(0.033, 0.110, 48, texture_px_per_mm, &rng));
  if (count >= 3) objects.push_back(MakeTriangularPrism(0.060, 0.150, texture_px_per_mm, &rng));
  for (size_t k = 0; k < objects.size(); ++k) {
    objects[k].obj_id = static_cast<int>(k) + 1;
    objects[k].name = BopObjectName(objects[k].obj_id);
  }
  return objects;
}

Mesh MakeSampleTable(double size_m, int cells, double tile_m, uint64_t seed) {
  if (!(size_m > 0.0) || cells < 1 || !(tile_m > 0.0)) {
    G6D_THROW("bad table: size " << size_m << " m, " << cells << " cells, tile " << tile_m << " m");
  }
  cv::RNG rng(seed);
  Mesh mesh;
  mesh.texture = MakeWoodTexture(512, &rng);
  const double step = size_m / cells;
  for (int j = 0; j <= cells; ++j) {
    for (int i = 0; i <= cells; ++i) {
      const double x = -size_m / 2 + i * step, y = -size_m / 2 + j * step;
      mesh.vertices.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
      mesh.normals.push_back(Eigen::Vector3f::UnitZ());
      // Repeats every tile_m (the renderer wraps texture coordinates).
      mesh.uvs.emplace_back(static_cast<float>(x / tile_m), static_cast<float>(y / tile_m));
    }
  }
  for (int j = 0; j < cells; ++j) {
    for (int i = 0; i < cells; ++i) {
      const int a = j * (cells + 1) + i, b = a + 1, c = a + cells + 1, d = c + 1;
      // Counter-clockwise seen from above (+z).
      mesh.faces.emplace_back(a, b, d);
      mesh.faces.emplace_back(a, d, c);
    }
  }
  return mesh;
}

void WriteTexturedObj(const Mesh& mesh, const std::string& obj_path) {
  if (!mesh.HasTexture())
    G6D_THROW("WriteTexturedObj: the mesh for '" << obj_path << "' has no texture");
  const fs::path path(obj_path);
  const std::string stem = path.stem().string();
  const fs::path mtl_path = path.parent_path() / (stem + ".mtl");
  const fs::path png_path = path.parent_path() / (stem + ".png");
  cv::Mat bgr;
  cv::cvtColor(mesh.texture, bgr, cv::COLOR_RGB2BGR);
  WriteImage(png_path, bgr);
  {
    std::ofstream mtl(mtl_path);
    mtl << "# g6d-make-sample: procedural print\nnewmtl print\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd "
           "1\nillum 1\n"
        << "map_Kd " << png_path.filename().string() << "\n";
    mtl.close();
    if (!mtl) G6D_THROW("cannot write '" << mtl_path.string() << "'");
  }
  std::ofstream obj(path);
  obj << "# g6d-make-sample: procedurally textured object, units: metres\n"
      << "mtllib " << mtl_path.filename().string() << "\no " << stem << "\n";
  char line[160];
  for (const Eigen::Vector3f& v : mesh.vertices) {
    std::snprintf(line, sizeof(line), "v %.7f %.7f %.7f\n", v.x(), v.y(), v.z());
    obj << line;
  }
  for (const Eigen::Vector2f& uv : mesh.uvs) {
    std::snprintf(line, sizeof(line), "vt %.7f %.7f\n", uv.x(), uv.y());
    obj << line;
  }
  for (const Eigen::Vector3f& n : mesh.normals) {
    std::snprintf(line, sizeof(line), "vn %.6f %.6f %.6f\n", n.x(), n.y(), n.z());
    obj << line;
  }
  obj << "usemtl print\n";
  const bool has_normals = mesh.normals.size() == mesh.vertices.size();
  for (const Eigen::Vector3i& f : mesh.faces) {
    obj << "f";
    for (int k = 0; k < 3; ++k) {
      const int i = f[k] + 1;  // OBJ indices are 1-based
      obj << " " << i << "/" << i;
      if (has_normals) obj << "/" << i;
    }
    obj << "\n";
  }
  obj.close();
  if (!obj) G6D_THROW("cannot write '" << obj_path << "'");
}

std::string SampleOptions::Check() const {
  std::ostringstream out;
  auto finite_positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (num_objects < 1 || num_objects > 3)
    out << "num_objects must be in 1..3 (got " << num_objects << ")";
  else if (num_frames < 1 || num_frames > 10000)
    out << "num_frames must be in 1..10000 (got " << num_frames << ")";
  else if (const std::string bad = camera.Check(); !bad.empty())
    out << "camera: " << bad;
  else if (!finite_positive(min_distance_m) || !(max_distance_m >= min_distance_m)) {
    out << "min_distance_m / max_distance_m must satisfy 0 < min <= max (got " << min_distance_m
        << ", " << max_distance_m << ")";
  } else if (!(min_elevation_deg > 0.0) || !(max_elevation_deg >= min_elevation_deg) ||
             !(max_elevation_deg <= 90.0)) {
    out << "min_elevation_deg / max_elevation_deg must satisfy 0 < min <= max <= 90 (got "
        << min_elevation_deg << ", " << max_elevation_deg << ")";
  } else if (!(look_at_jitter_m >= 0.0))
    out << "look_at_jitter_m must be >= 0";
  else if (!finite_positive(cluster_radius_m))
    out << "cluster_radius_m must be > 0";
  else if (!(contact_gap_m >= 0.0))
    out << "contact_gap_m must be >= 0";
  else if (!(footprint_margin_m >= 0.0))
    out << "footprint_margin_m must be >= 0";
  else if (!(min_visible_fraction >= 0.0 && min_visible_fraction <= 1.0))
    out << "min_visible_fraction must be in [0, 1]";
  else if (!(occlusion_below_fraction >= 0.0 && occlusion_below_fraction <= 1.0)) {
    out << "occlusion_below_fraction must be in [0, 1]";
  } else if (max_tries < 1)
    out << "max_tries must be >= 1";
  else if (border_margin_px < 0)
    out << "border_margin_px must be >= 0";
  else if (!(depth_noise_m >= 0.0 && depth_noise_m < 0.1))
    out << "depth_noise_m must be in [0, 0.1) m";
  else if (!(color_noise >= 0.0 && color_noise <= 64.0))
    out << "color_noise must be in [0, 64]";
  else if (!finite_positive(depth_scale_mm))
    out << "depth_scale_mm must be > 0";
  else if (supersampling < 1 || supersampling > 4)
    out << "supersampling must be in 1..4";
  else if (!(texture_px_per_mm > 0.0 && texture_px_per_mm <= 20.0))
    out << "texture_px_per_mm must be in (0, 20]";
  else if (!finite_positive(table_size_m) || table_cells < 1 || !finite_positive(table_tile_m)) {
    out << "table_size_m, table_cells and table_tile_m must be > 0";
  } else if (const std::string bad = sequence.Check(); !bad.empty()) {
    out << "sequence." << bad;
  } else if (sequence.enabled && sequence.abrupt_frame != -1 &&
             (sequence.abrupt_frame < 1 || sequence.abrupt_frame >= num_frames)) {
    out << "sequence.abrupt_frame must be -1 or in 1..num_frames-1 = " << num_frames - 1 << " (got "
        << sequence.abrupt_frame << ")";
  }
  return out.str();
}

std::string SampleSequenceOptions::Check() const {
  std::ostringstream out;
  // Each pair: 0 <= low <= high (and finite).
  auto range = [](double low, double high) {
    return std::isfinite(low) && std::isfinite(high) && low >= 0.0 && high >= low;
  };
  if (!(std::isfinite(fps) && fps > 0.0))
    out << "fps must be finite and > 0 (got " << fps << ")";
  else if (abrupt_frame < -1)
    out << "abrupt_frame must be -1 (none) or an image index (got " << abrupt_frame << ")";
  else if (abrupt_object < 0)
    out << "abrupt_object must be >= 0 (got " << abrupt_object << ")";
  else if (max_valid_candidates < 1)
    out << "max_valid_candidates must be >= 1 (got " << max_valid_candidates << ")";
  else if (!range(min_sweep_deg, max_sweep_deg) || max_sweep_deg > 180.0) {
    out << "min_sweep_deg / max_sweep_deg must satisfy 0 <= min <= max <= 180 (got "
        << min_sweep_deg << ", " << max_sweep_deg << ")";
  } else if (!range(min_elevation_wobble_deg, max_elevation_wobble_deg)) {
    out << "min_elevation_wobble_deg / max_elevation_wobble_deg must satisfy 0 <= min <= max";
  } else if (!range(min_distance_wobble_m, max_distance_wobble_m)) {
    out << "min_distance_wobble_m / max_distance_wobble_m must satisfy 0 <= min <= max";
  } else if (!(look_at_drift_m >= 0.0 && std::isfinite(look_at_drift_m)))
    out << "look_at_drift_m must be >= 0";
  else if (!(max_camera_speed_m_s > 0.0 && std::isfinite(max_camera_speed_m_s)))
    out << "max_camera_speed_m_s must be > 0";
  else if (!(max_rotation_deg_s > 0.0 && std::isfinite(max_rotation_deg_s)))
    out << "max_rotation_deg_s must be > 0";
  else if (!range(min_jump_m, max_jump_m) || !(min_jump_m > 0.0)) {
    out << "min_jump_m / max_jump_m must satisfy 0 < min <= max (got " << min_jump_m << ", "
        << max_jump_m << ")";
  } else if (!range(min_jump_turn_deg, max_jump_turn_deg) || max_jump_turn_deg > 180.0) {
    out << "min_jump_turn_deg / max_jump_turn_deg must satisfy 0 <= min <= max <= 180 (got "
        << min_jump_turn_deg << ", " << max_jump_turn_deg << ")";
  }
  return out.str();
}

void ComposeSampleDepth(const std::vector<const Mesh*>& meshes,
                        const std::vector<Eigen::Isometry3d>& cam_from_object, const Mesh* table,
                        const Eigen::Isometry3d& cam_from_world, const Camera& camera,
                        cv::Mat* nearest_index, cv::Mat* depth_m) {
  G6D_CHECK(meshes.size() == cam_from_object.size());
  *nearest_index = cv::Mat(camera.height, camera.width, CV_32S, cv::Scalar(-1));
  *depth_m = cv::Mat::zeros(camera.height, camera.width, CV_32F);
  RasterImage raster;
  const int n = static_cast<int>(meshes.size());
  for (int k = 0; k <= n; ++k) {
    if (k < n) {
      Rasterize(*meshes[k], camera, cam_from_object[k], DepthOnlyRaster(), &raster);
    } else if (table != nullptr) {
      Rasterize(*table, camera, cam_from_world, DepthOnlyRaster(), &raster);
    } else {
      break;
    }
    for (int y = 0; y < camera.height; ++y) {
      const float* z = raster.depth.ptr<float>(y);
      float* best = depth_m->ptr<float>(y);
      int* index = nearest_index->ptr<int>(y);
      for (int x = 0; x < camera.width; ++x) {
        // Strictly nearer wins: ties keep the lower index.
        if (z[x] > 0.0f && (index[x] < 0 || z[x] < best[x])) {
          best[x] = z[x];
          index[x] = k;
        }
      }
    }
  }
}

Mesh SampleTableFor(const SampleOptions& options) {
  return MakeSampleTable(options.table_size_m, options.table_cells, options.table_tile_m,
                         DerivedSeed(options.seed, kTablePart));
}

SampleFrame RenderSampleFrame(const SampleOptions& options,
                              const std::vector<SampleObject>& objects, const Mesh& table,
                              uint64_t frame_seed) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad sample option: " << bad);
  SampleRenderers renderers(objects, table);
  return RenderFrameWith(options, objects, table, frame_seed, &renderers);
}

namespace {

// Image `im_id` of a planned sequence; `frame_seed` draws its noise.
SampleFrame RenderPlannedFrame(const SampleOptions& options,
                               const std::vector<SampleObject>& objects, const Mesh& table,
                               const SampleSequencePlan& plan, int im_id, uint64_t frame_seed,
                               SampleRenderers* renderers) {
  SampleFrame frame;
  frame.cam_from_world = plan.cam_from_world[im_id];
  std::vector<Eigen::Isometry3d> world_from_object;
  for (int k = 0; k < static_cast<int>(objects.size()); ++k)
    world_from_object.push_back(plan.WorldFromObject(im_id, k));
  // PlanSampleSequence() checked this very view.
  const bool inside = MeasureArrangement(options, objects, world_from_object, &frame);
  G6D_CHECK(inside);
  frame.tries = 1;
  cv::RNG rng(frame_seed);
  ShadeFrame(options, objects, table, renderers, &rng, &frame);
  return frame;
}

}  // namespace

SampleReport WriteSampleDataset(const SampleOptions& options, const std::string& root,
                                const SampleProgressCallback& progress) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad sample option: " << bad);
  const Stopwatch watch;
  auto say = [&](const std::string& line) {
    if (progress) progress(line);
  };
  SampleReport report;
  const fs::path models = fs::path(root) / "models";
  const fs::path scene = fs::path(root) / "test" / "000001";
  // A stale scene from a run with more frames must not survive.
  fs::remove_all(scene);
  fs::remove_all(models);
  for (const char* folder : {"rgb", "depth", "mask", "mask_visib"})
    fs::create_directories(scene / folder);
  fs::create_directories(models);

  // 1. Objects: written, then read back, so that rendering uses exactly the files.
  const std::vector<SampleObject> generated = MakeSampleObjects(
      options.num_objects, DerivedSeed(options.seed, kObjectsPart), options.texture_px_per_mm);
  Json models_info = Json::object();
  for (const SampleObject& object : generated) {
    const fs::path obj_path = models / (object.name + ".obj");
    WriteTexturedObj(object.mesh, obj_path.string());
    SampleObject loaded = object;
    loaded.mesh = LoadMesh(obj_path.string(), Units::kMetres);
    const double diameter_m = ComputeDiameter(loaded.mesh);
    const Eigen::AlignedBox3d box = ComputeBoundingBox(loaded.mesh);
    models_info[std::to_string(object.obj_id)] = {
        {"diameter", diameter_m * 1000.0},      {"min_x", box.min().x() * 1000.0},
        {"min_y", box.min().y() * 1000.0},      {"min_z", box.min().z() * 1000.0},
        {"size_x", box.sizes().x() * 1000.0},   {"size_y", box.sizes().y() * 1000.0},
        {"size_z", box.sizes().z() * 1000.0},   {"units", "m"},
        {"mesh", obj_path.filename().string()}, {"name", object.kind},
    };
    char line[200];
    std::snprintf(line, sizeof(line), "object %s: %s, diameter %.1f mm, %zu faces, texture %dx%d",
                  object.name.c_str(), object.dimensions.c_str(), diameter_m * 1000.0,
                  loaded.mesh.faces.size(), loaded.mesh.texture.cols, loaded.mesh.texture.rows);
    say(line);
    report.diameters_m.push_back(diameter_m);
    report.objects.push_back(std::move(loaded));
  }
  WriteJson(models / "models_info.json", models_info);
  const Camera& camera = options.camera;
  WriteJson(fs::path(root) / "camera.json", {{"cx", camera.cx},
                                             {"cy", camera.cy},
                                             {"depth_scale", options.depth_scale_mm},
                                             {"fx", camera.fx},
                                             {"fy", camera.fy},
                                             {"height", camera.height},
                                             {"width", camera.width}});

  // 2. Images: each its own arrangement, or the planned sequence.
  const Mesh table = SampleTableFor(options);
  SampleRenderers renderers(report.objects, table);
  const SampleSequenceOptions& sequence = options.sequence;
  if (sequence.enabled) {
    report.sequence = PlanSampleSequence(options, report.objects);
    const SampleSequencePlan& plan = report.sequence;
    char line[320];
    std::snprintf(line, sizeof(line),
                  "sequence: %d images at %.0f fps, camera sweeps %.1f deg, steps up to %.1f mm "
                  "and %.2f deg per image, objects at least %.2f visible (%d candidate%s drawn)",
                  options.num_frames, sequence.fps, plan.sweep_deg, plan.max_step_m * 1000.0,
                  plan.max_step_deg, plan.min_visib_fract, plan.tries, plan.tries == 1 ? "" : "s");
    say(line);
    if (plan.abrupt_object >= 0) {
      std::snprintf(line, sizeof(line),
                    "sequence: %s jumps at image %d by %.1f mm and %.1f deg about the table normal",
                    report.objects[plan.abrupt_object].name.c_str(), plan.abrupt_frame,
                    plan.jump_m * 1000.0, plan.jump_turn_deg);
      say(line);
    }
  }
  Json scene_gt = Json::object(), scene_camera = Json::object(), scene_gt_info = Json::object();
  Json targets = Json::array();
  double visib_sum = 0.0;
  for (int im_id = 0; im_id < options.num_frames; ++im_id) {
    const uint64_t frame_seed = DerivedSeed(options.seed, kFramePartBase + im_id);
    const SampleFrame frame =
        sequence.enabled ? RenderPlannedFrame(options, report.objects, table, report.sequence,
                                              im_id, frame_seed, &renderers)
                         : RenderFrameWith(options, report.objects, table, frame_seed, &renderers);
    cv::Mat bgr;
    cv::cvtColor(frame.rgb, bgr, cv::COLOR_RGB2BGR);
    WriteImage(scene / "rgb" / ImageName(im_id), bgr);
    cv::Mat depth_units(frame.depth_m.size(), CV_16U);
    const double units_per_m = 1000.0 / options.depth_scale_mm;
    for (int y = 0; y < depth_units.rows; ++y) {
      for (int x = 0; x < depth_units.cols; ++x) {
        depth_units.at<uint16_t>(y, x) =
            static_cast<uint16_t>(std::lround(frame.depth_m.at<float>(y, x) * units_per_m));
      }
    }
    WriteImage(scene / "depth" / ImageName(im_id), depth_units);

    Json gt_list = Json::array(), info_list = Json::array();
    std::string visib_text;
    for (size_t k = 0; k < frame.instances.size(); ++k) {
      const SampleInstance& instance = frame.instances[k];
      WriteImage(scene / "mask" / MaskName(im_id, static_cast<int>(k)), frame.masks[k]);
      WriteImage(scene / "mask_visib" / MaskName(im_id, static_cast<int>(k)), frame.masks_visib[k]);
      gt_list.push_back({{"cam_R_m2c", RotationJson(instance.cam_from_object.linear())},
                         {"cam_t_m2c", TranslationMmJson(instance.cam_from_object.translation())},
                         {"obj_id", instance.obj_id}});
      const cv::Mat has_depth = depth_units > 0;
      const cv::Mat valid = frame.masks[k] & has_depth;
      info_list.push_back({{"bbox_obj", BoxJson(instance.bbox_obj)},
                           {"bbox_visib", BoxJson(instance.bbox_visib)},
                           {"px_count_all", instance.px_count_all},
                           {"px_count_valid", cv::countNonZero(valid)},
                           {"px_count_visib", instance.px_count_visib},
                           {"visib_fract", instance.visib_fract}});
      if (instance.visib_fract >= kBopTargetMinVisibFract) {
        targets.push_back(
            {{"im_id", im_id}, {"inst_count", 1}, {"obj_id", instance.obj_id}, {"scene_id", 1}});
      }
      ++report.instances_written;
      report.occluded_instances += instance.visib_fract < kOccludedReportFraction;
      report.min_visib_fract = std::min(report.min_visib_fract, instance.visib_fract);
      visib_sum += instance.visib_fract;
      char text[16];
      std::snprintf(text, sizeof(text), " %.2f", instance.visib_fract);
      visib_text += text;
    }
    const std::string key = std::to_string(im_id);
    scene_gt[key] = gt_list;
    scene_gt_info[key] = info_list;
    scene_camera[key] = {{"cam_K", Json::array({camera.fx, 0.0, camera.cx, 0.0, camera.fy,
                                                camera.cy, 0.0, 0.0, 1.0})},
                         {"cam_R_w2c", RotationJson(frame.cam_from_world.linear())},
                         {"cam_t_w2c", TranslationMmJson(frame.cam_from_world.translation())},
                         {"depth_scale", options.depth_scale_mm}};
    ++report.frames_written;
    char line[200];
    if (sequence.enabled) {
      const SampleSequencePlan& plan = report.sequence;
      std::snprintf(
          line, sizeof(line), "image %d/%d: visible fractions%s%s%s", im_id + 1, options.num_frames,
          visib_text.c_str(), im_id == plan.abrupt_frame ? ", jumped: " : "",
          im_id == plan.abrupt_frame ? report.objects[plan.abrupt_object].name.c_str() : "");
    } else {
      std::snprintf(line, sizeof(line), "image %d/%d: visible fractions%s (%d arrangement%s drawn)",
                    im_id + 1, options.num_frames, visib_text.c_str(), frame.tries,
                    frame.tries == 1 ? "" : "s");
    }
    say(line);
  }
  WriteJson(scene / "scene_gt.json", scene_gt);
  WriteJson(scene / "scene_camera.json", scene_camera);
  WriteJson(scene / "scene_gt_info.json", scene_gt_info);
  WriteJson(fs::path(root) / "test_targets_bop19.json", targets);

  report.mean_visib_fract =
      report.instances_written > 0 ? visib_sum / report.instances_written : 0.0;
  report.seconds = watch.ElapsedMs() / 1000.0;
  report.success = true;
  report.message = "ok";
  return report;
}

SampleCacheEntry WriteSampleCache(const TemplateBuildOptions& options, const BopObjectInfo& object,
                                  const std::string& cache_path, Executor* executor) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad template option: " << bad);
  const Stopwatch watch;
  const Mesh mesh = LoadMesh(object.mesh_path, object.mesh_units);
  TemplateBank bank = BuildTemplateBank(mesh, object.name, options, executor);
  // Provenance exactly as g6d-build-templates records it.
  bank.mesh_hash = HashFile(object.mesh_path);
  bank.mesh_path = object.mesh_path;
  bank.mesh_units = object.mesh_units;
  const fs::path parent = fs::path(cache_path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
  WriteTemplateCache(bank, cache_path);
  SampleCacheEntry entry;
  entry.object_id = object.name;
  entry.path = cache_path;
  entry.templates = static_cast<int>(bank.templates.size());
  entry.keypoints = bank.NumKeypoints();
  entry.bytes = static_cast<int64_t>(fs::file_size(cache_path));
  entry.seconds = watch.ElapsedMs() / 1000.0;
  return entry;
}

}  // namespace g6d
