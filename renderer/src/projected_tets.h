// Shirley-Tuchman projected tetrahedra, the CPU half: each tet's projection classified and
// split into triangles around one thick vertex. The renderer draws every tet as a fan of 4
// triangles (thick, p0, p1), (thick, p1, p2), (thick, p2, p3), (thick, p3, p0) over its
// projection's boundary p0..p3 (tet corners); a tet whose projection is a triangle (one
// corner projects inside the other three's) repeats p2 as p3, which makes the third triangle
// empty. The thick vertex lies where the ray through the projection's inner point enters the
// tet, and carries the values where that ray enters and leaves the tet and the length between,
// so that the triangles are the tet's front surface and every attribute the fragments need is
// linear across each triangle.
// Shirley, Tuchman, "A polygonal approximation to direct scalar volume rendering" (1990).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "camera_math.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

// One vertex of a tet's fan, as the projected-tetrahedra vertex shader reads it (28 bytes):
// classify_tet writes 5 a tet, its boundary p0..p3 (thickness 0, front and back its value)
// then its thick vertex.
struct ProjectedVertex {
  float x = 0, y = 0, z = 0;  // the thick vertex: where the ray enters the tet
  float front = 0, back = 0;  // values at entry and exit, over the transfer function's range (0..1 inside)
  float thickness = 0;        // length of the ray inside the tet
  float light = 1;            // isosurfaces' shading in this tet, 0.25 + 0.75 |cos| of the gradient and the ray (thick vertex only)
};
static_assert(sizeof(ProjectedVertex) == 28);
constexpr int kVerticesPerTet = 5;

// Tet `tet` of `mesh` seen from `frame`: writes its 5 vertices to `out`; values normalised as
// (v - lo) * inv_span; with `light`, the isosurfaces' shading. The frame's eye must be in front
// of every corner (perspective): the renderer draws tets that reach the near plane with the
// exact method.
void classify_tet(const SceneMesh& mesh, uint32_t tet, const Frame& frame, double lo, double inv_span, bool light, ProjectedVertex* out);

// classify_tet for every tet of `order`, into out[5 * i...], on `threads` threads.
void classify_tets(const SceneMesh& mesh, std::span<const uint32_t> order, const Frame& frame, double lo, double inv_span, bool light, unsigned threads,
                   ProjectedVertex* out);

}  // namespace tetrascope::renderer
