#include "solver/observation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace g6d {

std::string GridOptions::Check() const {
  std::ostringstream out;
  if (!(margin >= 0.0 && margin <= 10.0)) out << "GridOptions.margin must be in [0, 10] (got " << margin << ")";
  else if (max_side_px < 8 || max_side_px > 4096) out << "GridOptions.max_side_px must be in [8, 4096] (got " << max_side_px << ")";
  else if (unseen_area_min_px < 0 || unseen_area_min_px > 255) out << "GridOptions.unseen_area_min_px must be in [0, 255] (got " << unseen_area_min_px << ")";
  return out.str();
}

cv::Mat UnseenAreaOutside(const cv::Mat& mask, const cv::Mat& depth, const cv::Rect& roi, int min_px) {
  G6D_CHECK(mask.type() == CV_8U && depth.type() == CV_32F && mask.size() == depth.size());
  G6D_CHECK((roi & cv::Rect(0, 0, mask.cols, mask.rows)) == roi && min_px >= 1);
  cv::Mat area(roi.size(), CV_8U);
  for (int v = 0; v < roi.height; ++v) {
    const uint8_t* m = mask.ptr<uint8_t>(roi.y + v) + roi.x;
    const float* d = depth.ptr<float>(roi.y + v) + roi.x;
    uint8_t* a = area.ptr<uint8_t>(v);
    for (int u = 0; u < roi.width; ++u) a[u] = !m[u] && !(d[u] > 0.0f && std::isfinite(d[u])) ? 255 : 0;
  }
  if (min_px > 1) {
    cv::morphologyEx(area, area, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(min_px, min_px)),
                     cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  }
  return area;
}

double MeanMaskedDepth(const cv::Mat& mask, const cv::Mat& depth, int* valid_pixels) {
  G6D_CHECK(mask.type() == CV_8U && depth.type() == CV_32F && mask.size() == depth.size());
  double sum = 0.0;
  int count = 0;
  for (int v = 0; v < mask.rows; ++v) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (m[u] && d[u] > 0.0f && std::isfinite(d[u])) {
        sum += d[u];
        ++count;
      }
    }
  }
  if (valid_pixels) *valid_pixels = count;
  return count > 0 ? sum / count : 0.0;
}

double MedianMaskedDepth(const cv::Mat& mask, const cv::Mat& depth, int* valid_pixels) {
  G6D_CHECK(mask.type() == CV_8U && depth.type() == CV_32F && mask.size() == depth.size());
  std::vector<float> values;
  for (int v = 0; v < mask.rows; ++v) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (m[u] && d[u] > 0.0f && std::isfinite(d[u])) values.push_back(d[u]);
    }
  }
  if (valid_pixels) *valid_pixels = static_cast<int>(values.size());
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

EvaluationGrid MakeEvaluationGrid(const Camera& camera, const cv::Mat& mask, const cv::Mat& depth,
                                  const GridOptions& options, const cv::Mat& support,
                                  const DepthSegmentation* segmentation, const cv::Mat& unsure) {
  G6D_CHECK(mask.type() == CV_8U && depth.type() == CV_32F);
  G6D_CHECK(support.empty() || (support.type() == CV_8U && support.size() == mask.size()));
  const cv::Mat segments = segmentation != nullptr ? segmentation->labels : cv::Mat();
  G6D_CHECK(segments.empty() || (segments.type() == CV_32S && segments.size() == mask.size()));
  G6D_CHECK(mask.cols == camera.width && mask.rows == camera.height && depth.size() == mask.size());
  EvaluationGrid grid;
  const cv::Rect box = cv::boundingRect(mask);
  if (box.area() == 0) {
    grid.camera = camera.Cropped(0, 0, 1, 1);
    grid.mask = cv::Mat::zeros(1, 1, CV_8U);
    grid.depth = cv::Mat::zeros(1, 1, CV_32F);
    return grid;
  }
  const int margin = static_cast<int>(std::ceil(options.margin * std::max(box.width, box.height)));
  const int x0 = std::max(0, box.x - margin);
  const int y0 = std::max(0, box.y - margin);
  const int x1 = std::min(camera.width, box.x + box.width + margin);
  const int y1 = std::min(camera.height, box.y + box.height + margin);
  const int roi_w = x1 - x0;
  const int roi_h = y1 - y0;
  const double scale = std::min(1.0, static_cast<double>(options.max_side_px) / std::max(roi_w, roi_h));
  Camera roi_camera = camera.Cropped(x0, y0, roi_w, roi_h);
  // Scale without rounding surprises: fix the grid size first, then the exact scale
  // factors per axis are what Camera::Scaled uses (uniform scale).
  grid.camera = roi_camera.Scaled(scale);
  grid.camera.width = std::max(1, grid.camera.width);
  grid.camera.height = std::max(1, grid.camera.height);
  grid.mask.create(grid.camera.height, grid.camera.width, CV_8U);
  grid.depth.create(grid.camera.height, grid.camera.width, CV_32F);
  if (!support.empty()) grid.support.create(grid.camera.height, grid.camera.width, CV_8U);
  G6D_CHECK(unsure.empty() || (unsure.type() == CV_8U && unsure.size() == mask.size()));
  if (!unsure.empty()) grid.unsure.create(grid.camera.height, grid.camera.width, CV_8U);
  // Depthless areas outside the mask at least unseen_area_min_px wide, on the ROI.
  cv::Mat unseen_area_roi, hole_near_roi, hole_far_roi;
  if (options.unseen_area_min_px > 0) {
    unseen_area_roi = UnseenAreaOutside(mask, depth, cv::Rect(x0, y0, roi_w, roi_h), options.unseen_area_min_px);
    grid.unseen_area.create(grid.camera.height, grid.camera.width, CV_8U);
  }
  if (options.unseen_area_min_px > 0 && options.fill_thin_holes) {
    // The valid depth around each pixel: nearest (min over valid) and farthest (max).
    const int side = options.unseen_area_min_px;
    cv::Mat near(roi_h, roi_w, CV_32F), far(roi_h, roi_w, CV_32F);
    for (int v = 0; v < roi_h; ++v) {
      const float* d = depth.ptr<float>(y0 + v) + x0;
      float* n = near.ptr<float>(v);
      float* f = far.ptr<float>(v);
      for (int u = 0; u < roi_w; ++u) {
        const bool valid = d[u] > 0.0f && std::isfinite(d[u]);
        n[u] = valid ? d[u] : std::numeric_limits<float>::max();
        f[u] = valid ? d[u] : 0.0f;
      }
    }
    const cv::Mat square = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(side, side));
    cv::erode(near, hole_near_roi, square, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
    cv::dilate(far, hole_far_roi, square, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
    grid.hole_near = cv::Mat::zeros(grid.camera.height, grid.camera.width, CV_32F);
    grid.hole_far = cv::Mat::zeros(grid.camera.height, grid.camera.width, CV_32F);
  }
  int background = 0, unseen = 0;
  for (int v = 0; v < grid.camera.height; ++v) {
    const int sv = std::min(y1 - 1, y0 + static_cast<int>((v + 0.5) / scale));
    const uint8_t* m = mask.ptr<uint8_t>(sv);
    const float* d = depth.ptr<float>(sv);
    uint8_t* gm = grid.mask.ptr<uint8_t>(v);
    float* gd = grid.depth.ptr<float>(v);
    const uint8_t* s = support.empty() ? nullptr : support.ptr<uint8_t>(sv);
    uint8_t* gs = support.empty() ? nullptr : grid.support.ptr<uint8_t>(v);
    for (int u = 0; u < grid.camera.width; ++u) {
      const int su = std::min(x1 - 1, x0 + static_cast<int>((u + 0.5) / scale));
      if (gs != nullptr) gs[u] = s[su] ? 255 : 0;
      if (!unsure.empty()) grid.unsure.at<uint8_t>(v, u) = unsure.at<uint8_t>(sv, su) ? 255 : 0;
      const uint8_t area = unseen_area_roi.empty() ? 0 : unseen_area_roi.at<uint8_t>(sv - y0, su - x0);
      if (!unseen_area_roi.empty()) grid.unseen_area.at<uint8_t>(v, u) = area;
      if (!hole_near_roi.empty()) {
        const float near = hole_near_roi.at<float>(sv - y0, su - x0);
        if (!m[su] && !area && !(d[su] > 0.0f && std::isfinite(d[su])) && near < std::numeric_limits<float>::max()) {
          grid.hole_near.at<float>(v, u) = near;
          grid.hole_far.at<float>(v, u) = hole_far_roi.at<float>(sv - y0, su - x0);
        }
      }
      gm[u] = m[su] ? 255 : 0;
      const float z = d[su];
      gd[u] = (z > 0.0f && std::isfinite(z)) ? z : 0.0f;
      grid.mask_pixels += gm[u] ? 1 : 0;
      background += gm[u] ? 0 : 1;
      unseen += !gm[u] && !(gd[u] > 0.0f) ? 1 : 0;
    }
  }
  grid.unseen_background = background > 0 ? static_cast<double>(unseen) / background : 0.0;
  if (!segments.empty()) {
    // The segments inside the mask on the grid; kept only when there are two or more.
    double max_label = 0.0;
    cv::minMaxLoc(segments, nullptr, &max_label, nullptr, nullptr, mask);
    grid.segment = cv::Mat::zeros(grid.mask.size(), CV_32S);
    grid.segment_pixels.assign(static_cast<size_t>(max_label) + 1, 0);
    int present = 0;
    for (int v = 0; v < grid.camera.height; ++v) {
      const int sv = std::min(y1 - 1, y0 + static_cast<int>((v + 0.5) / scale));
      const int* labels = segments.ptr<int>(sv);
      const uint8_t* gm = grid.mask.ptr<uint8_t>(v);
      int* gl = grid.segment.ptr<int>(v);
      for (int u = 0; u < grid.camera.width; ++u) {
        if (!gm[u]) continue;
        const int label = labels[std::min(x1 - 1, x0 + static_cast<int>((u + 0.5) / scale))];
        gl[u] = label;
        present += label > 0 && grid.segment_pixels[static_cast<size_t>(label)] == 0;
        ++grid.segment_pixels[static_cast<size_t>(label)];
      }
    }
    if (present < 2) {
      grid.segment.release();
      grid.segment_pixels.clear();
    } else {
      grid.segment_spans.resize(grid.segment_pixels.size());
      for (size_t k = 1; k < grid.segment_spans.size(); ++k) grid.segment_spans[k] = segmentation->segments[k - 1].spans;
    }
  }
  return grid;
}

}  // namespace g6d
