// The sampling simplifier's parts, private to lod/ (the API is simplify_sampled in simplify.h):
//   simplify_sample_border.cpp  the border triangles and their intersection-free half-edge
//                               collapses on quadrics (§4.2.1)
//   simplify_sample.cpp         octree point sampling (§4.2.2), TetGen (§4.2.3), Steiner values
//   simplify_sample_fit.cpp     the output's vertex values by least squares
//   border_intersection.cpp     the triangle tests and the vertex octree of regions
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "border_intersection.h"
#include "tetrascope/storage/mesh.h"

namespace tetrascope::lod::detail {

struct BorderSimplifyResult {
  std::vector<std::array<uint32_t, 3>> triangles;  // the simplified border (input vertex ids)
  uint64_t collapses = 0, refused_topology = 0, refused_geometry = 0, refused_intersection = 0;
};

// The attributes the border's collapses weigh: per vertex `channels` normalised values; a
// collapse q -> p costs its quadric distance plus (weight |a_q - a_p|)^2.
struct BorderField {
  const float* values = nullptr;
  size_t channels = 0;
  double weight = 0;
  // collapses costing at most this (squared, the cost's units) go on past the target: a flat
  // border of even values keeps no more vertices than it needs, whatever the target's share
  double free_cost = 0;
};

// Half-edge collapses q -> p over `triangles` (a closed, intersection-free surface over
// `positions`), cheapest quadric first, until `target_triangles` or until the next collapse
// would move the border farther than `max_distance`. A vertex with locked[v] is never
// removed; a vertex on a non-manifold edge or with a non-disk star is never removed either.
// A collapse is refused when it would fold a triangle, break the link condition, or make the
// surface intersect itself (regions of influence in an octree, then exact tests).
BorderSimplifyResult simplify_border(const std::vector<Point3>& positions, const std::vector<std::array<uint32_t, 3>>& triangles,
                                     const std::vector<uint8_t>& locked, uint64_t target_triangles, double max_distance,
                                     const BorderField& field = {});

// Do the triangles a and b (vertex ids into positions) meet other than along shared vertices
// and edges? Sharing an edge: a coplanar fold. Sharing three vertices: always.
bool triangle_pair_intersects(const std::vector<Point3>& positions, const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b);

// The output's values of attributes (not tensors) fitted by least squares to the input's at
// its vertices (simplify_sample_fit.cpp): out's linear interpolant at each input vertex against
// that vertex's value, with source_vertex (per output vertex: the input vertex it is, or
// 0xFFFFFFFF) naming the exact matches. Output vertices with fixed[v] keep their values; the
// others stay in each scalar's input range. Returns the conjugate-gradient iterations taken.
uint64_t fit_values(const storage::TetMesh& input, storage::TetMesh& out, const std::vector<uint32_t>& source_vertex, const std::vector<uint8_t>& fixed);

}  // namespace tetrascope::lod::detail
