// Whole-mesh properties the tests assert: how often each face is used, signed volumes.
#pragma once

#include <algorithm>
#include <array>
#include <map>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::testing {

struct MeshCheck {
  std::map<std::array<uint32_t, 3>, int> face_uses;  // sorted vertex triple -> tets using it
  size_t faces_shared_by_more_than_two = 0;
  size_t nonpositive = 0;  // tets of zero or negative volume
  double volume = 0;       // sum of signed volumes
};

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
