// CPU geometry the GL renderer uploads or draws: per-tet planes and linear fields, the
// boundary surface and its edges, silhouettes and the bounding box as line lists. No GL here:
// these are computed once per mesh (or per frame for view-dependent lines) and then uploaded.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "camera_math.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

// Per tet, five vec4 (20 floats): its four outward unit face planes (n, -n.p) in kTetFace
// order, then its linear field (gradient, offset) in attribute units.
constexpr size_t kFloatsPerTetCell = 20;
std::vector<float> tet_cells(const SceneMesh& mesh);

// Per tet: centroid (3 floats), the radius of the sphere about it through the farthest vertex,
// and the range of its vertex values (2 floats): the sort and skip inputs of the volume pass.
struct TetSortInputs {
  std::vector<float> centroid, radius, range;
};
TetSortInputs tet_sort_inputs(const SceneMesh& mesh);

// The 12 face-corner indices of each of `slots` tet slots: slot i's corners index vertices
// 4i..4i+3, so a vertex cache runs 4 vertex shaders a tet, not 12.
std::vector<uint32_t> tet_corner_indices(uint32_t slots);

// The 12 indices of each of `slots` projected-tetrahedra fans (projected_tets.h): slot i's
// vertices are 5i..5i+3 (its boundary) and 5i+4 (its thick vertex).
std::vector<uint32_t> projected_fan_indices(uint32_t slots);

// Boundary triangles as (x, y, z, value) corners, and every boundary edge with the one or two
// boundary faces that share it (kNoOppositeFace where open).
struct BoundaryGeometry {
  std::vector<float> corners;
  std::vector<std::array<uint32_t, 4>> edges;  // vertex a, vertex b, face, face
};
BoundaryGeometry boundary_geometry(const SceneMesh& mesh);

// Appends (x, y, z, 0) line corners: the silhouette edges of the boundary as seen from
// `frame` (and open edges), or every boundary edge with `all_edges` (a wireframe). Faces
// marked in `hidden` (per boundary face; empty: none) are left out: an edge of a shown face
// next to a hidden one is an open edge.
void append_boundary_edges(const SceneMesh& mesh, const BoundaryGeometry& boundary, const Frame& frame, bool all_edges, std::vector<float>& lines,
                           const std::vector<uint8_t>& hidden = {});

// Appends the 12 edges of the mesh's bounding box as (x, y, z, 0) line corners.
void append_box_edges(const storage::Bounds& bounds, std::vector<float>& lines);

}  // namespace tetrascope::renderer
