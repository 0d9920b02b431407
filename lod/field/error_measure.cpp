// Field and domain error between two tet meshes over the same domain (dissertation §4.2.5):
// the mean field error Ẽ_M^f (RMS over the original vertices, points outside the simplified
// mesh projected to its boundary), the largest field error, and the symmetric Hausdorff and
// mean distance between the two boundary surfaces, sampled.
#include "tetrascope/lod/field/error_measure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "box_grid.h"
#include "tet_locator.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::lod {
namespace {

using detail::BoxGrid;

Vec3 vertex(const storage::TetMesh& m, uint32_t v) { return {m.x[v], m.y[v], m.z[v]}; }

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5); returns
// barycentric weights in w.
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double w[3]) {
  Vec3 ab = b - a, ac = c - a, ap = p - a;
  double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) { w[0] = 1; w[1] = w[2] = 0; return a; }
  Vec3 bp = p - b;
  double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) { w[1] = 1; w[0] = w[2] = 0; return b; }
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    double v = d1 / (d1 - d3);
    w[0] = 1 - v; w[1] = v; w[2] = 0;
    return {a[0] + v * ab[0], a[1] + v * ab[1], a[2] + v * ab[2]};
  }
  Vec3 cp = p - c;
  double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) { w[2] = 1; w[0] = w[1] = 0; return c; }
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    double v = d2 / (d2 - d6);
    w[0] = 1 - v; w[1] = 0; w[2] = v;
    return {a[0] + v * ac[0], a[1] + v * ac[1], a[2] + v * ac[2]};
  }
  double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    double v = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    w[0] = 0; w[1] = 1 - v; w[2] = v;
    return {b[0] + v * (c[0] - b[0]), b[1] + v * (c[1] - b[1]), b[2] + v * (c[2] - b[2])};
  }
  double denom = 1 / (va + vb + vc), v = vb * denom, u = vc * denom;
  w[0] = 1 - v - u; w[1] = v; w[2] = u;
  return {a[0] + ab[0] * v + ac[0] * u, a[1] + ab[1] * v + ac[1] * u, a[2] + ab[2] * v + ac[2] * u};
}

// Nearest points on a triangle surface.
class Surface {
 public:
  Surface(const storage::TetMesh& m) : m_(m), triangles_(boundary_faces_by_key(m.tets)) {
    std::vector<std::array<Vec3, 2>> boxes;
    for (const auto& t : triangles_) {
      Vec3 lo = vertex(m, t[0]), hi = lo;
      for (int i = 1; i < 3; ++i) {
        Vec3 p = vertex(m, t[i]);
        for (int k = 0; k < 3; ++k) {
          lo[k] = std::min(lo[k], p[k]);
          hi[k] = std::max(hi[k], p[k]);
        }
      }
      boxes.push_back({lo, hi});
    }
    if (!boxes.empty()) grid_.build(boxes);
  }
  const std::vector<std::array<uint32_t, 3>>& triangles() const { return triangles_; }
  // Distance to the surface; the nearest triangle and barycentric weights.
  double nearest(const Vec3& p, uint32_t* triangle, double w[3]) const {
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0;; ++r) {
      bool inside = grid_.ring(p, r, [&](uint32_t i) {
        const auto& t = triangles_[i];
        double weights[3];
        Vec3 c = closest_on_triangle(p, vertex(m_, t[0]), vertex(m_, t[1]), vertex(m_, t[2]), weights);
        Vec3 d = c - p;
        double dist = std::sqrt(dot(d, d));
        if (dist < best) {
          best = dist;
          *triangle = i;
          std::copy(weights, weights + 3, w);
        }
      });
      // every unvisited item is at least r * cell away
      if (best <= r * grid_.cell() || (!inside && r > 0 && std::isfinite(best))) break;
      if (!inside && r > 1000000) break;
    }
    return best;
  }

 private:
  const storage::TetMesh& m_;
  std::vector<std::array<uint32_t, 3>> triangles_;
  BoxGrid grid_;
};

struct Normaliser {  // per attribute channel: scalars to [0, 1], vectors by the longest, 0.5 v + 0.5
  std::vector<double> offset, scale;
  std::vector<bool> vector;
};

// Distances from sample points of one boundary surface to another.
struct SurfaceDistance {
  double hausdorff = 0, sum = 0;
  uint64_t samples = 0;
};

// `samples` area-weighted random points of `from` (a surface of from_mesh) plus its vertices,
// measured to `to`.
void sample_surface_distance(const storage::TetMesh& from_mesh, const Surface& from, const Surface& to, uint32_t samples, std::mt19937& rng,
                             SurfaceDistance& out) {
  const auto& tris = from.triangles();
  if (tris.empty()) return;
  std::vector<double> area(tris.size());
  double total = 0;
  for (size_t i = 0; i < tris.size(); ++i) {
    Vec3 n = cross(vertex(from_mesh, tris[i][1]) - vertex(from_mesh, tris[i][0]), vertex(from_mesh, tris[i][2]) - vertex(from_mesh, tris[i][0]));
    total += std::sqrt(dot(n, n));
    area[i] = total;
  }
  std::uniform_real_distribution<double> unit(0, 1);
  auto measure = [&](const Vec3& p) {
    uint32_t tri;
    double w[3];
    double d = to.nearest(p, &tri, w);
    out.hausdorff = std::max(out.hausdorff, d);
    out.sum += d;
    ++out.samples;
  };
  for (uint32_t s = 0; s < samples; ++s) {
    size_t i = std::lower_bound(area.begin(), area.end(), unit(rng) * total) - area.begin();
    i = std::min(i, tris.size() - 1);
    double u = unit(rng), v = unit(rng);
    if (u + v > 1) { u = 1 - u; v = 1 - v; }
    Vec3 a = vertex(from_mesh, tris[i][0]), b = vertex(from_mesh, tris[i][1]), c = vertex(from_mesh, tris[i][2]);
    measure({a[0] + u * (b[0] - a[0]) + v * (c[0] - a[0]), a[1] + u * (b[1] - a[1]) + v * (c[1] - a[1]), a[2] + u * (b[2] - a[2]) + v * (c[2] - a[2])});
  }
  for (const auto& t : tris)  // the surface's vertices, where extremes usually sit
    for (uint32_t corner : t) measure(vertex(from_mesh, corner));
}

// An attribute of the original mesh that the simplified mesh has too, with the per-channel
// normalisation of its differences.
struct Pair {
  const storage::Attribute *a, *b;
  std::vector<double> offset, scale;
  bool vector;
};

// The attributes in both meshes, each with its normalisation; adds a field to r for each.
std::vector<Pair> pair_attributes(const storage::TetMesh& original, const storage::TetMesh& simplified, MeshErrorReport& r) {
  std::vector<Pair> pairs;
  for (const auto& a : original.attributes) {
    const storage::Attribute* b = simplified.find_attribute(a.info.name);
    if (!b || b->info.components != a.info.components) continue;
    Pair p{&a, b, {}, {}, a.info.components > 1};
    if (!p.vector) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (float v : a.values)
        if (std::isfinite(v)) { lo = std::min<double>(lo, v); hi = std::max<double>(hi, v); }
      p.offset = {std::isfinite(lo) ? lo : 0};
      p.scale = {hi > lo ? 1 / (hi - lo) : 0};
    } else {
      double longest = 0;
      const uint32_t c = a.info.components;
      for (size_t v = 0; v < original.vertex_count(); ++v) {
        double l2 = 0;
        for (uint32_t k = 0; k < c; ++k) l2 += double(a.values[v * c + k]) * a.values[v * c + k];
        if (std::isfinite(l2)) longest = std::max(longest, std::sqrt(l2));
      }
      p.offset.assign(c, 0);
      p.scale.assign(c, longest > 0 ? 0.5 / longest : 0);  // 0.5 v / longest (+0.5 cancels in differences)
    }
    pairs.push_back(p);
    r.fields.push_back({a.info.name, a.info.components, 0, 0});
  }
  return pairs;
}

// Field error: each paired attribute at every original vertex against the simplified mesh's
// interpolation there (in its tet, or outside at the nearest boundary point); fills r's
// per-field mean and max, mean_all and outside.
void measure_field_error(const storage::TetMesh& original, const storage::TetMesh& simplified, const std::vector<Pair>& pairs, const detail::TetLocator& tets,
                         const Surface& simplified_surface, MeshErrorReport& r) {
  std::vector<double> sum2(pairs.size(), 0.0);
  double total2 = 0;
  for (uint32_t v = 0; v < original.vertex_count(); ++v) {
    const Vec3 p = vertex(original, v);
    // barycentric location
    double bary[4] = {0, 0, 0, 0};
    const uint32_t found = tets.containing(p, bary, 1e-9);
    const uint32_t* corners;
    int count;
    uint32_t triangle_corners[3];
    if (found != detail::kNoTet) {
      corners = &simplified.tets[4 * size_t{found}];
      count = 4;
    } else {  // outside: the nearest point on the simplified boundary
      ++r.outside;
      uint32_t tri = 0;
      double w[3] = {1, 0, 0};
      simplified_surface.nearest(p, &tri, w);
      for (int i = 0; i < 3; ++i) triangle_corners[i] = simplified_surface.triangles()[tri][i];
      corners = triangle_corners;
      count = 3;
      bary[0] = w[0]; bary[1] = w[1]; bary[2] = w[2]; bary[3] = 0;
    }
    double vertex_total = 0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const Pair& pair = pairs[i];
      const uint32_t c = pair.a->info.components;
      double diff2 = 0;
      for (uint32_t k = 0; k < c; ++k) {
        double approx = 0;
        for (int j = 0; j < count; ++j) approx += bary[j] * pair.b->values[size_t{corners[j]} * c + k];
        double d = (double(pair.a->values[size_t{v} * c + k]) - approx) * pair.scale[k];
        if (std::isfinite(d)) diff2 += d * d;
      }
      sum2[i] += diff2;
      vertex_total += diff2;
      r.fields[i].max = std::max(r.fields[i].max, std::sqrt(diff2));
    }
    total2 += vertex_total;
  }
  for (size_t i = 0; i < pairs.size(); ++i) r.fields[i].mean = std::sqrt(sum2[i] / std::max<uint64_t>(1, r.vertices));
  r.mean_all = std::sqrt(total2 / std::max<uint64_t>(1, r.vertices));
}

}  // namespace

nlohmann::json MeshErrorReport::to_json() const {
  nlohmann::json f = nlohmann::json::array();
  for (const auto& e : fields) f.push_back({{"name", e.name}, {"components", e.components}, {"mean_field_error", e.mean}, {"max_field_error", e.max}});
  return {{"fields", f}, {"mean_field_error", mean_all}, {"vertices", vertices}, {"outside_vertices", outside},
          {"domain_error", {{"hausdorff", hausdorff}, {"mean", mean_distance}, {"hausdorff_relative", diagonal > 0 ? hausdorff / diagonal : 0},
                            {"mean_relative", diagonal > 0 ? mean_distance / diagonal : 0}, {"samples", samples}}},
          {"bounding_box_diagonal", diagonal}};
}

MeshErrorReport measure_error(const storage::TetMesh& original, const storage::TetMesh& simplified, uint32_t samples_per_surface) {
  MeshErrorReport r;
  r.vertices = original.vertex_count();
  storage::Bounds box = storage::compute_bounds(original);
  r.diagonal = std::sqrt(std::pow(box.max[0] - box.min[0], 2) + std::pow(box.max[1] - box.min[1], 2) + std::pow(box.max[2] - box.min[2], 2));
  // attributes in both
  const std::vector<Pair> pairs = pair_attributes(original, simplified, r);
  // locate the original vertices in the simplified tets
  const detail::TetLocator tets(simplified);
  Surface simplified_surface(simplified), original_surface(original);
  measure_field_error(original, simplified, pairs, tets, simplified_surface, r);
  // domain error: sample each boundary surface and measure the distance to the other
  std::mt19937 rng(1);
  SurfaceDistance distance;
  sample_surface_distance(original, original_surface, simplified_surface, samples_per_surface, rng, distance);
  sample_surface_distance(simplified, simplified_surface, original_surface, samples_per_surface, rng, distance);
  r.hausdorff = distance.hausdorff;
  r.mean_distance = distance.samples ? distance.sum / distance.samples : 0;
  r.samples = distance.samples;
  return r;
}

}  // namespace tetrascope::lod
