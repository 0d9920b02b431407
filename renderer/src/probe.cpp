// The probe: one ray against the slice, isosurface and boundary triangles of a scene
// (Möller-Trumbore), the nearest hit wins; values interpolated barycentrically.
#include "tetrascope/renderer/probe.h"

#include <cmath>
#include <limits>

#include "camera_math.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/storage/vec3.h"

namespace tetrascope::renderer {
namespace {

struct Ray {
  Vec3 origin, direction;
};

// distance along the ray and barycentric (u, v) of the hit, or nothing
std::optional<std::array<double, 3>> intersect(const Ray& r, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = cross(r.direction, e2);
  const double det = dot(e1, p);
  if (std::fabs(det) < 1e-300) return std::nullopt;
  const Vec3 t = r.origin - a;
  const double u = dot(t, p) / det;
  if (u < 0 || u > 1) return std::nullopt;
  const Vec3 q = cross(t, e1);
  const double v = dot(r.direction, q) / det;
  if (v < 0 || u + v > 1) return std::nullopt;
  const double distance = dot(e2, q) / det;
  if (!(distance > 0)) return std::nullopt;
  return std::array<double, 3>{distance, u, v};
}

}  // namespace

ProbeHit probe(const SceneMesh& scene, const RenderSettings& settings, double x, double y) {
  ProbeHit best;
  if (!(x >= 0 && y >= 0 && x < settings.width && y < settings.height)) return best;
  Frame frame = camera_frame(settings.camera, settings.width, settings.height);
  Ray r;
  {  // the ray through (x, y): ray() takes pixel centres at integer + 0.5
    const double u = 2 * x / frame.width - 1, v = 1 - 2 * y / frame.height;
    if (frame.ortho) {
      for (int k = 0; k < 3; ++k) r.origin[k] = frame.eye[k] + u * frame.half_height * frame.aspect * frame.right[k] + v * frame.half_height * frame.up[k];
      r.direction = frame.forward;
    } else {
      r.origin = frame.eye;
      Vec3 d;
      for (int k = 0; k < 3; ++k) d[k] = frame.forward[k] + u * frame.tan_half * frame.aspect * frame.right[k] + v * frame.tan_half * frame.up[k];
      r.direction = normalise(d);
    }
  }
  double nearest = std::numeric_limits<double>::infinity();
  // (x, y, z, value) triangles: slices, isosurfaces
  auto test_triangles = [&](const std::vector<float>& tris, const char* surface) {
    for (size_t i = 0; i + 12 <= tris.size(); i += 12) {
      const Vec3 a{tris[i], tris[i + 1], tris[i + 2]}, b{tris[i + 4], tris[i + 5], tris[i + 6]}, c{tris[i + 8], tris[i + 9], tris[i + 10]};
      const auto hit = intersect(r, a, b, c);
      if (!hit || (*hit)[0] >= nearest) continue;
      nearest = (*hit)[0];
      const double u = (*hit)[1], v = (*hit)[2];
      best.surface = surface;
      best.distance = nearest;
      for (int k = 0; k < 3; ++k) best.position[k] = r.origin[k] + nearest * r.direction[k];
      best.value = (1 - u - v) * tris[i + 3] + u * tris[i + 7] + v * tris[i + 11];
      best.iso_color_value.reset();
    }
  };
  std::vector<float> slices;
  for (const protocol::Plane& plane : settings.slices.planes) slice_scene(scene, plane, slices, nullptr);
  test_triangles(slices, "slice");
  if (settings.iso)
    for (double iso : settings.isovalues) {
      const std::vector<float> xyz = marching_tets(scene, iso);
      std::vector<float> tris;
      for (size_t i = 0; i + 3 <= xyz.size(); i += 3) tris.insert(tris.end(), {xyz[i], xyz[i + 1], xyz[i + 2], static_cast<float>(iso)});
      test_triangles(tris, "isosurface");
    }
  const bool iso_color = scene.iso_color_value.size() == scene.value.size() && !scene.iso_color_attribute.empty();
  for (const auto& f : scene.boundary) {
    Vec3 p[3];
    for (int c = 0; c < 3; ++c) p[c] = {scene.xyz[3 * size_t{f[c]}], scene.xyz[3 * size_t{f[c]} + 1], scene.xyz[3 * size_t{f[c]} + 2]};
    const auto hit = intersect(r, p[0], p[1], p[2]);
    if (!hit || (*hit)[0] >= nearest) continue;
    nearest = (*hit)[0];
    const double u = (*hit)[1], v = (*hit)[2];
    best.surface = "boundary";
    best.distance = nearest;
    for (int k = 0; k < 3; ++k) best.position[k] = r.origin[k] + nearest * r.direction[k];
    best.value = (1 - u - v) * scene.value[f[0]] + u * scene.value[f[1]] + v * scene.value[f[2]];
    if (iso_color) best.iso_color_value = (1 - u - v) * scene.iso_color_value[f[0]] + u * scene.iso_color_value[f[1]] + v * scene.iso_color_value[f[2]];
    else best.iso_color_value.reset();
  }
  return best;
}

}  // namespace tetrascope::renderer
