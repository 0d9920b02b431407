// Triangle-triangle intersection after [GBK03] (edge-triangle tests on exact orientation
// predicates) and the vertex octree with regions of influence of dissertation §4.2.1.
#include "border_intersection.h"
#include "simplify_sample.h"

#define TETLIBRARY
#include <tetgen.h>

#include <algorithm>
#include <cmath>
#include <mutex>

#include "tetrascope/lod/simplify/border_intersection.h"

// Shewchuk's adaptive exact predicate, compiled into libtet but not declared by tetgen.h: its
// sign is exact, and it stops at the first stage whose error bound settles it (the full
// expansion, orient3dexact, cost most of the border phase on curved borders)
REAL orient3dadapt(REAL* pa, REAL* pb, REAL* pc, REAL* pd, REAL permanent);

namespace tetrascope::lod {
namespace detail {
namespace {

std::once_flag predicates_ready;

// Shewchuk's orient3d error bound for the plain double evaluation.
constexpr double kOrientBound = (7.0 + 56.0 * 1.1102230246251565e-16) * 1.1102230246251565e-16;

int sign_of(double v) { return (v > 0) - (v < 0); }

// 2D orientation after dropping axis `drop`.
double orient2d(const Point3& a, const Point3& b, const Point3& c, int drop) {
  const int i = drop == 0 ? 1 : 0, j = drop == 2 ? 1 : 2;
  return (b[i] - a[i]) * (c[j] - a[j]) - (b[j] - a[j]) * (c[i] - a[i]);
}

int dominant_axis(const Point3& a, const Point3& b, const Point3& c) {
  const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  const double n[3] = {std::abs(uy * vz - uz * vy), std::abs(uz * vx - ux * vz), std::abs(ux * vy - uy * vx)};
  return n[0] >= n[1] && n[0] >= n[2] ? 0 : (n[1] >= n[2] ? 1 : 2);
}

bool segments_cross_2d(const Point3& p, const Point3& q, const Point3& a, const Point3& b, int drop) {
  const int s1 = sign_of(orient2d(p, q, a, drop)), s2 = sign_of(orient2d(p, q, b, drop));
  const int s3 = sign_of(orient2d(a, b, p, drop)), s4 = sign_of(orient2d(a, b, q, drop));
  if (s1 * s2 > 0 || s3 * s4 > 0) return false;
  if (s1 == 0 && s2 == 0) {  // collinear: overlap of the projections
    const int i = drop == 0 ? 1 : 0, j = drop == 2 ? 1 : 2;
    for (int k : {i, j}) {
      const double lo1 = std::min(p[k], q[k]), hi1 = std::max(p[k], q[k]), lo2 = std::min(a[k], b[k]), hi2 = std::max(a[k], b[k]);
      if (hi1 < lo2 || hi2 < lo1) return false;
    }
  }
  return true;
}

bool point_in_triangle_2d(const Point3& p, const Point3& a, const Point3& b, const Point3& c, int drop) {
  const int s1 = sign_of(orient2d(a, b, p, drop)), s2 = sign_of(orient2d(b, c, p, drop)), s3 = sign_of(orient2d(c, a, p, drop));
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

// Does the closed segment pq meet the closed triangle abc?
bool segment_meets_triangle(const Point3& p, const Point3& q, const Point3& a, const Point3& b, const Point3& c) {
  const int s1 = orient3d_sign(a, b, c, p), s2 = orient3d_sign(a, b, c, q);
  if (s1 * s2 > 0) return false;
  if (s1 == 0 && s2 == 0) {  // coplanar
    const int drop = dominant_axis(a, b, c);
    if (point_in_triangle_2d(p, a, b, c, drop) || point_in_triangle_2d(q, a, b, c, drop)) return true;
    return segments_cross_2d(p, q, a, b, drop) || segments_cross_2d(p, q, b, c, drop) || segments_cross_2d(p, q, c, a, drop);
  }
  const int t1 = orient3d_sign(p, q, a, b), t2 = orient3d_sign(p, q, b, c), t3 = orient3d_sign(p, q, c, a);
  return (t1 >= 0 && t2 >= 0 && t3 >= 0) || (t1 <= 0 && t2 <= 0 && t3 <= 0);
}

}  // namespace

int orient3d_sign(const Point3& a, const Point3& b, const Point3& c, const Point3& d) {
  const double adx = a[0] - d[0], bdx = b[0] - d[0], cdx = c[0] - d[0];
  const double ady = a[1] - d[1], bdy = b[1] - d[1], cdy = c[1] - d[1];
  const double adz = a[2] - d[2], bdz = b[2] - d[2], cdz = c[2] - d[2];
  const double bc = bdy * cdz - bdz * cdy, ca = cdy * adz - cdz * ady, ab = ady * bdz - adz * bdy;
  const double det = adx * bc + bdx * ca + cdx * ab;
  const double permanent = std::abs(adx) * (std::abs(bdy * cdz) + std::abs(bdz * cdy)) + std::abs(bdx) * (std::abs(cdy * adz) + std::abs(cdz * ady)) +
                           std::abs(cdx) * (std::abs(ady * bdz) + std::abs(adz * bdy));
  if (std::abs(det) > kOrientBound * permanent) return sign_of(det);
  // four points in one axis-aligned plane (a box's faces, symmetry planes): a zero row, so the
  // determinant is exactly 0 (the exact expansion would only confirm it, at many times the cost)
  if ((adx == 0 && bdx == 0 && cdx == 0) || (ady == 0 && bdy == 0 && cdy == 0) || (adz == 0 && bdz == 0 && cdz == 0)) return 0;
  // the exact predicate needs TetGen's machine constants (the same values in every thread)
  std::call_once(predicates_ready, [] { exactinit(0, 0, 1, 1.0, 1.0, 1.0); });
  Point3 pa = a, pb = b, pc = c, pd = d;
  return sign_of(orient3dadapt(pa.data(), pb.data(), pc.data(), pd.data(), permanent));
}

bool triangles_intersect(const std::array<Point3, 3>& t, const std::array<Point3, 3>& u) {
  for (int e = 0; e < 3; ++e)
    if (segment_meets_triangle(t[e], t[(e + 1) % 3], u[0], u[1], u[2])) return true;
  for (int e = 0; e < 3; ++e)
    if (segment_meets_triangle(u[e], u[(e + 1) % 3], t[0], t[1], t[2])) return true;
  return false;
}

bool triangles_intersect_sharing_vertex(const std::array<Point3, 3>& t, int t_shared, const std::array<Point3, 3>& u, int u_shared) {
  if (segment_meets_triangle(t[(t_shared + 1) % 3], t[(t_shared + 2) % 3], u[0], u[1], u[2])) return true;
  return segment_meets_triangle(u[(u_shared + 1) % 3], u[(u_shared + 2) % 3], t[0], t[1], t[2]);
}

void RegionOctree::build(const std::vector<Point3>& positions, const std::vector<Box3>& regions, const std::vector<uint8_t>& alive) {
  nodes_.clear();
  regions_ = regions;
  positions_ = positions;
  leaf_of_.assign(positions.size(), kNoNode);
  Box3 cell;
  for (size_t v = 0; v < positions.size(); ++v)
    if (alive.empty() || alive[v]) cell.add(positions[v]);
  if (cell.lo[0] > cell.hi[0]) return;
  double extent = 0;
  for (int k = 0; k < 3; ++k) extent = std::max(extent, cell.hi[k] - cell.lo[k]);
  for (int k = 0; k < 3; ++k) {  // a cube, slightly enlarged
    const double mid = 0.5 * (cell.lo[k] + cell.hi[k]);
    cell.lo[k] = mid - 0.505 * extent - 1e-30;
    cell.hi[k] = mid + 0.505 * extent + 1e-30;
  }
  nodes_.push_back(Node{cell, Box3{}, kNoNode, kNoNode, {}});
  for (uint32_t v = 0; v < positions.size(); ++v)
    if (alive.empty() || alive[v]) insert(v, positions[v], 24);
  // node boxes bottom-up (children always follow their parent)
  for (size_t n = nodes_.size(); n-- > 0;) {
    Node& node = nodes_[n];
    for (uint32_t v : node.vertices) node.box.add(regions_[v]);
    if (node.parent != kNoNode) nodes_[node.parent].box.add(node.box);
  }
}

void RegionOctree::insert(uint32_t vertex, const Point3& p, int depth_limit) {
  uint32_t n = 0;
  int depth = 0;
  for (;;) {
    if (nodes_[n].first_child == kNoNode) {
      if (nodes_[n].vertices.size() < kLeafCapacity || depth >= depth_limit) break;
      // split the leaf at its mid-point and spread its vertices
      const uint32_t first = static_cast<uint32_t>(nodes_.size());
      const Box3 cell = nodes_[n].cell;
      for (uint32_t c = 0; c < 8; ++c) {
        Box3 child;
        for (int k = 0; k < 3; ++k) {
          const double mid = 0.5 * (cell.lo[k] + cell.hi[k]);
          child.lo[k] = (c >> k) & 1 ? mid : cell.lo[k];
          child.hi[k] = (c >> k) & 1 ? cell.hi[k] : mid;
        }
        nodes_.push_back(Node{child, Box3{}, n, kNoNode, {}});
      }
      nodes_[n].first_child = first;
      std::vector<uint32_t> moving;
      moving.swap(nodes_[n].vertices);
      for (uint32_t w : moving) {
        uint32_t octant = 0;
        for (int k = 0; k < 3; ++k)
          if (positions_[w][k] >= 0.5 * (cell.lo[k] + cell.hi[k])) octant |= 1u << k;
        nodes_[first + octant].vertices.push_back(w);
        leaf_of_[w] = first + octant;
      }
    }
    if (nodes_[n].first_child == kNoNode) break;
    uint32_t octant = 0;
    for (int k = 0; k < 3; ++k)
      if (p[k] >= 0.5 * (nodes_[n].cell.lo[k] + nodes_[n].cell.hi[k])) octant |= 1u << k;
    n = nodes_[n].first_child + octant;
    ++depth;
  }
  nodes_[n].vertices.push_back(vertex);
  leaf_of_[vertex] = n;
}

void RegionOctree::remove(uint32_t vertex) {
  const uint32_t n = leaf_of_[vertex];
  if (n == kNoNode) return;
  auto& list = nodes_[n].vertices;
  auto it = std::find(list.begin(), list.end(), vertex);
  if (it != list.end()) {
    *it = list.back();
    list.pop_back();
  }
  leaf_of_[vertex] = kNoNode;
}

void RegionOctree::grow(uint32_t vertex, const Box3& region) {
  regions_[vertex] = region;
  for (uint32_t n = leaf_of_[vertex]; n != kNoNode; n = nodes_[n].parent) {
    if (nodes_[n].box.contains(region)) break;
    nodes_[n].box.add(region);
  }
}

bool triangle_pair_intersects(const std::vector<Point3>& positions, const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b) {
  int shared = 0, ta = 0, ub = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) {
        ++shared;
        ta = i;
        ub = j;
      }
  const std::array<Point3, 3> t{positions[a[0]], positions[a[1]], positions[a[2]]};
  const std::array<Point3, 3> u{positions[b[0]], positions[b[1]], positions[b[2]]};
  if (shared == 0) return triangles_intersect(t, u);
  if (shared == 1) return triangles_intersect_sharing_vertex(t, ta, u, ub);
  if (shared == 3) return true;  // the same triangle twice
  // sharing an edge: a fold when coplanar with the opposite vertices on one side of the edge
  int oa = 0, ob = 0;
  for (int i = 0; i < 3; ++i) {
    if (a[i] != b[0] && a[i] != b[1] && a[i] != b[2]) oa = i;
    if (b[i] != a[0] && b[i] != a[1] && b[i] != a[2]) ob = i;
  }
  if (orient3d_sign(t[0], t[1], t[2], u[ob]) != 0) return false;
  const Point3& e0 = t[(oa + 1) % 3];
  const Point3& e1 = t[(oa + 2) % 3];
  const int drop = dominant_axis(t[0], t[1], t[2]);
  return sign_of(orient2d(e0, e1, t[oa], drop)) * sign_of(orient2d(e0, e1, u[ob], drop)) > 0;
}

std::vector<std::array<uint32_t, 2>> self_intersections(const std::vector<Point3>& positions, const std::vector<std::array<uint32_t, 3>>& triangles,
                                                        size_t limit) {
  std::vector<std::array<uint32_t, 2>> found;
  const size_t nv = positions.size();
  std::vector<uint32_t> start(nv + 1, 0), star(3 * triangles.size());
  for (const auto& t : triangles)
    for (uint32_t v : t) ++start[v + 1];
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t i = 0; i < triangles.size(); ++i)
      for (uint32_t v : triangles[i]) star[fill[v]++] = i;
  }
  std::vector<Box3> triangle_box(triangles.size()), region(nv);
  std::vector<uint8_t> used(nv, 0);
  for (uint32_t i = 0; i < triangles.size(); ++i) {
    for (uint32_t v : triangles[i]) triangle_box[i].add(positions[v]);
    for (uint32_t v : triangles[i]) {
      region[v].add(triangle_box[i]);
      used[v] = 1;
    }
  }
  RegionOctree octree;
  octree.build(positions, region, used);
  std::vector<uint32_t> seen(triangles.size(), 0xFFFFFFFFu);
  for (uint32_t i = 0; i < triangles.size() && found.size() < limit; ++i) {
    octree.query(triangle_box[i], [&](uint32_t v) {
      for (uint32_t s = start[v]; s < start[v + 1]; ++s) {
        const uint32_t j = star[s];
        if (j <= i || seen[j] == i || found.size() >= limit) continue;
        seen[j] = i;
        if (!triangle_box[i].overlaps(triangle_box[j])) continue;
        const bool hit = triangle_pair_intersects(positions, triangles[i], triangles[j]);
        if (hit) found.push_back({i, j});
      }
    });
  }
  return found;
}

}  // namespace detail

BorderIntersections border_self_intersections(const storage::TetMesh& mesh, size_t limit) {
  BorderIntersections out;
  const std::vector<std::array<uint32_t, 3>> border = border_triangles(mesh);
  out.border_triangles = border.size();
  std::vector<detail::Point3> positions(mesh.vertex_count());
  for (size_t v = 0; v < positions.size(); ++v) positions[v] = {mesh.x[v], mesh.y[v], mesh.z[v]};
  out.pairs = detail::self_intersections(positions, border, limit);
  out.truncated = out.pairs.size() >= limit;
  return out;
}

}  // namespace tetrascope::lod
