#include "tetrascope/storage/mesh.h"

#include <algorithm>

namespace tetrascope::storage {

const Attribute* TetMesh::find_attribute(const std::string& name) const {
  for (const Attribute& a : attributes) {
    if (a.info.name == name) return &a;
  }
  return nullptr;
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

}  // namespace tetrascope::storage
