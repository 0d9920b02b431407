// Slices: the cross-section of every tet with a plane is a triangle or a quad, found as
// marching tetrahedra finds an isosurface (Doi, Koide 1991), with the signed distance to the
// plane as the field and the attribute interpolated on the cut edges. A vertex on the plane
// counts as above it, so a face lying in the plane is emitted by the one tet below it.
#include <algorithm>
#include <array>
#include <limits>
#include <cmath>

#include "camera_math.h"
#include "slice_hits.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

void slice_scene(const SceneMesh& scene, const view::Plane& plane, std::vector<float>& triangles, std::vector<float>* edges) {
  const size_t vertex_count = scene.xyz.size() / 3;
  std::vector<double> side(vertex_count);
  for (size_t v = 0; v < vertex_count; ++v) side[v] = plane.side(scene.xyz[3 * v], scene.xyz[3 * v + 1], scene.xyz[3 * v + 2]);
  auto point = [&](uint32_t a, uint32_t b) {
    const double u = side[b] != side[a] ? std::clamp(side[a] / (side[a] - side[b]), 0.0, 1.0) : 0.5;
    std::array<float, 4> p{};
    for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(scene.xyz[3 * size_t{a} + k] + u * (double(scene.xyz[3 * size_t{b} + k]) - scene.xyz[3 * size_t{a} + k]));
    p[3] = static_cast<float>(scene.value[a] + u * (double(scene.value[b]) - scene.value[a]));
    return p;
  };
  auto put = [](std::vector<float>& out, const std::array<float, 4>& p, bool line) {
    out.insert(out.end(), p.begin(), p.begin() + 3);
    out.push_back(line ? 0.0f : p[3]);
  };
  for (size_t t = 0; t < scene.tets.size() / 4; ++t) {
    const uint32_t* tet = &scene.tets[4 * t];
    uint32_t above[4], below[4];
    int na = 0, nb = 0;
    for (int k = 0; k < 4; ++k) (side[tet[k]] >= 0 ? above[na++] : below[nb++]) = tet[k];
    if (na == 0 || nb == 0) continue;
    std::array<std::array<float, 4>, 4> poly;
    int corners = 3;
    if (na == 1) {
      for (int k = 0; k < 3; ++k) poly[k] = point(below[k], above[0]);
    } else if (nb == 1) {
      for (int k = 0; k < 3; ++k) poly[k] = point(below[0], above[k]);
    } else {  // a quad, in cyclic order
      poly = {point(below[0], above[0]), point(below[0], above[1]), point(below[1], above[1]), point(below[1], above[0])};
      corners = 4;
    }
    for (int k : {0, 1, 2}) put(triangles, poly[k], false);
    if (corners == 4)
      for (int k : {0, 2, 3}) put(triangles, poly[k], false);
    if (edges)
      for (int k = 0; k < corners; ++k) {
        put(*edges, poly[k], true);
        put(*edges, poly[(k + 1) % corners], true);
      }
  }
}

double triangles_area(std::span<const float> triangles) {
  double area = 0;
  for (size_t i = 0; i + 12 <= triangles.size(); i += 12) {
    const float* a = &triangles[i];
    const double e1[3] = {double(a[4]) - a[0], double(a[5]) - a[1], double(a[6]) - a[2]};
    const double e2[3] = {double(a[8]) - a[0], double(a[9]) - a[1], double(a[10]) - a[2]};
    area += 0.5 * std::hypot(e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]);
  }
  return area;
}

SliceHits slice_hits(const SceneMesh& scene, const RenderSettings& settings, double lo, double hi) {
  const uint32_t W = settings.width, H = settings.height;
  SliceHits hits;
  hits.distance.assign(size_t{W} * H, std::numeric_limits<float>::infinity());
  hits.rgb.assign(size_t{W} * H, {0, 0, 0});
  std::vector<float> triangles;
  for (const view::Plane& plane : settings.slices.planes) slice_scene(scene, plane, triangles, nullptr);
  if (triangles.empty()) return hits;
  const Frame frame = camera_frame(settings.camera, W, H);
  for (size_t i = 0; i + 12 <= triangles.size(); i += 12) {
    Vec3 p[3];
    double value[3];
    for (int c = 0; c < 3; ++c) {
      p[c] = {triangles[i + 4 * c], triangles[i + 4 * c + 1], triangles[i + 4 * c + 2]};
      value[c] = triangles[i + 4 * c + 3];
    }
    const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
    const Vec3 normal = normalise(cross(e1, e2));
    const PixelBox box = pixel_box(frame, p);
    for (int y = box.y0; y <= box.y1; ++y)
      for (int x = box.x0; x <= box.x1; ++x) {
        Vec3 o, dir;
        ray(frame, x, y, &o, &dir);
        // Moller-Trumbore
        const Vec3 pv = cross(dir, e2);
        const double det = dot(e1, pv);
        if (std::fabs(det) < 1e-300) continue;
        const Vec3 tv = o - p[0];
        const double u = dot(tv, pv) / det;
        if (u < 0 || u > 1) continue;
        const Vec3 qv = cross(tv, e1);
        const double v = dot(dir, qv) / det;
        if (v < 0 || u + v > 1) continue;
        const double t = dot(e2, qv) / det;
        const size_t at = size_t{static_cast<uint32_t>(y)} * W + static_cast<uint32_t>(x);
        if (!(t > 0) || t >= hits.distance[at]) continue;
        hits.distance[at] = static_cast<float>(t);
        const double s = std::clamp(((1 - u - v) * value[0] + u * value[1] + v * value[2] - lo) / (hi - lo), 0.0, 1.0);
        const auto base = settings.tf.colors.empty() ? colormap(settings.tf.colormap, s) : settings.tf.user_color(lo + s * (hi - lo));
        const double light = settings.slices.lit ? 0.25 + 0.75 * std::fabs(dot(normal, dir)) : 1.0;
        for (int k = 0; k < 3; ++k) hits.rgb[at][k] = static_cast<float>(base[k] * light);
      }
  }
  return hits;
}

}  // namespace tetrascope::renderer
