// g6d-inspect: prints what a template cache holds and draws a contact sheet.
//
//   g6d-inspect caches/obj_000001.g6dcache [--sheet sheet.png] [--max 64] [--cell 128]
//       [--fewest]
//
// The contact sheet shows, for up to --max templates evenly spread over the bank (or the
// --max templates with the fewest keypoints), the
// stored grey thumbnail of the normalized crop, the outline of the template mask (green)
// and the stored keypoints (coloured dots). It needs no OpenGL: everything comes from the
// cache.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/hash.h"
#include "mesh/mesh.h"
#include "templates/cache.h"
#include "templates/template_bank.h"

namespace {

void PrintSummary(const g6d::TemplateBank& bank, const std::string& path) {
  const g6d::TemplateBuildOptions& o = bank.options;
  std::vector<size_t> counts;
  for (const g6d::Template& t : bank.templates) counts.push_back(t.keypoints.size());
  std::sort(counts.begin(), counts.end());
  const auto& box = bank.bounding_box;
  std::printf("file            %s (%ju bytes)\n", path.c_str(),
              static_cast<uintmax_t>(std::filesystem::file_size(path)));
  std::printf("format version  %u\n", g6d::kCacheFormatVersion);
  std::printf("object id       %s\n", bank.object_id.c_str());
  std::printf("mesh            %s (%s), hash %s\n", bank.mesh_path.c_str(),
              g6d::UnitsName(bank.mesh_units), g6d::HexString(bank.mesh_hash).c_str());
  std::printf("diameter        %.2f mm\n", bank.diameter_m * 1000.0);
  std::printf("bounding box    min (%.2f, %.2f, %.2f) max (%.2f, %.2f, %.2f) mm\n",
              box.min().x() * 1e3, box.min().y() * 1e3, box.min().z() * 1e3, box.max().x() * 1e3,
              box.max().y() * 1e3, box.max().z() * 1e3);
  std::printf("symmetries      %zu given; geometric: %s\n", bank.symmetries.size(),
              bank.geometric_symmetries.Describe().c_str());
  std::printf("appearance      %zu coloured samples%s\n", bank.appearance.points.size(),
              bank.appearance.Empty() ? " (none: no appearance tie-break)" : "");
  std::printf("online mesh     %zu vertices, %zu faces, %s\n", bank.online_mesh.vertices.size(),
              bank.online_mesh.faces.size(),
              g6d::IsClosedAndOriented(bank.online_mesh) ? "closed and oriented" : "open or inconsistently oriented");
  const g6d::Camera& c = bank.template_camera;
  std::printf("template camera %dx%d, fx %.1f fy %.1f cx %.1f cy %.1f\n", c.width, c.height, c.fx,
              c.fy, c.cx, c.cy);
  std::printf(
      "build options   views %d directions x %d in-plane, fill %.2f; render %d px, "
      "focal %.1f px\n",
      o.views.num_directions, o.views.num_inplane, o.views.fill_fraction, o.render_size_px,
      o.render_focal_px);
  std::printf(
      "                crop S %d, padding %.2f, background %d, mean %.0f std %.0f "
      "(min std %.1f)\n",
      o.crop.size_px, o.crop.padding, o.crop.background_gray, o.crop.normalized_mean,
      o.crop.normalized_std, o.crop.min_std);
  std::printf(
      "                ORB %d features, scale %.2f, %d levels, edge %d, FAST %d, "
      "erosion %d px\n",
      o.orb.max_features, o.orb.scale_factor, o.orb.num_levels, o.orb.edge_threshold,
      o.orb.fast_threshold, o.orb.mask_erosion_px);
  std::printf("                online faces %d, max view angle %.1f deg, thumbnail %d px\n",
              o.online_mesh_faces, o.max_view_angle_deg, o.thumbnail_size_px);
  std::printf("templates       %zu\n", bank.templates.size());
  if (!counts.empty()) {
    std::printf("keypoints       min %zu / median %zu / max %zu per template, total %zu\n",
                counts.front(), counts[counts.size() / 2], counts.back(), bank.NumKeypoints());
  }
}

cv::Scalar KeypointColor(size_t i) {
  // Hue cycling through well separated colours (BGR for OpenCV drawing).
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<double>((i * 37) % 180), 255, 255));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b v = bgr.at<cv::Vec3b>(0, 0);
  return cv::Scalar(v[0], v[1], v[2]);
}

// Which templates go on the sheet: evenly spread over the bank, or the ones with the
// fewest keypoints (to look at weak views).
std::vector<int> PickTemplates(const g6d::TemplateBank& bank, int max_cells, bool fewest) {
  const int num_templates = static_cast<int>(bank.templates.size());
  const int num_cells = std::min(num_templates, max_cells);
  std::vector<int> picked;
  if (fewest) {
    std::vector<int> order(static_cast<size_t>(num_templates));
    for (int j = 0; j < num_templates; ++j) order[static_cast<size_t>(j)] = j;
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return bank.templates[static_cast<size_t>(a)].keypoints.size() <
             bank.templates[static_cast<size_t>(b)].keypoints.size();
    });
    picked.assign(order.begin(), order.begin() + num_cells);
  } else {
    for (int cell = 0; cell < num_cells; ++cell) {
      picked.push_back(static_cast<int>(static_cast<int64_t>(cell) * num_templates / num_cells));
    }
  }
  return picked;
}

cv::Mat DrawSheet(const g6d::TemplateBank& bank, const std::vector<int>& picked, int cell_px) {
  const int num_cells = static_cast<int>(picked.size());
  if (num_cells == 0) return cv::Mat();
  const int columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(num_cells))));
  const int rows = (num_cells + columns - 1) / columns;
  cv::Mat sheet(rows * cell_px, columns * cell_px, CV_8UC3, cv::Scalar(40, 40, 40));
  const double crop_size = bank.options.crop.size_px;

  for (int cell = 0; cell < num_cells; ++cell) {
    const int j = picked[static_cast<size_t>(cell)];
    const g6d::Template& t = bank.templates[static_cast<size_t>(j)];
    cv::Mat view(
        sheet, cv::Rect((cell % columns) * cell_px, (cell / columns) * cell_px, cell_px, cell_px));
    if (!t.thumbnail.empty()) {
      cv::Mat gray, bgr;
      cv::resize(t.thumbnail, gray, cv::Size(cell_px, cell_px), 0, 0, cv::INTER_LINEAR);
      cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
      bgr.copyTo(view);
    }
    if (!t.mask.empty()) {
      cv::Mat mask;
      cv::resize(t.mask, mask, cv::Size(cell_px, cell_px), 0, 0, cv::INTER_AREA);
      std::vector<std::vector<cv::Point>> contours;
      cv::findContours(mask > 127, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
      cv::drawContours(view, contours, -1, cv::Scalar(0, 200, 0), 1, cv::LINE_AA);
    }
    // Template image px -> crop px (inverse affine) -> cell px (area-style resize).
    const double cell_per_crop = cell_px / crop_size;
    for (size_t i = 0; i < t.keypoints.size(); ++i) {
      const Eigen::Vector2d source = t.keypoints[i].cast<double>();
      const Eigen::Vector2d crop = (source - t.crop_offset) / t.crop_scale;
      const Eigen::Vector2d xy = (crop.array() + 0.5) * cell_per_crop - 0.5;
      // Sub-pixel drawing: 4 fractional bits.
      const cv::Point centre(static_cast<int>(std::lround(xy.x() * 16)),
                             static_cast<int>(std::lround(xy.y() * 16)));
      cv::circle(view, centre, 2 * 16, KeypointColor(i), 1, cv::LINE_AA, 4);
    }
    cv::putText(view, std::to_string(j), cv::Point(3, 12), cv::FONT_HERSHEY_PLAIN, 0.8,
                cv::Scalar(255, 255, 0), 1, cv::LINE_AA);
    cv::putText(view, std::to_string(t.keypoints.size()), cv::Point(3, cell_px - 4),
                cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(0, 200, 255), 1, cv::LINE_AA);
  }
  return sheet;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-inspect: summary and contact sheet of a G6D template cache"};
  std::string cache_path, sheet_path;
  int max_cells = 64;
  int cell_px = 128;
  bool fewest = false;
  app.add_option("cache", cache_path, "template cache file")->required();
  app.add_option("--sheet", sheet_path, "write a contact sheet PNG of the templates here");
  app.add_option("--max", max_cells, "templates on the contact sheet (evenly spread)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--cell", cell_px, "side of one contact sheet cell, pixels")
      ->capture_default_str()
      ->check(CLI::Range(16, 1024));
  app.add_flag(
      "--fewest", fewest,
      "put the templates with the fewest keypoints on the sheet instead of an even spread");
  CLI11_PARSE(app, argc, argv);

  try {
    const g6d::TemplateBank bank = g6d::ReadTemplateCache(cache_path);
    PrintSummary(bank, cache_path);
    if (!sheet_path.empty()) {
      const cv::Mat sheet = DrawSheet(bank, PickTemplates(bank, max_cells, fewest), cell_px);
      if (sheet.empty()) {
        std::fprintf(stderr, "g6d-inspect: error: the cache has no templates to draw\n");
        return 1;
      }
      if (!cv::imwrite(sheet_path, sheet)) {
        std::fprintf(stderr, "g6d-inspect: error: cannot write '%s'\n", sheet_path.c_str());
        return 1;
      }
      std::printf("contact sheet   %s (%d templates)\n", sheet_path.c_str(),
                  std::min(max_cells, static_cast<int>(bank.templates.size())));
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-inspect: error: %s\n", e.what());
    return 1;
  }
}
