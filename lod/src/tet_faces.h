// Faces of tet meshes, shared by the simplifier and the error measure.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace tetrascope::lod::detail {

// Face f of a positively oriented tet is opposite vertex f and, in this order, points outward.
constexpr int kTetFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

// The faces that belong to one tet only (the mesh boundary), outward oriented.
inline std::vector<std::array<uint32_t, 3>> boundary_faces(std::span<const uint32_t> tets) {
  std::vector<std::pair<std::array<uint32_t, 3>, std::array<uint32_t, 3>>> faces;  // sorted key, oriented
  faces.reserve(tets.size());
  for (size_t t = 0; t < tets.size() / 4; ++t) {
    for (const auto& f : kTetFace) {
      std::array<uint32_t, 3> face{tets[4 * t + f[0]], tets[4 * t + f[1]], tets[4 * t + f[2]]}, key = face;
      std::sort(key.begin(), key.end());
      faces.push_back({key, face});
    }
  }
  std::sort(faces.begin(), faces.end());
  std::vector<std::array<uint32_t, 3>> out;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].first == faces[i].first) ++j;
    if (j - i == 1) out.push_back(faces[i].second);
    i = j;
  }
  return out;
}

}  // namespace tetrascope::lod::detail
