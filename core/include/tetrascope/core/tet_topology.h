// Tetrahedron topology shared by every library: the face table, sorted face keys, face pairing
// and the boundary of a tet soup. One definition; the readers, the segment store, the
// multi-triangulation build, the cut and the renderer all use it.
#pragma once

#include <algorithm>
#include <array>
#include <compare>
#include <cstdint>
#include <span>
#include <utility>
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

// Reusable memory for the pairing below; keep one per thread and pass it to every call.
struct FacePairingScratch {
  std::vector<uint32_t> local_of;  // vertex id -> dense local id; kNoOppositeFace between calls
  std::vector<uint32_t> touched;   // the vertex ids given a local id in this call
  std::vector<std::pair<uint64_t, uint32_t>> packed;  // (packed key, face)
  std::vector<std::pair<FaceVertices, uint32_t>> wide;  // (key, face) when ids do not pack
};

// pair_faces into `opposite` (resized to 4 per tet), reusing `scratch` across calls; returns
// the number of non-manifold faces. The tets' vertex ids are first renumbered densely, so
// that a key packs three 21-bit ids into one 64-bit integer and the sort is on integers;
// tets with 2^21 distinct vertices or more sort three-id keys instead. Same result either way.
inline size_t pair_faces(std::span<const uint32_t> tets, FacePairingScratch& scratch, std::vector<uint32_t>& opposite) {
  const size_t faces = tets.size();
  opposite.assign(faces, kNoOppositeFace);
  uint32_t next = 0;
  for (uint32_t g : tets) {
    if (g >= scratch.local_of.size()) scratch.local_of.resize(size_t{g} + 1, kNoOppositeFace);
    if (scratch.local_of[g] == kNoOppositeFace) {
      scratch.local_of[g] = next++;
      scratch.touched.push_back(g);
    }
  }
  size_t non_manifold = 0;
  // pairs the first two faces of every run of equal keys in a sorted list
  auto pair_runs = [&](const auto& sorted) {
    for (size_t i = 0; i < sorted.size();) {
      size_t j = i + 1;
      while (j < sorted.size() && sorted[j].first == sorted[i].first) ++j;
      if (j - i >= 2) {
        opposite[sorted[i].second] = sorted[i + 1].second;
        opposite[sorted[i + 1].second] = sorted[i].second;
      }
      if (j - i > 2) ++non_manifold;
      i = j;
    }
  };
  constexpr uint32_t kPackedIds = 1u << 21;
  if (next < kPackedIds) {
    auto& keys = scratch.packed;
    keys.resize(faces);
    for (size_t t = 0; t < faces / 4; ++t) {
      for (int f = 0; f < 4; ++f) {
        uint64_t v[3];
        for (int i = 0; i < 3; ++i) v[i] = scratch.local_of[tets[4 * t + kTetFace[f][i]]];
        if (v[0] > v[1]) std::swap(v[0], v[1]);
        if (v[1] > v[2]) std::swap(v[1], v[2]);
        if (v[0] > v[1]) std::swap(v[0], v[1]);
        keys[4 * t + f] = {v[0] << 42 | v[1] << 21 | v[2], static_cast<uint32_t>(4 * t + f)};
      }
    }
    std::sort(keys.begin(), keys.end());
    pair_runs(keys);
  } else {
    auto& keys = scratch.wide;
    keys.resize(faces);
    for (size_t i = 0; i < faces; ++i) keys[i] = {face_key(tet_face(tets, i / 4, int(i % 4))), static_cast<uint32_t>(i)};
    std::sort(keys.begin(), keys.end());
    pair_runs(keys);
  }
  for (uint32_t g : scratch.touched) scratch.local_of[g] = kNoOppositeFace;
  scratch.touched.clear();
  return non_manifold;
}

inline FacePairing pair_faces(std::span<const uint32_t> tets) {
  FacePairingScratch scratch;
  FacePairing out;
  out.non_manifold_faces = pair_faces(tets, scratch, out.opposite);
  return out;
}

// A face left unpaired inside its segment (or patch), to be glued to another segment's.
struct OpenFace {
  FaceVertices key;  // face_key of the face, in the ids shared across segments
  uint32_t segment;  // the segment (or patch) it belongs to
  uint32_t face;     // 4 * tet + f within that segment
  auto operator<=>(const OpenFace&) const = default;  // by key, then segment, then face
};

// Sorts `faces` and calls glue(a, b) for every key held by exactly two of them (a before b);
// keys held once are boundary faces, keys held three times or more are left alone.
template <class Glue>
void pair_open_faces(std::vector<OpenFace>& faces, Glue&& glue) {
  std::sort(faces.begin(), faces.end());
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 2) glue(faces[i], faces[i + 1]);
    i = j;
  }
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

// boundary_faces ordered by their keys rather than by tet: an order that does not depend on
// how the tets are numbered (sums over the faces then round the same way).
inline std::vector<FaceVertices> boundary_faces_by_key(std::span<const uint32_t> tets) {
  std::vector<FaceVertices> out = boundary_faces(tets);
  std::vector<std::pair<FaceVertices, uint32_t>> keyed(out.size());
  for (size_t i = 0; i < out.size(); ++i) keyed[i] = {face_key(out[i]), static_cast<uint32_t>(i)};
  std::sort(keyed.begin(), keyed.end());
  std::vector<FaceVertices> sorted(out.size());
  for (size_t i = 0; i < keyed.size(); ++i) sorted[i] = out[keyed[i].second];
  return sorted;
}

}  // namespace tetrascope
