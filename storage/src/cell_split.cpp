// Hybrid cells to tetrahedra without Steiner points, conforming across cells.
//
// Every quadrilateral face is split by the diagonal through its vertex of smallest global
// id (the rule of Dompierre, Labbe, Vallet and Camarero, "How to subdivide pyramids, prisms
// and hexahedra into tetrahedra", IMR 1999), so the two cells that share a face always agree.
// We realise it by coning from the cell's smallest vertex v0: every face that does not hold
// v0 is triangulated by the rule and joined to v0. A face that holds v0 is then split through
// v0, which is also its smallest vertex, so the rule holds on every face. For a convex cell
// this gives 6 tets for a hexahedron, 3 for a wedge and 2 for a pyramid.
#include "cell_split.h"

#include <array>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

struct Face {
  int size;
  std::array<int, 4> v;
};

constexpr std::array<Face, 6> kHexFaces{{
    {4, {0, 3, 2, 1}}, {4, {4, 5, 6, 7}}, {4, {0, 1, 5, 4}},
    {4, {1, 2, 6, 5}}, {4, {2, 3, 7, 6}}, {4, {3, 0, 4, 7}},
}};
constexpr std::array<Face, 5> kWedgeFaces{{
    {3, {0, 1, 2, 0}}, {3, {3, 5, 4, 0}}, {4, {0, 3, 4, 1}}, {4, {1, 4, 5, 2}}, {4, {2, 5, 3, 0}},
}};
constexpr std::array<Face, 5> kPyramidFaces{{
    {4, {0, 3, 2, 1}}, {3, {0, 1, 4, 0}}, {3, {1, 2, 4, 0}}, {3, {2, 3, 4, 0}}, {3, {3, 0, 4, 0}},
}};

template <size_t N>
size_t cone(const std::array<Face, N>& faces, std::span<const uint32_t> c, uint32_t* out) {
  int apex = 0;
  for (int i = 1; i < static_cast<int>(c.size()); ++i) {
    if (c[i] < c[apex]) apex = i;
  }
  size_t tets = 0;
  auto emit = [&](int a, int b, int d) {
    uint32_t* t = out + 4 * tets++;
    t[0] = c[apex];
    t[1] = c[a];
    t[2] = c[b];
    t[3] = c[d];
  };
  for (const Face& f : faces) {
    bool holds_apex = false;
    for (int k = 0; k < f.size; ++k) holds_apex |= f.v[k] == apex;
    if (holds_apex) continue;
    if (f.size == 3) {
      emit(f.v[0], f.v[1], f.v[2]);
      continue;
    }
    int smallest = 0;
    for (int k = 1; k < 4; ++k) {
      if (c[f.v[k]] < c[f.v[smallest]]) smallest = k;
    }
    int a = f.v[smallest], b = f.v[(smallest + 1) % 4], d = f.v[(smallest + 2) % 4], e = f.v[(smallest + 3) % 4];
    emit(a, b, d);
    emit(a, d, e);
  }
  return tets;
}

}  // namespace

size_t split_cell(int type, std::span<const uint32_t> c, uint32_t* out) {
  switch (type) {
    case kVtkTetra:
      for (int i = 0; i < 4; ++i) out[i] = c[i];
      return 1;
    case kVtkVoxel: {
      const std::array<uint32_t, 8> hex{c[0], c[1], c[3], c[2], c[4], c[5], c[7], c[6]};
      return cone(kHexFaces, hex, out);
    }
    case kVtkHexahedron: return cone(kHexFaces, c.first(8), out);
    case kVtkWedge: return cone(kWedgeFaces, c.first(6), out);
    case kVtkPyramid: return cone(kPyramidFaces, c.first(5), out);
    default: return 0;
  }
}

}  // namespace tetrascope::storage::detail
