// Clipping a tet mesh by half-spaces, one plane at a time: a tet with vertices on both sides
// keeps a tet (one vertex kept) or a prism (two or three kept), and prisms are split into
// three tets by the smallest-vertex-id rule of Dompierre, Labbé, Vallet, Camarero, "How to
// subdivide pyramids, prisms and hexahedra into tetrahedra" (IMR 1999): neighbouring tets
// choose the same diagonal on their shared quad, so the result is conforming. Cut vertices
// are keyed by their edge, so the tets around an edge share them; a cut that falls on a kept
// vertex (its distance is exactly 0) is that vertex, and the tets this collapses (a vertex
// named twice) are dropped - they have no volume.
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "tetrascope/renderer/clip.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::renderer {
namespace {

// The prism's vertices permuted so that the smallest id comes first (index: where it was);
// vertex i of the bottom (0, 1, 2) is joined to i + 3 of the top.
constexpr int kPrismPermutation[6][6] = {{0, 1, 2, 3, 4, 5}, {1, 2, 0, 4, 5, 3}, {2, 0, 1, 5, 3, 4},
                                         {3, 5, 4, 0, 2, 1}, {4, 3, 5, 1, 0, 2}, {5, 4, 3, 2, 1, 0}};

class PlaneClipper {
 public:
  PlaneClipper(ClipMesh& mesh, const view::Plane& plane, bool crinkle) : mesh_(mesh), plane_(plane), crinkle_(crinkle) {}

  void run() {
    const size_t vertex_count = mesh_.xyz.size() / 3;
    side_.resize(vertex_count);
    // a vertex within float rounding of the plane lies on it: cutting there would make slivers
    // of no volume (or of rounding-negative volume) instead of reusing the vertex
    double extent = std::fabs(plane_.offset);
    for (float c : mesh_.xyz) extent = std::max(extent, double(std::fabs(c)));
    const double on_plane = 4 * extent * std::numeric_limits<float>::epsilon();
    for (size_t v = 0; v < vertex_count; ++v) {
      side_[v] = plane_.side(mesh_.xyz[3 * v], mesh_.xyz[3 * v + 1], mesh_.xyz[3 * v + 2]);
      if (std::fabs(side_[v]) <= on_plane) side_[v] = 0;
    }
    std::vector<uint32_t> out;
    out.reserve(mesh_.tets.size());
    for (size_t t = 0; t < mesh_.tets.size() / 4; ++t) {
      const uint32_t* tet = &mesh_.tets[4 * t];
      uint32_t kept[4], cut[4];
      int nk = 0, nc = 0;
      for (int k = 0; k < 4; ++k) (side_[tet[k]] <= 0 ? kept[nk++] : cut[nc++]) = tet[k];
      if (nc == 0 || (crinkle_ && nk > 0)) {
        out.insert(out.end(), tet, tet + 4);
        continue;
      }
      if (nk == 0 || crinkle_) continue;
      const bool positive = volume(tet[0], tet[1], tet[2], tet[3]) >= 0;
      if (nk == 1) {
        emit(out, positive, {kept[0], at(kept[0], cut[0]), at(kept[0], cut[1]), at(kept[0], cut[2])});
      } else if (nk == 3) {
        prism(out, positive, {kept[0], kept[1], kept[2], at(kept[0], cut[0]), at(kept[1], cut[0]), at(kept[2], cut[0])});
      } else {
        prism(out, positive, {kept[0], at(kept[0], cut[0]), at(kept[0], cut[1]), kept[1], at(kept[1], cut[0]), at(kept[1], cut[1])});
      }
    }
    mesh_.tets = std::move(out);
  }

 private:
  // The cut vertex on edge (a kept, b cut); a itself when a lies on the plane.
  uint32_t at(uint32_t a, uint32_t b) {
    if (side_[a] == 0) return a;
    const uint64_t key = uint64_t{a} << 32 | b;  // a is always the kept end: one key an edge
    auto [it, inserted] = cut_vertices_.try_emplace(key, 0);
    if (!inserted) return it->second;
    const double u = side_[a] / (side_[a] - side_[b]);  // in (0, 1): side_[a] < 0 < side_[b]
    const auto id = static_cast<uint32_t>(mesh_.xyz.size() / 3);
    for (int k = 0; k < 3; ++k) {
      const double pa = mesh_.xyz[3 * size_t{a} + k], pb = mesh_.xyz[3 * size_t{b} + k];
      mesh_.xyz.push_back(static_cast<float>(pa + u * (pb - pa)));
    }
    for (uint32_t k = 0; k < mesh_.width; ++k) {
      const double da = mesh_.data[size_t{a} * mesh_.width + k], db = mesh_.data[size_t{b} * mesh_.width + k];
      mesh_.data.push_back(static_cast<float>(da + u * (db - da)));
    }
    side_.push_back(0);
    it->second = id;
    return id;
  }

  double volume(uint32_t a, uint32_t b, uint32_t c, uint32_t d) const {
    const float* p[4] = {&mesh_.xyz[3 * size_t{a}], &mesh_.xyz[3 * size_t{b}], &mesh_.xyz[3 * size_t{c}], &mesh_.xyz[3 * size_t{d}]};
    double e[3][3];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) e[i][k] = double(p[i + 1][k]) - p[0][k];
    return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
  }

  // A tet, oriented as its parent was; dropped when it names a vertex twice.
  void emit(std::vector<uint32_t>& out, bool positive, std::array<uint32_t, 4> t) {
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (t[i] == t[j]) return;
    if ((volume(t[0], t[1], t[2], t[3]) >= 0) != positive) std::swap(t[2], t[3]);
    out.insert(out.end(), t.begin(), t.end());
  }

  void prism(std::vector<uint32_t>& out, bool positive, const std::array<uint32_t, 6>& p) {
    const int first = static_cast<int>(std::min_element(p.begin(), p.end()) - p.begin());
    uint32_t v[6];
    for (int i = 0; i < 6; ++i) v[i] = p[kPrismPermutation[first][i]];
    if (std::min(v[1], v[5]) < std::min(v[2], v[4])) {
      emit(out, positive, {v[0], v[1], v[2], v[5]});
      emit(out, positive, {v[0], v[1], v[5], v[4]});
    } else {
      emit(out, positive, {v[0], v[1], v[2], v[4]});
      emit(out, positive, {v[0], v[4], v[2], v[5]});
    }
    emit(out, positive, {v[0], v[4], v[5], v[3]});
  }

  ClipMesh& mesh_;
  const view::Plane plane_;
  const bool crinkle_;
  std::vector<double> side_;
  std::unordered_map<uint64_t, uint32_t> cut_vertices_;
};

// Drops the vertices no tet uses and renumbers the tets.
void drop_unused(ClipMesh& mesh) {
  const size_t vertex_count = mesh.xyz.size() / 3;
  constexpr uint32_t kUnused = 0xFFFFFFFFu;
  std::vector<uint32_t> remap(vertex_count, kUnused);
  for (uint32_t v : mesh.tets) remap[v] = 0;
  uint32_t next = 0;
  for (size_t v = 0; v < vertex_count; ++v) {
    if (remap[v] == kUnused) continue;
    remap[v] = next;
    if (next != v) {
      std::copy_n(&mesh.xyz[3 * v], 3, &mesh.xyz[3 * size_t{next}]);
      std::copy_n(&mesh.data[v * mesh.width], mesh.width, &mesh.data[size_t{next} * mesh.width]);
    }
    ++next;
  }
  mesh.xyz.resize(3 * size_t{next});
  mesh.data.resize(size_t{next} * mesh.width);
  for (uint32_t& v : mesh.tets) v = remap[v];
}

}  // namespace

ClipMesh clip_tets(ClipMesh mesh, const view::ClipSpec& spec) {
  for (const view::Plane& plane : spec.half_spaces()) PlaneClipper(mesh, plane, spec.crinkle).run();
  drop_unused(mesh);
  return mesh;
}

SceneMesh clip_scene(const SceneMesh& scene, const view::ClipSpec& spec) {
  const bool iso_color = scene.iso_color_value.size() == scene.value.size() && !scene.iso_color_attribute.empty();
  ClipMesh m;
  m.xyz = scene.xyz;
  m.tets = scene.tets;
  m.width = iso_color ? 2 : 1;
  m.data.resize(scene.value.size() * m.width);
  for (size_t v = 0; v < scene.value.size(); ++v) {
    m.data[v * m.width] = scene.value[v];
    if (iso_color) m.data[v * m.width + 1] = scene.iso_color_value[v];
  }
  m = clip_tets(std::move(m), spec);
  SceneMesh out;
  out.xyz = std::move(m.xyz);
  out.tets = std::move(m.tets);
  const size_t n = out.xyz.size() / 3;
  out.value.resize(n);
  if (iso_color) out.iso_color_value.resize(n);
  for (size_t v = 0; v < n; ++v) {
    out.value[v] = m.data[v * m.width];
    if (iso_color) out.iso_color_value[v] = m.data[v * m.width + 1];
  }
  out.boundary = boundary_faces(out.tets);
  out.bounds = scene.bounds;
  out.diagonal = scene.diagonal;
  out.max_edge = scene.max_edge;
  out.attribute = scene.attribute;
  out.component = scene.component;
  out.value_min = scene.value_min;
  out.value_max = scene.value_max;
  out.iso_color_attribute = scene.iso_color_attribute;
  out.iso_color_min = scene.iso_color_min;
  out.iso_color_max = scene.iso_color_max;
  return out;
}

storage::TetMesh clip_mesh(const storage::TetMesh& mesh, const view::ClipSpec& spec) {
  ClipMesh m;
  const size_t n = mesh.vertex_count();
  m.xyz.resize(3 * n);
  for (size_t v = 0; v < n; ++v) {
    m.xyz[3 * v] = mesh.x[v];
    m.xyz[3 * v + 1] = mesh.y[v];
    m.xyz[3 * v + 2] = mesh.z[v];
  }
  m.tets = mesh.tets;
  for (const auto& a : mesh.attributes) m.width += a.info.components;
  m.data.resize(n * m.width);
  uint32_t column = 0;
  for (const auto& a : mesh.attributes) {
    const uint32_t c = a.info.components;
    for (size_t v = 0; v < n; ++v) std::copy_n(&a.values[v * c], c, &m.data[v * m.width + column]);
    column += c;
  }
  m = clip_tets(std::move(m), spec);
  storage::TetMesh out;
  const size_t kept = m.xyz.size() / 3;
  out.x.resize(kept);
  out.y.resize(kept);
  out.z.resize(kept);
  for (size_t v = 0; v < kept; ++v) {
    out.x[v] = m.xyz[3 * v];
    out.y[v] = m.xyz[3 * v + 1];
    out.z[v] = m.xyz[3 * v + 2];
  }
  out.tets = std::move(m.tets);
  column = 0;
  for (const auto& a : mesh.attributes) {
    storage::Attribute b;
    b.info = a.info;
    const uint32_t c = a.info.components;
    b.values.resize(kept * c);
    for (size_t v = 0; v < kept; ++v) std::copy_n(&m.data[v * m.width + column], c, &b.values[v * c]);
    column += c;
    out.attributes.push_back(std::move(b));
  }
  return out;
}

}  // namespace tetrascope::renderer
