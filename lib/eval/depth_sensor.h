#pragma once
/// @file depth_sensor.h
/// A structured-light depth sensor (Kinect v1, Asus Xtion) simulated on exact depth, to
/// measure the solver on depth as a real sensor gives it where a dataset has only rendered
/// depth (LM-O here: its depth is rendered from the ground truth, and flatters every stage
/// that reads depth). What the simulation does, in this order, all from the exact depth:
///
///  1. projector shadows: the projector sits `baseline_m` to the camera's +x; a point the
///     projector cannot see (a closer surface crosses its ray) has no depth: a band left of
///     every object, as wide as the disparity step between it and what is behind;
///  2. grazing surfaces: no depth where the surface normal turns more than
///     `max_incidence_deg` from the viewing ray (the pattern is too stretched to match);
///  3. depth steps: a pixel next to a step larger than max(`edge_step_m`, `edge_relative` ·
///     z) loses its depth with probability `edge_drop`, else becomes a flying pixel (its
///     depth drawn between its own and the far side's);
///  4. noise and quantisation in disparity d = fx · baseline / z: Gaussian noise of
///     `noise_at_1m_m` · fx · baseline (so sigma_z = noise_at_1m_m · z², in metres), then
///     rounded to steps of `disparity_step_px`;
///  5. dark and shining surfaces (read from the colour image, when given): where its grey
///     value is below `dark_grey` a pixel loses its depth with probability `dark_drop`, at
///     or above `bright_grey` (a highlight on metal) with `bright_drop`, in blobs (a random
///     field of `blob_px` cells, so holes are areas as on a real sensor, not speckle);
///  6. speckle: each pixel loses its depth with probability `dropout`.
///
/// The drop rates are those of synth_dev's structured-light model, measured against its
/// exact depth by grey level away from depth steps (bench/RESULTS.md, "Depth as a sensor
/// gives it"). The simulation knows no material beyond grey levels and does not blur: a
/// floor for what a real sensor does, not a model of one make. Every random choice comes
/// from a std::mt19937_64 seeded by `seed` and a per-frame key: runs are repeatable.

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "core/camera.h"

namespace g6d {

/// What SimulateDepthSensor() does (the defaults: an Asus Xtion / Kinect v1 at VGA).
struct DepthSensorModel {
  bool shadows = true;               ///< 1. off: the projector sees everything
  double baseline_m = 0.075;         ///< projector to camera along +x, metres (> 0)
  double disparity_step_px = 0.125;  ///< disparity quantisation, pixels (> 0)
  double noise_at_1m_m = 0.0015;     ///< depth noise sigma at 1 m, metres; grows with z² (>= 0)
  double max_incidence_deg = 78.0;   ///< no depth beyond this angle of surface to ray, (0, 90]
  bool edges = true;                 ///< 3. off: pixels at depth steps keep their depth
  double edge_step_m = 0.02;         ///< a depth step at least this large, metres ...
  double edge_relative = 0.04;       ///< ... and this fraction of z, marks an edge pixel
  double edge_drop = 0.5;            ///< an edge pixel loses its depth with this probability, else flies
  int dark_grey = 64;                ///< grey values below this are dark ...
  double dark_drop = 0.3;            ///< ... and lose their depth with this probability
  int bright_grey = 208;             ///< grey values at or above this shine ...
  double bright_drop = 0.55;         ///< ... and lose their depth with this probability
  int blob_px = 4;                   ///< the dropout field's cell, pixels (>= 1)
  double dropout = 0.003;            ///< any pixel loses its depth with this probability
  uint64_t seed = 1;

  /// Empty when valid, else a message naming the bad field and its value.
  std::string Check() const;
};

/// `model` with the effects named in `names` (comma separated: shadows, grazing, edges,
/// noise, dark, bright, speckle) switched off, for ablations. Throws g6d::Error naming an
/// unknown name and the valid ones.
DepthSensorModel WithoutSensorEffects(DepthSensorModel model, const std::string& names);

/// The names SimulateDepthSensor's callers accept: "none" (the depth as it is) and
/// "structured-light" (DepthSensorModel's defaults). Throws g6d::Error naming `name` and
/// the valid names otherwise; returns false for "none".
bool ParseDepthSensorName(const std::string& name);

/// `depth_m` (CV_32F metres, 0 = no depth, as LoadBopDepth gives it) as the sensor `model`
/// would measure it with `camera` (fx for the disparity; depth_m must be camera-sized).
/// `rgb` (CV_8UC3 of the same size, any channel order) gives the dark and shining
/// surfaces; empty: none. `frame_key` (e.g. MaskInstanceKey(scene, im, -1)) varies the
/// random choices per frame. Throws g6d::Error when model.Check() fails, depth_m is not a
/// CV_32F image of the camera's size, or rgb is neither empty nor CV_8UC3 of that size.
cv::Mat SimulateDepthSensor(const cv::Mat& depth_m, const cv::Mat& rgb, const Camera& camera,
                            const DepthSensorModel& model, uint64_t frame_key);

}  // namespace g6d
