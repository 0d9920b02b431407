// Camera geometry shared by the GL renderer and the CPU reference: the same pixel centres,
// rays and projection, so that the two agree pixel for pixel.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "tetrascope/view/camera.h"
#include "tetrascope/view/transfer_function.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

// The camera's frame (view/camera.h): basis, projection, rays through pixel centres.
using Frame = view::ViewFrame;
inline Frame camera_frame(const view::Camera& c, uint32_t width, uint32_t height) { return view::ViewFrame::of(c, width, height); }
inline void ray(const Frame& f, int x, int y, Vec3* origin, Vec3* direction) { f.ray(x, y, origin, direction); }
inline bool project(const Frame& f, const Vec3& p, double* px, double* py) { return f.project(p, px, py); }

// The pixels the projection of `corners` may cover: their pixel box grown by one pixel and
// kept inside the image; the whole image when a corner is behind the eye, and none when
// every corner is (no ray reaches behind the eye).
struct PixelBox {
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;  // inclusive
};
inline PixelBox pixel_box(const Frame& f, std::span<const Vec3> corners) {
  double x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
  size_t behind = 0;
  for (const Vec3& q : corners) {
    double px, py;
    if (!project(f, q, &px, &py)) ++behind;
    x0 = std::min(x0, px);
    x1 = std::max(x1, px);
    y0 = std::min(y0, py);
    y1 = std::max(y1, py);
  }
  if (behind == corners.size()) return {};
  PixelBox box{0, static_cast<int>(f.width) - 1, 0, static_cast<int>(f.height) - 1};
  if (behind == 0) {
    box.x0 = std::max(box.x0, static_cast<int>(std::floor(x0)) - 1);
    box.x1 = std::min(box.x1, static_cast<int>(std::ceil(x1)) + 1);
    box.y0 = std::max(box.y0, static_cast<int>(std::floor(y0)) - 1);
    box.y1 = std::min(box.y1, static_cast<int>(std::ceil(y1)) + 1);
  }
  return box;
}

// Column-major 4x4 matrices for GL.
inline std::array<float, 16> view_projection(const Frame& f, double near_plane, double far_plane) {
  // view: rows right, up, -forward
  double view[16] = {f.right[0], f.up[0], -f.forward[0], 0, f.right[1], f.up[1], -f.forward[1], 0, f.right[2], f.up[2], -f.forward[2], 0,
                     -dot(f.right, f.eye), -dot(f.up, f.eye), dot(f.forward, f.eye), 1};
  double proj[16] = {};
  if (f.ortho) {
    const double h = f.half_height, w = h * f.aspect;
    proj[0] = 1 / w;
    proj[5] = 1 / h;
    proj[10] = -2 / (far_plane - near_plane);
    proj[14] = -(far_plane + near_plane) / (far_plane - near_plane);
    proj[15] = 1;
  } else {
    proj[0] = 1 / (f.tan_half * f.aspect);
    proj[5] = 1 / f.tan_half;
    proj[10] = -(far_plane + near_plane) / (far_plane - near_plane);
    proj[11] = -1;
    proj[14] = -2 * far_plane * near_plane / (far_plane - near_plane);
  }
  std::array<float, 16> out{};
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += proj[k * 4 + r] * view[c * 4 + k];
      out[c * 4 + r] = static_cast<float>(s);
    }
  return out;
}

}  // namespace tetrascope::renderer
