#include "tetrascope/storage/mesh.h"

#include <algorithm>
#include <cstddef>

namespace tetrascope::storage {

const Attribute* TetMesh::find_attribute(const std::string& name) const {
  for (const Attribute& a : attributes) {
    if (a.info.name == name) return &a;
  }
  return nullptr;
}

uint32_t FaceTags::tag(const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it != names.end()) return static_cast<uint32_t>(it - names.begin());
  names.push_back(name);
  return static_cast<uint32_t>(names.size() - 1);
}

void FaceTags::renumber(const std::vector<uint32_t>& renumber, uint32_t dropped) {
  size_t kept = 0;
  for (size_t t = 0; t < triangles.size(); ++t) {
    std::array<uint32_t, 3> tri = triangles[t];
    bool keep = true;
    for (uint32_t& v : tri) {
      v = v < renumber.size() ? renumber[v] : dropped;
      keep = keep && v != dropped;
    }
    if (!keep) continue;
    triangles[kept] = tri;
    tags[kept++] = tags[t];
  }
  triangles.resize(kept);
  tags.resize(kept);
}

double signed_volume(const TetMesh& m, uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
  double ax = double(m.x[b]) - m.x[a], ay = double(m.y[b]) - m.y[a], az = double(m.z[b]) - m.z[a];
  double bx = double(m.x[c]) - m.x[a], by = double(m.y[c]) - m.y[a], bz = double(m.z[c]) - m.z[a];
  double cx = double(m.x[d]) - m.x[a], cy = double(m.y[d]) - m.y[a], cz = double(m.z[d]) - m.z[a];
  return (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)) / 6.0;
}

Bounds compute_bounds(const TetMesh& mesh) {
  Bounds b;
  if (mesh.x.empty()) return b;
  const std::vector<float>* axes[3] = {&mesh.x, &mesh.y, &mesh.z};
  for (int k = 0; k < 3; ++k) {
    auto [lo, hi] = std::minmax_element(axes[k]->begin(), axes[k]->end());
    b.min[k] = *lo;
    b.max[k] = *hi;
  }
  return b;
}

uint64_t drop_unused_vertices(TetMesh& mesh) {
  constexpr uint32_t kUnused = UINT32_MAX;
  const size_t vertex_count = mesh.vertex_count();
  std::vector<uint32_t> renumber(vertex_count, kUnused);
  for (uint32_t v : mesh.tets) renumber[v] = 0;
  uint32_t kept = 0;
  for (size_t v = 0; v < vertex_count; ++v) {
    if (renumber[v] != kUnused) renumber[v] = kept++;
  }
  if (kept == vertex_count) return 0;
  for (uint32_t& v : mesh.tets) v = renumber[v];
  mesh.face_tags.renumber(renumber, kUnused);
  auto compact = [&](std::vector<float>& values, size_t components) {
    for (size_t v = 0; v < vertex_count; ++v) {
      if (renumber[v] == kUnused || renumber[v] == v) continue;
      std::copy_n(values.begin() + static_cast<std::ptrdiff_t>(v * components), components,
                  values.begin() + static_cast<std::ptrdiff_t>(size_t{renumber[v]} * components));
    }
    values.resize(size_t{kept} * components);
    values.shrink_to_fit();
  };
  compact(mesh.x, 1);
  compact(mesh.y, 1);
  compact(mesh.z, 1);
  for (Attribute& a : mesh.attributes) compact(a.values, a.info.components);
  return vertex_count - kept;
}

}  // namespace tetrascope::storage
