// Seeing inside a mesh: clip planes and slice planes as mesh operations on the CPU, before
// drawing, so every draw path (the GL volume, isosurfaces, boundary, wireframe, silhouettes,
// and the CPU reference) sees exactly the clipped geometry with no shader change.
//
//  - clip: each tet is cut by the kept half-spaces (n.x <= d) into the kept polyhedron,
//    re-tetrahedralised with the values interpolated on the cut edges. The cut is conforming
//    (cut vertices are shared by the tets around an edge and prisms are split by the
//    smallest-id rule), so the clipped mesh's boundary is the old boundary inside the kept
//    region plus the cut face: the surface mode caps the cut, coloured by the attribute.
//    With `crinkle`, whole tets touching the kept side of every plane are kept instead.
//  - slice: the exact cross-section of the tets with a plane (marching tets on the signed
//    distance), triangles carrying the attribute, and optionally the polygon edges.
//
// Planes (view/planes.h) arrive checked (protocol::parse_clip_spec / parse_slice_spec / parse_plane_text):
// unit, finite normals. Nothing here throws on their account.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "tetrascope/view/planes.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh.h"

namespace tetrascope::renderer {

// A tet mesh reduced to what clipping needs: interleaved positions, tets, and `width` floats
// of per-vertex data (any attributes, concatenated) that are interpolated on cut edges.
struct ClipMesh {
  std::vector<float> xyz;
  std::vector<uint32_t> tets;
  std::vector<float> data;  // width per vertex
  uint32_t width = 0;
};

// The part of `mesh` on the kept side of every half-space of `spec` (crinkle: the tets that
// touch it), with unused vertices dropped. Tets stay positively oriented when they were.
ClipMesh clip_tets(ClipMesh mesh, const view::ClipSpec& spec);

// The clipped scene: value range, bounds, diagonal and longest edge are the source's, so
// colours, opacity per unit length and the camera's planes do not move with the planes.
SceneMesh clip_scene(const SceneMesh& scene, const view::ClipSpec& spec);
// The clipped mesh with all its attributes (`tetrascope cut --clip`).
storage::TetMesh clip_mesh(const storage::TetMesh& mesh, const view::ClipSpec& spec);

// The cross-section of `scene` with `plane`: triangles as (x, y, z, value) corners (12 floats
// a triangle), and with `edges` the sides of every tet's section polygon as (x, y, z, 0) line
// corners (8 floats a segment). A face lying in the plane is emitted once.
void slice_scene(const SceneMesh& scene, const view::Plane& plane, std::vector<float>& triangles, std::vector<float>* edges);

// Total area of (x, y, z, value) triangles (tests, checks).
double triangles_area(std::span<const float> triangles);

}  // namespace tetrascope::renderer
