#pragma once
/// @file frame.h
/// Frame: one RGB-D image pair with its intrinsics, as the solver sees it. It lives in core
/// (not solver) so the wire layer can decode into it without depending on solver internals.

#include <opencv2/core.hpp>

#include "core/camera.h"

namespace g6d {

/// One RGB-D frame as the solver sees it.
struct Frame {
  Camera camera;  ///< intrinsics and image size
  cv::Mat rgb;    ///< CV_8UC3, RGB order
  cv::Mat depth;  ///< CV_32F, metres along the optical axis; 0 (or NaN) = no measurement
};

}  // namespace g6d
