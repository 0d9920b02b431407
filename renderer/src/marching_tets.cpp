// Marching tetrahedra: the isosurface of a linear field in each tet is a triangle or a quad
// (Doi, Koide, "An Efficient Method of Triangulating Equi-Valued Surfaces by Using
// Tetrahedral Cells", 1991).
#include <algorithm>
#include <array>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

std::vector<float> marching_tets(const SceneMesh& mesh, double isovalue, std::vector<float>* iso_color) {
  std::vector<float> out;
  if (iso_color && mesh.iso_color_value.size() != mesh.value.size()) throw std::invalid_argument("the scene has no iso-colour attribute");
  // a corner: position and, in the fourth slot, the iso-colour attribute
  auto point = [&](uint32_t a, uint32_t b) {
    const double va = mesh.value[a], vb = mesh.value[b];
    const double u = vb != va ? std::clamp((isovalue - va) / (vb - va), 0.0, 1.0) : 0.5;
    std::array<float, 4> p{};
    for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(mesh.xyz[3 * size_t{a} + k] + u * (mesh.xyz[3 * size_t{b} + k] - mesh.xyz[3 * size_t{a} + k]));
    if (iso_color) p[3] = static_cast<float>(mesh.iso_color_value[a] + u * (mesh.iso_color_value[b] - mesh.iso_color_value[a]));
    return p;
  };
  for (size_t t = 0; t < mesh.tets.size() / 4; ++t) {
    const uint32_t* tet = &mesh.tets[4 * t];
    uint32_t above[4], below[4];
    int na = 0, nb = 0;
    for (int k = 0; k < 4; ++k) (mesh.value[tet[k]] >= isovalue ? above[na++] : below[nb++]) = tet[k];
    if (na == 0 || nb == 0) continue;
    std::vector<std::array<float, 4>> poly;
    if (na == 1) {
      for (int k = 0; k < 3; ++k) poly.push_back(point(above[0], below[k]));
    } else if (nb == 1) {
      for (int k = 0; k < 3; ++k) poly.push_back(point(below[0], above[k]));
    } else {  // a quad, in cyclic order
      poly = {point(above[0], below[0]), point(above[0], below[1]), point(above[1], below[1]), point(above[1], below[0])};
    }
    // orient towards increasing values: the direction from a below vertex to an above one
    double up[3];
    for (int k = 0; k < 3; ++k) up[k] = mesh.xyz[3 * size_t{above[0]} + k] - mesh.xyz[3 * size_t{below[0]} + k];
    auto emit = [&](const std::array<float, 4>& a, const std::array<float, 4>& b, const std::array<float, 4>& c) {
      const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]}, e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
      const double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      const bool flip = nrm[0] * up[0] + nrm[1] * up[1] + nrm[2] * up[2] < 0;
      const std::array<float, 4>* corners[3] = {&a, flip ? &c : &b, flip ? &b : &c};
      for (auto* p : corners) {
        out.insert(out.end(), p->begin(), p->begin() + 3);
        if (iso_color) iso_color->push_back((*p)[3]);
      }
    };
    emit(poly[0], poly[1], poly[2]);
    if (poly.size() == 4) emit(poly[0], poly[2], poly[3]);
  }
  return out;
}

}  // namespace tetrascope::renderer
