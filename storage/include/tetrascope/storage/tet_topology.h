// Tetrahedron topology shared by every library: the face table, sorted face keys, face pairing
// and the boundary of a tet soup. One definition; the readers, the segment store, the
// multi-triangulation build, the cut and the renderer all use it.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <tuple>
#include <vector>

namespace tetrascope {

// Face f of a positively oriented tet is opposite vertex f and, in this vertex order, its
// normal points out of the tet.
constexpr int kTetFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

// Marks a face with no partner (on the boundary of the tets given).
constexpr uint32_t kNoOppositeFace = 0xFFFFFFFFu;

using FaceVertices = std::array<uint32_t, 3>;

// The three vertex ids of face f of tet t, in outward order.
inline FaceVertices tet_face(std::span<const uint32_t> tets, size_t t, int f) {
  return {tets[4 * t + kTetFace[f][0]], tets[4 * t + kTetFace[f][1]], tets[4 * t + kTetFace[f][2]]};
}

// The same face as an orientation-free key: its vertex ids sorted ascending.
inline FaceVertices face_key(FaceVertices face) {
  std::sort(face.begin(), face.end());
  return face;
}

// For every face 4t+f of `tets`, the face 4u+g it is glued to, or kNoOppositeFace.
// A face shared by more than two tets (a non-manifold input) pairs its first two and leaves
// the rest unpaired; callers that must refuse such input check `non_manifold_faces`.
struct FacePairing {
  std::vector<uint32_t> opposite;    // 4 per tet
  size_t non_manifold_faces = 0;     // keys met three times or more
};

inline FacePairing pair_faces(std::span<const uint32_t> tets) {
  const size_t faces = tets.size();
  struct Entry {
    FaceVertices key;
    uint32_t face;
    bool operator<(const Entry& o) const { return std::tie(key, face) < std::tie(o.key, o.face); }
  };
  std::vector<Entry> entries(faces);
  for (size_t i = 0; i < faces; ++i) entries[i] = {face_key(tet_face(tets, i / 4, int(i % 4))), uint32_t(i)};
  std::sort(entries.begin(), entries.end());
  FacePairing out;
  out.opposite.assign(faces, kNoOppositeFace);
  for (size_t i = 0; i < entries.size();) {
    size_t j = i + 1;
    while (j < entries.size() && entries[j].key == entries[i].key) ++j;
    if (j - i >= 2) {
      out.opposite[entries[i].face] = entries[i + 1].face;
      out.opposite[entries[i + 1].face] = entries[i].face;
    }
    if (j - i > 2) ++out.non_manifold_faces;
    i = j;
  }
  return out;
}

// The faces that belong to one tet only (the boundary of the tets given), outward oriented,
// in the order of the tets.
inline std::vector<FaceVertices> boundary_faces(std::span<const uint32_t> tets) {
  const FacePairing pairing = pair_faces(tets);
  std::vector<FaceVertices> out;
  for (size_t i = 0; i < pairing.opposite.size(); ++i) {
    if (pairing.opposite[i] == kNoOppositeFace) out.push_back(tet_face(tets, i / 4, int(i % 4)));
  }
  return out;
}

}  // namespace tetrascope
