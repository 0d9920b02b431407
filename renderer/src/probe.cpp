// The probe: one ray against the slice, isosurface and boundary triangles of a scene
// (Möller-Trumbore), the nearest hit wins; values interpolated barycentrically.
#include "tetrascope/renderer/probe.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "camera_math.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/core/vec3.h"

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
  for (const view::Plane& plane : settings.slices.planes) slice_scene(scene, plane, slices, nullptr);
  test_triangles(slices, "slice");
  if (settings.iso)
    for (double iso : settings.isovalues) {
      const std::vector<float> xyz = marching_tets(scene, iso);
      std::vector<float> tris;
      for (size_t i = 0; i + 3 <= xyz.size(); i += 3) tris.insert(tris.end(), {xyz[i], xyz[i + 1], xyz[i + 2], static_cast<float>(iso)});
      test_triangles(tris, "isosurface");
    }
  // the boundary is a surface the eye sees only in surface mode: otherwise (the volume) a
  // slice or isosurface inside it is what the click means
  if (!best.surface.empty() && !settings.surface) return best;
  const bool iso_color = scene.iso_color_value.size() == scene.value.size() && !scene.iso_color_attribute.empty();
  // the regions the surface leaves out (the volume's boundary stays whole)
  const std::vector<uint8_t> hidden = settings.surface ? hidden_faces(scene, settings.hidden_regions) : std::vector<uint8_t>{};
  for (size_t i = 0; i < scene.boundary.size(); ++i) {
    if (!hidden.empty() && hidden[i]) continue;
    const auto& f = scene.boundary[i];
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

std::vector<PointValue> values_at(const SceneMesh& scene, const std::array<double, 3>& position) {
  std::vector<PointValue> out;
  if (scene.attributes.empty()) return out;
  const Vec3 p{position[0], position[1], position[2]};
  const double slack = 1e-6 * scene.diagonal;  // positions are floats
  double best = -std::numeric_limits<double>::infinity();
  std::array<double, 4> weights{};
  const uint32_t* held = nullptr;
  for (size_t t = 0; t < scene.tets.size() / 4 && best < 0; ++t) {
    const uint32_t* tet = &scene.tets[4 * t];
    Vec3 v[4];
    bool near = true;
    for (int k = 0; k < 4; ++k) v[k] = {scene.xyz[3 * size_t{tet[k]}], scene.xyz[3 * size_t{tet[k]} + 1], scene.xyz[3 * size_t{tet[k]} + 2]};
    for (int a = 0; a < 3 && near; ++a) {
      const double lo = std::min({v[0][a], v[1][a], v[2][a], v[3][a]}), hi = std::max({v[0][a], v[1][a], v[2][a], v[3][a]});
      near = p[a] >= lo - slack && p[a] <= hi + slack;
    }
    if (!near) continue;
    const Vec3 e1 = v[1] - v[0], e2 = v[2] - v[0], e3 = v[3] - v[0], q = p - v[0];
    const double det = dot(e1, cross(e2, e3));
    if (!(std::fabs(det) > 0)) continue;
    const double w1 = dot(q, cross(e2, e3)) / det, w2 = dot(e1, cross(q, e3)) / det, w3 = dot(e1, cross(e2, q)) / det;
    const std::array<double, 4> w{1 - w1 - w2 - w3, w1, w2, w3};
    const double least = std::min({w[0], w[1], w[2], w[3]});
    if (least > best) {
      best = least;
      weights = w;
      held = tet;
    }
  }
  if (!held || best < -1e-4) return out;
  double sum = 0;  // a boundary point a rounding outside: onto the tet
  for (double& w : weights) sum += (w = std::max(w, 0.0));
  for (double& w : weights) w /= sum;
  for (const storage::Attribute& a : scene.attributes) {
    const uint32_t c = a.info.components;
    if (c == 0 || a.values.size() < (scene.xyz.size() / 3) * c) continue;
    PointValue value{a.info.name, std::vector<double>(c, 0.0), 0};
    for (int k = 0; k < 4; ++k)
      for (uint32_t i = 0; i < c; ++i) value.components[i] += weights[k] * a.values[size_t{held[k]} * c + i];
    if (c > 1) {
      double m = 0;
      for (double x : value.components) m += x * x;
      value.magnitude = std::sqrt(m);
    }
    out.push_back(std::move(value));
  }
  return out;
}

}  // namespace tetrascope::renderer
