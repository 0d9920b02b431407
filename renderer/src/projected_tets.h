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

// One tet's thick vertex, as the projected-tetrahedra vertex shader reads it (32 bytes).
struct ThickVertex {
  float x = 0, y = 0, z = 0;  // where the ray enters the tet
  uint32_t corners = 0;       // the boundary p0..p3 as tet corners, 2 bits each from bit 0
  float front = 0, back = 0;  // values at entry and exit, over the transfer function's range (0..1 inside)
  float thickness = 0;        // length of the ray inside the tet
  float pad = 0;
};
static_assert(sizeof(ThickVertex) == 32);

// Tet `tet` of `mesh` seen from `frame`; values normalised as (v - lo) * inv_span. The frame's
// eye must be in front of every corner (perspective): the renderer draws tets that reach the
// near plane with the exact method.
ThickVertex classify_tet(const SceneMesh& mesh, uint32_t tet, const Frame& frame, double lo, double inv_span);

// classify_tet for every tet of `order`, into `out` (resized), on `threads` threads.
void classify_tets(const SceneMesh& mesh, std::span<const uint32_t> order, const Frame& frame, double lo, double inv_span, unsigned threads,
                   std::vector<ThickVertex>& out);

}  // namespace tetrascope::renderer
