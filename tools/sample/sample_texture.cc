// The embedded sample's objects and table: procedural packaging-like prints, textured
// meshes assembled from printed patches (box, can, prism), the wood table. One of the four
// files of g6d_sample (sample_texture, sample_layout, sample_render, sample_writers).
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "eval/bop.h"
#include "sample/sample_scene.h"

namespace g6d {
namespace {

// Gutter between atlas tiles, pixels: linear texture filtering near a tile edge reads
// the gutter, which carries the tile's own print (each print is drawn over its gutter).
constexpr int kAtlasGutterPx = 4;
constexpr int kAtlasMinWidthPx = 1024;

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
}  // namespace

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

}  // namespace g6d
