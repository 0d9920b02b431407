// Shirley-Tuchman classification of a tet's projection (see projected_tets.h).
#include "projected_tets.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

namespace {

struct Projected {
  Vec3 p[4];
  double s[4], x[4], y[4], w[4];  // value, image-plane coordinates, depth along the view
};

double orient(const Projected& q, int a, int b, int c) { return (q.x[b] - q.x[a]) * (q.y[c] - q.y[a]) - (q.y[b] - q.y[a]) * (q.x[c] - q.x[a]); }

// Under perspective a parameter along a projected edge is not the parameter along the edge in
// space: 1/w interpolates linearly on the image plane.
double space_parameter(double u, double wa, double wb, bool ortho) {
  if (ortho) return u;
  const double a = (1 - u) / wa, b = u / wb;
  return a + b > 0 ? std::clamp(b / (a + b), 0.0, 1.0) : u;
}

// The isosurfaces' shading: the field's gradient against the ray through `p`.
float iso_light(const Projected& q, const Frame& f, const Vec3& p) {
  const Vec3 e1 = q.p[1] - q.p[0], e2 = q.p[2] - q.p[0], e3 = q.p[3] - q.p[0];
  const Vec3 g = (q.s[1] - q.s[0]) * cross(e2, e3) + (q.s[2] - q.s[0]) * cross(e3, e1) + (q.s[3] - q.s[0]) * cross(e1, e2);  // times the volume
  const Vec3 d = f.ortho ? f.forward : p - f.eye;
  const double gn = length(g), dn = length(d);
  return static_cast<float>(0.25 + 0.75 * (gn > 0 && dn > 0 ? std::fabs(dot(g, d)) / (gn * dn) : 1.0));
}

// The fan's five vertices: the boundary's corners, then the thick vertex from the two points
// where the ray through it meets the tet.
void emit(const Projected& q, const Frame& f, const int (&corners)[4], const Vec3& p1, double s1, const Vec3& p2, double s2, bool light,
          ProjectedVertex* out) {
  for (int j = 0; j < 4; ++j) {
    const int c = corners[j];
    out[j] = {static_cast<float>(q.p[c][0]), static_cast<float>(q.p[c][1]), static_cast<float>(q.p[c][2]), static_cast<float>(q.s[c]),
              static_cast<float>(q.s[c]), 0, 1};
  }
  const double d1 = f.ortho ? dot(p1 - f.eye, f.forward) : length(p1 - f.eye), d2 = f.ortho ? dot(p2 - f.eye, f.forward) : length(p2 - f.eye);
  const bool first_in_front = d1 <= d2;
  const Vec3& front = first_in_front ? p1 : p2;
  out[4] = {static_cast<float>(front[0]), static_cast<float>(front[1]), static_cast<float>(front[2]), static_cast<float>(first_in_front ? s1 : s2),
            static_cast<float>(first_in_front ? s2 : s1), static_cast<float>(length(p2 - p1)), light ? iso_light(q, f, front) : 1.0f};
}

}  // namespace

void classify_tet(const SceneMesh& mesh, uint32_t tet, const Frame& f, double lo, double inv_span, bool light, ProjectedVertex* out) {
  Projected q;
  for (int k = 0; k < 4; ++k) {
    const uint32_t v = mesh.tets[4 * size_t{tet} + k];
    q.p[k] = {mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2]};
    q.s[k] = (mesh.value[v] - lo) * inv_span;
    const Vec3 r = q.p[k] - f.eye;
    q.w[k] = dot(r, f.forward);
    q.x[k] = dot(r, f.right);
    q.y[k] = dot(r, f.up);
    if (!f.ortho) {
      q.w[k] = std::max(q.w[k], 1e-30);
      q.x[k] /= q.w[k];
      q.y[k] /= q.w[k];
    }
  }
  // two opposite edges whose projections cross: the projection is a quadrilateral with them
  // as diagonals, the thick vertex where they cross
  static constexpr int kOpposite[3][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2}};
  for (const auto& e : kOpposite) {
    const int a = e[0], b = e[1], c = e[2], d = e[3];
    const double o1 = orient(q, a, b, c), o2 = orient(q, a, b, d), o3 = orient(q, c, d, a), o4 = orient(q, c, d, b);
    if (!(o1 * o2 < 0 && o3 * o4 < 0)) continue;
    const double u = space_parameter(o3 / (o3 - o4), q.w[a], q.w[b], f.ortho), v = space_parameter(o1 / (o1 - o2), q.w[c], q.w[d], f.ortho);
    const Vec3 pab = q.p[a] + u * (q.p[b] - q.p[a]), pcd = q.p[c] + v * (q.p[d] - q.p[c]);
    emit(q, f, {a, c, b, d}, pab, q.s[a] + u * (q.s[b] - q.s[a]), pcd, q.s[c] + v * (q.s[d] - q.s[c]), light, out);
    return;
  }
  // a triangle: the corner projecting inside the other three's triangle (the one with the
  // largest smallest barycentric coordinate, robust to corners on edges)
  static constexpr int kOthers[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  int best = -1;
  double best_min = -1e300, best_l[3] = {};
  for (int i = 0; i < 4; ++i) {
    const int a = kOthers[i][0], b = kOthers[i][1], c = kOthers[i][2];
    const double area = orient(q, a, b, c);
    if (!(std::fabs(area) > 0)) continue;
    const double l[3] = {orient(q, i, b, c) / area, orient(q, a, i, c) / area, orient(q, a, b, i) / area};
    const double m = std::min({l[0], l[1], l[2]});
    if (m > best_min) {
      best_min = m;
      best = i;
      std::copy_n(l, 3, best_l);
    }
  }
  if (best < 0) {  // the projection has no area: nothing to draw
    emit(q, f, {1, 2, 3, 3}, q.p[0], q.s[0], q.p[0], q.s[0], false, out);
    return;
  }
  const int* o = kOthers[best];
  double mu[3], sum = 0;
  for (int k = 0; k < 3; ++k) {
    mu[k] = std::max(best_l[k], 0.0) / (f.ortho ? 1.0 : q.w[o[k]]);
    sum += mu[k];
  }
  Vec3 face{0, 0, 0};
  double s_face = 0;
  for (int k = 0; k < 3; ++k) {
    const double m = sum > 0 ? mu[k] / sum : 1.0 / 3;
    face = face + m * q.p[o[k]];
    s_face += m * q.s[o[k]];
  }
  emit(q, f, {o[0], o[1], o[2], o[2]}, q.p[best], q.s[best], face, s_face, light, out);
}

void classify_tets(const SceneMesh& mesh, std::span<const uint32_t> order, const Frame& frame, double lo, double inv_span, bool light, unsigned threads,
                   ProjectedVertex* out) {
  auto work = [&](size_t first, size_t end) {
    for (size_t i = first; i < end; ++i) classify_tet(mesh, order[i], frame, lo, inv_span, light, out + kVerticesPerTet * i);
  };
  threads = std::max(1u, threads);
  if (threads == 1 || order.size() < 4096) {
    work(0, order.size());
    return;
  }
  std::vector<std::thread> pool;
  const size_t per = (order.size() + threads - 1) / threads;
  for (unsigned k = 1; k < threads; ++k) pool.emplace_back(work, std::min(order.size(), k * per), std::min(order.size(), (k + 1) * per));
  work(0, std::min(order.size(), per));
  for (auto& t : pool) t.join();
}

}  // namespace tetrascope::renderer
