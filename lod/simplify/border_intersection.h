// Self-intersection tests for triangle meshes (the border of a tetrahedral mesh), private to
// lod/: the intersection-free border simplification of dissertation §4.2.1 and the check of
// `tetrascope error` (border_intersection.h in include/ is the public side).
//   - triangle-triangle tests on orientation predicates (a float filter, then Shewchuk's exact
//     orient3d from TetGen's predicates) after [GBK03]: a pair with no shared vertex
//     intersects when an edge of one meets the other; a pair sharing one vertex when an
//     edge opposite the shared vertex meets the other triangle.
//   - a vertex octree whose nodes carry the union of their vertices' regions of influence
//     (axis-aligned boxes), so that a query box rejects most triangles by box-box tests.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tetrascope::lod::detail {

using Point3 = std::array<double, 3>;

struct Box3 {
  Point3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  void add(const Point3& p) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = lo[k] < p[k] ? lo[k] : p[k];
      hi[k] = hi[k] > p[k] ? hi[k] : p[k];
    }
  }
  void add(const Box3& b) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = lo[k] < b.lo[k] ? lo[k] : b.lo[k];
      hi[k] = hi[k] > b.hi[k] ? hi[k] : b.hi[k];
    }
  }
  bool overlaps(const Box3& b) const {
    for (int k = 0; k < 3; ++k)
      if (lo[k] > b.hi[k] || b.lo[k] > hi[k]) return false;
    return true;
  }
  bool contains(const Box3& b) const {
    for (int k = 0; k < 3; ++k)
      if (b.lo[k] < lo[k] || b.hi[k] > hi[k]) return false;
    return true;
  }
};

// Sign of the orientation of d against the plane abc (exact: filtered, then exact arithmetic).
int orient3d_sign(const Point3& a, const Point3& b, const Point3& c, const Point3& d);

// Do the closed triangles t = (a0, a1, a2) and u = (b0, b1, b2) meet anywhere they should not?
// `shared` vertices (0, 1 or 2, by index) are allowed to touch: pass their count and which
// corners they are. Triangles sharing two vertices (an edge) are not tested here: folds across
// an edge are the simplifier's normal check.
bool triangles_intersect(const std::array<Point3, 3>& t, const std::array<Point3, 3>& u);
bool triangles_intersect_sharing_vertex(const std::array<Point3, 3>& t, int t_shared, const std::array<Point3, 3>& u, int u_shared);

// The octree of vertices with regions of influence. Vertices are inserted once (by their
// position); a vertex may be removed and its box may grow; node boxes only grow.
class RegionOctree {
 public:
  static constexpr uint32_t kLeafCapacity = 10;  // a leaf splits past this many vertices (§4.2.1)
  void build(const std::vector<Point3>& positions, const std::vector<Box3>& regions, const std::vector<uint8_t>& alive);
  void remove(uint32_t vertex);
  // vertex's region becomes `region` (its position unchanged); the boxes of its leaf's ancestors grow to hold it
  void grow(uint32_t vertex, const Box3& region);
  // Calls visit(vertex) for every vertex whose region overlaps `query`.
  template <class Visit>
  void query(const Box3& query, Visit&& visit) const {
    if (nodes_.empty()) return;
    stack_.clear();
    stack_.push_back(0);
    while (!stack_.empty()) {
      const uint32_t n = stack_.back();
      stack_.pop_back();
      const Node& node = nodes_[n];
      if (!node.box.overlaps(query)) continue;
      if (node.first_child != kNoNode) {
        for (uint32_t c = 0; c < 8; ++c) stack_.push_back(node.first_child + c);
        continue;
      }
      for (uint32_t v : node.vertices)
        if (regions_[v].overlaps(query)) visit(v);
    }
  }
  const Box3& region(uint32_t vertex) const { return regions_[vertex]; }

 private:
  static constexpr uint32_t kNoNode = 0xFFFFFFFFu;
  struct Node {
    Box3 cell;  // the octree cell
    Box3 box;   // union of the regions of the vertices below
    uint32_t parent = kNoNode, first_child = kNoNode;
    std::vector<uint32_t> vertices;
  };
  void insert(uint32_t vertex, const Point3& p, int depth_limit);
  std::vector<Node> nodes_;
  std::vector<Box3> regions_;
  std::vector<Point3> positions_;
  std::vector<uint32_t> leaf_of_;
  mutable std::vector<uint32_t> stack_;
};

// Pairs of triangles of `triangles` (vertex ids into positions) that intersect, up to
// `limit` of them (each pair once). Triangles sharing an edge are checked for a fold (the two
// opposite vertices on the same side, coplanar overlap); sharing a vertex or nothing by the
// tests above.
std::vector<std::array<uint32_t, 2>> self_intersections(const std::vector<Point3>& positions, const std::vector<std::array<uint32_t, 3>>& triangles,
                                                        size_t limit);

}  // namespace tetrascope::lod::detail
