#include "core/camera.h"

#include <cmath>
#include <sstream>

namespace g6d {

std::string Camera::Check() const {
  std::ostringstream out;
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(fx)) out << "fx must be finite and > 0 (got " << fx << ")";
  else if (!positive(fy)) out << "fy must be finite and > 0 (got " << fy << ")";
  else if (!std::isfinite(cx)) out << "cx must be finite (got " << cx << ")";
  else if (!std::isfinite(cy)) out << "cy must be finite (got " << cy << ")";
  else if (width <= 0 || width > (1 << 15)) out << "width must be in 1..32768 (got " << width << ")";
  else if (height <= 0 || height > (1 << 15)) out << "height must be in 1..32768 (got " << height << ")";
  return out.str();
}

Camera Camera::Cropped(int x0, int y0, int w, int h) const {
  Camera out = *this;
  out.cx -= x0;
  out.cy -= y0;
  out.width = w;
  out.height = h;
  return out;
}

Camera Camera::Scaled(double scale) const {
  Camera out = *this;
  out.fx *= scale;
  out.fy *= scale;
  out.cx *= scale;
  out.cy *= scale;
  out.width = static_cast<int>(std::lround(width * scale));
  out.height = static_cast<int>(std::lround(height * scale));
  return out;
}

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k;
  k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return k;
}

}  // namespace g6d
