// Whole-mesh properties the tests assert: how often each face is used, signed volumes.
#pragma once

#include <algorithm>
#include <array>
#include <map>
#include <utility>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::testing {

struct MeshCheck {
  std::map<std::array<uint32_t, 3>, int> face_uses;  // sorted vertex triple -> tets using it
  size_t faces_shared_by_more_than_two = 0;
  size_t nonpositive = 0;  // tets of zero or negative volume
  double volume = 0;       // sum of signed volumes
};

// A box [0,1]^3 of n^3 cubes, 6 tets each (Kuhn split: conforming), inner vertices moved by up
// to `jitter` of a cube (deterministic), with one scalar attribute "f" = field(x, y, z).
template <class Field>
storage::TetMesh kuhn_box(int n, double jitter, Field field) {
  storage::TetMesh m;
  auto at = [&](int i, int j, int k) { return static_cast<uint32_t>((k * (n + 1) + j) * (n + 1) + i); };
  uint32_t seed = 12345;
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        auto wobble = [&](int c) {
          seed = seed * 1664525u + 1013904223u;
          bool inner = c > 0 && c < n;
          return inner ? jitter * ((seed >> 8) / double(1 << 24) - 0.5) / n : 0.0;
        };
        m.x.push_back(static_cast<float>(double(i) / n + wobble(i)));
        m.y.push_back(static_cast<float>(double(j) / n + wobble(j)));
        m.z.push_back(static_cast<float>(double(k) / n + wobble(k)));
      }
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        uint32_t c[8] = {at(i, j, k), at(i + 1, j, k), at(i + 1, j + 1, k), at(i, j + 1, k),
                         at(i, j, k + 1), at(i + 1, j, k + 1), at(i + 1, j + 1, k + 1), at(i, j + 1, k + 1)};
        const int kuhn[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6}, {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
        for (auto& t : kuhn) {
          uint32_t tet[4] = {c[t[0]], c[t[1]], c[t[2]], c[t[3]]};
          if (storage::signed_volume(m, tet[0], tet[1], tet[2], tet[3]) < 0) std::swap(tet[2], tet[3]);
          m.tets.insert(m.tets.end(), tet, tet + 4);
        }
      }
  storage::Attribute f{{"f", 1}, {}};
  for (size_t v = 0; v < m.vertex_count(); ++v) f.values.push_back(static_cast<float>(field(m.x[v], m.y[v], m.z[v])));
  m.attributes.push_back(f);
  return m;
}

inline MeshCheck check_mesh(const storage::TetMesh& mesh) {
  MeshCheck c;
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    const uint32_t* v = &mesh.tets[4 * t];
    double volume = storage::signed_volume(mesh, v[0], v[1], v[2], v[3]);
    c.volume += volume;
    if (volume <= 0) ++c.nonpositive;
    const int faces[4][3] = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
    for (const auto& f : faces) {
      std::array<uint32_t, 3> key{v[f[0]], v[f[1]], v[f[2]]};
      std::sort(key.begin(), key.end());
      ++c.face_uses[key];
    }
  }
  for (const auto& [key, uses] : c.face_uses) c.faces_shared_by_more_than_two += uses > 2;
  return c;
}

}  // namespace tetrascope::testing
