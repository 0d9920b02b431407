// Stream lines as the renderer draws them, and the two ways a user picks lines to show opaque
// (dissertation §7.3.2): a selection box, and a click on the image.
#include <algorithm>
#include <cmath>
#include <limits>

#include "camera_math.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

LineSet line_set_from(const lod::Streamlines& lines, const std::string& field) {
  LineSet out;
  out.field = field;
  const size_t n = lines.point_count();
  out.xyz.resize(3 * n);
  out.flow.resize(3 * n);
  out.value.resize(n);
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (size_t i = 0; i < n; ++i) {
    const float p[3] = {lines.x[i], lines.y[i], lines.z[i]};
    for (int k = 0; k < 3; ++k) {
      out.xyz[3 * i + k] = p[k];
      lo[k] = std::min(lo[k], double(p[k]));
      hi[k] = std::max(hi[k], double(p[k]));
    }
    out.flow[3 * i] = lines.vx[i];
    out.flow[3 * i + 1] = lines.vy[i];
    out.flow[3 * i + 2] = lines.vz[i];
    out.value[i] = std::sqrt(lines.vx[i] * lines.vx[i] + lines.vy[i] * lines.vy[i] + lines.vz[i] * lines.vz[i]);
  }
  out.line_first = lines.line_first;
  if (n) {
    const auto [mn, mx] = std::minmax_element(out.value.begin(), out.value.end());
    out.value_min = *mn;
    out.value_max = *mx > *mn ? double(*mx) : *mn + 1.0;
    out.diagonal = std::max(1e-30, std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2])));
  }
  return out;
}

namespace {

// Does the segment a-b meet the box [lo, hi]? (slab clipping)
bool segment_meets_box(const double* a, const double* b, const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  double t0 = 0, t1 = 1;
  for (int k = 0; k < 3; ++k) {
    const double d = b[k] - a[k];
    if (std::abs(d) < 1e-300) {
      if (a[k] < lo[k] || a[k] > hi[k]) return false;
      continue;
    }
    double s0 = (lo[k] - a[k]) / d, s1 = (hi[k] - a[k]) / d;
    if (s0 > s1) std::swap(s0, s1);
    t0 = std::max(t0, s0);
    t1 = std::min(t1, s1);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

std::vector<uint32_t> lines_in_box(const LineSet& lines, const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  std::vector<uint32_t> out;
  for (uint32_t l = 0; l < lines.line_count(); ++l) {
    const uint32_t first = lines.line_first[l], end = lines.line_first[l + 1];
    bool hit = false;
    for (uint32_t i = first; i < end && !hit; ++i) {
      const double a[3] = {lines.xyz[3 * i], lines.xyz[3 * i + 1], lines.xyz[3 * i + 2]};
      const double* b = a;
      double next[3];
      if (i + 1 < end) {
        for (int k = 0; k < 3; ++k) next[k] = lines.xyz[3 * (i + 1) + k];
        b = next;
      }
      hit = segment_meets_box(a, b, lo, hi);
    }
    if (hit) out.push_back(l);
  }
  return out;
}

std::vector<uint32_t> line_at_pixel(const LineSet& lines, const view::Camera& camera, uint32_t width, uint32_t height, double x, double y, double max_pixels) {
  const Frame frame = camera_frame(camera, width, height);
  double best = max_pixels * max_pixels;
  double best_depth = std::numeric_limits<double>::max();
  uint32_t best_line = std::numeric_limits<uint32_t>::max();
  // pixel centres are at integers in `project`; a click at (x, y) is at pixel (x - 0.5, y - 0.5)
  const double cx = x - 0.5, cy = y - 0.5;
  for (uint32_t l = 0; l < lines.line_count(); ++l) {
    double pa[2] = {0, 0}, pb[2] = {0, 0};
    bool have_a = false;
    double depth_a = 0;
    for (uint32_t i = lines.line_first[l]; i < lines.line_first[l + 1]; ++i) {
      const Vec3 p{lines.xyz[3 * i], lines.xyz[3 * i + 1], lines.xyz[3 * i + 2]};
      const bool visible = project(frame, p, &pb[0], &pb[1]);
      const double depth_b = dot(p - frame.eye, frame.forward);
      if (visible && have_a) {
        const double dx = pb[0] - pa[0], dy = pb[1] - pa[1];
        const double len2 = dx * dx + dy * dy;
        const double t = len2 > 0 ? std::clamp(((cx - pa[0]) * dx + (cy - pa[1]) * dy) / len2, 0.0, 1.0) : 0.0;
        const double ex = pa[0] + t * dx - cx, ey = pa[1] + t * dy - cy;
        const double d2 = ex * ex + ey * ey;
        const double depth = depth_a + t * (depth_b - depth_a);
        // the nearest on screen; among lines equally near (within a pixel), the front one
        if (d2 < best - 1 || (d2 <= best + 1 && depth < best_depth && d2 <= max_pixels * max_pixels)) {
          best = std::min(best, d2);
          best_depth = depth;
          best_line = l;
        }
      }
      have_a = visible;
      pa[0] = pb[0];
      pa[1] = pb[1];
      depth_a = depth_b;
    }
  }
  if (best_line == std::numeric_limits<uint32_t>::max()) return {};
  return {best_line};
}

}  // namespace tetrascope::renderer
