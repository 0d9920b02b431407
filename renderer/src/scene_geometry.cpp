// CPU geometry of the GL renderer's passes (see scene_geometry.h).
#include "scene_geometry.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

namespace {

Vec3 position(const SceneMesh& mesh, uint32_t v) { return {mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2]}; }

}  // namespace

std::vector<float> tet_cells(const SceneMesh& mesh) {
  const size_t tets = mesh.tets.size() / 4;
  std::vector<float> cells(kFloatsPerTetCell * tets);
  for (size_t t = 0; t < tets; ++t) {
    Vec3 p[4];
    double value[4];
    for (int k = 0; k < 4; ++k) {
      const uint32_t v = mesh.tets[4 * t + k];
      p[k] = position(mesh, v);
      value[k] = mesh.value[v];
    }
    float* c = &cells[kFloatsPerTetCell * t];
    for (int f = 0; f < 4; ++f) {
      const Vec3& a = p[kTetFace[f][0]];
      const Vec3 n = normalise(cross(p[kTetFace[f][1]] - a, p[kTetFace[f][2]] - a));
      c[4 * f] = static_cast<float>(n[0]);
      c[4 * f + 1] = static_cast<float>(n[1]);
      c[4 * f + 2] = static_cast<float>(n[2]);
      c[4 * f + 3] = static_cast<float>(-dot(n, a));
    }
    // gradient g of the linear field: g.e_i = value_i - value_0
    const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0], e3 = p[3] - p[0];
    const double det = dot(e1, cross(e2, e3));
    Vec3 g{0, 0, 0};
    if (std::fabs(det) > 0) {
      const Vec3 c23 = cross(e2, e3), c31 = cross(e3, e1), c12 = cross(e1, e2);
      for (int k = 0; k < 3; ++k) g[k] = ((value[1] - value[0]) * c23[k] + (value[2] - value[0]) * c31[k] + (value[3] - value[0]) * c12[k]) / det;
    }
    c[16] = static_cast<float>(g[0]);
    c[17] = static_cast<float>(g[1]);
    c[18] = static_cast<float>(g[2]);
    c[19] = static_cast<float>(value[0] - dot(g, p[0]));
  }
  return cells;
}

TetSortInputs tet_sort_inputs(const SceneMesh& mesh) {
  const size_t tets = mesh.tets.size() / 4;
  TetSortInputs out;
  out.centroid.assign(3 * tets, 0.0f);
  out.radius.resize(tets);
  out.range.resize(2 * tets);
  for (size_t t = 0; t < tets; ++t) {
    float lo = 3.4e38f, hi = -3.4e38f;
    for (int j = 0; j < 4; ++j) {
      const uint32_t v = mesh.tets[4 * t + j];
      for (int k = 0; k < 3; ++k) out.centroid[3 * t + k] += 0.25f * mesh.xyz[3 * size_t{v} + k];
      lo = std::min(lo, mesh.value[v]);
      hi = std::max(hi, mesh.value[v]);
    }
    double r2 = 0;
    for (int j = 0; j < 4; ++j) {
      const uint32_t v = mesh.tets[4 * t + j];
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += std::pow(double(mesh.xyz[3 * size_t{v} + k]) - out.centroid[3 * t + k], 2);
      r2 = std::max(r2, d2);
    }
    out.radius[t] = static_cast<float>(std::sqrt(r2) * (1 + 1e-6));  // float centroid: a little slack
    out.range[2 * t] = lo;
    out.range[2 * t + 1] = hi;
  }
  return out;
}

std::vector<uint32_t> projected_fan_indices(uint32_t slots) {
  static constexpr uint32_t kFan[12] = {4, 0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0};
  std::vector<uint32_t> out(size_t{slots} * 12);
  for (uint32_t i = 0; i < slots; ++i)
    for (int k = 0; k < 12; ++k) out[12 * size_t{i} + k] = 5 * i + kFan[k];
  return out;
}

std::vector<uint32_t> tet_corner_indices(uint32_t slots) {
  std::vector<uint32_t> indices(12 * size_t{slots});
  for (uint32_t i = 0; i < slots; ++i)
    for (int f = 0; f < 4; ++f)
      for (int k = 0; k < 3; ++k) indices[12 * size_t{i} + 3 * f + k] = 4 * i + static_cast<uint32_t>(kTetFace[f][k]);
  return indices;
}

BoundaryGeometry boundary_geometry(const SceneMesh& mesh) {
  BoundaryGeometry out;
  out.corners.reserve(mesh.boundary.size() * 12);
  std::map<std::pair<uint32_t, uint32_t>, std::array<uint32_t, 2>> edges;
  for (uint32_t f = 0; f < mesh.boundary.size(); ++f) {
    const auto& tri = mesh.boundary[f];
    for (int i = 0; i < 3; ++i) {
      const uint32_t v = tri[i];
      out.corners.insert(out.corners.end(), {mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2], mesh.value[v]});
      auto key = std::minmax(tri[i], tri[(i + 1) % 3]);
      auto [it, inserted] = edges.try_emplace({key.first, key.second}, std::array<uint32_t, 2>{f, kNoOppositeFace});
      if (!inserted) it->second[1] = f;
    }
  }
  out.edges.reserve(edges.size());
  for (const auto& [e, faces] : edges) out.edges.push_back({e.first, e.second, faces[0], faces[1]});
  return out;
}

void append_boundary_edges(const SceneMesh& mesh, const BoundaryGeometry& boundary, const Frame& frame, bool all_edges, std::vector<float>& lines,
                           const std::vector<uint8_t>& hidden) {
  std::vector<int8_t> facing(mesh.boundary.size());
  for (size_t i = 0; i < mesh.boundary.size(); ++i) {
    const auto& t = mesh.boundary[i];
    const Vec3 a = position(mesh, t[0]), b = position(mesh, t[1]), c = position(mesh, t[2]);
    const Vec3 n = cross(b - a, c - a);
    facing[i] = (frame.ortho ? -dot(n, frame.forward) : dot(n, frame.eye - a)) > 0;
  }
  auto shown = [&](uint32_t face) { return face != kNoOppositeFace && (hidden.empty() || !hidden[face]); };
  for (const auto& e : boundary.edges) {
    if (!shown(e[2]) && !shown(e[3])) continue;
    const bool open = !shown(e[2]) || !shown(e[3]);
    const bool silhouette = open || facing[e[2]] != facing[e[3]];
    if (!silhouette && !all_edges) continue;
    for (uint32_t v : {e[0], e[1]}) lines.insert(lines.end(), {mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2], 0.0f});
  }
}

void append_box_edges(const storage::Bounds& b, std::vector<float>& lines) {
  for (int axis = 0; axis < 3; ++axis)
    for (int i = 0; i < 4; ++i) {
      double p[3], q[3];
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      p[axis] = b.min[axis];
      q[axis] = b.max[axis];
      p[u] = q[u] = (i & 1) ? b.max[u] : b.min[u];
      p[w] = q[w] = (i & 2) ? b.max[w] : b.min[w];
      lines.insert(lines.end(), {float(p[0]), float(p[1]), float(p[2]), 0.0f, float(q[0]), float(q[1]), float(q[2]), 0.0f});
    }
}

}  // namespace tetrascope::renderer
