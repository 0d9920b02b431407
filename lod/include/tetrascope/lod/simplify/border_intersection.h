// The border of a tetrahedral mesh (its faces used by one tet) and whether it intersects
// itself (dissertation §4.2.1): `tetrascope error` reports it; the sampling simplifier keeps
// its simplified border free of intersections with the same tests.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::lod {

// Faces of `mesh` that belong to one tet only, oriented outwards (for positively oriented
// tets). Faces used by three or more tets (a non-conforming mesh) are not border faces.
std::vector<std::array<uint32_t, 3>> border_triangles(const storage::TetMesh& mesh);

struct BorderIntersections {
  uint64_t border_triangles = 0;
  std::vector<std::array<uint32_t, 2>> pairs;  // intersecting border triangles (indices into border_triangles())
  bool truncated = false;                      // the search stopped at the limit
};

// Pairs of border triangles that meet other than along their shared vertices and edges, up
// to `limit` pairs. Box-box rejection in a vertex octree, then exact triangle tests.
BorderIntersections border_self_intersections(const storage::TetMesh& mesh, size_t limit = 1000);

}  // namespace tetrascope::lod
