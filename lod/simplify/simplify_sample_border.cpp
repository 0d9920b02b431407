// Intersection-free border simplification, dissertation §4.2.1: quadric edge collapses on the
// border triangle mesh [GH97], each checked against the triangles whose regions of influence
// (boxes) meet the collapse's region, found through a vertex octree. Collapses are half-edge
// (q onto p): kept vertices keep their exact positions and values, so a locked border stays
// bit-identical and no new border vertex needs values.
#include <algorithm>
#include <cmath>
#include <queue>

#include "simplify_sample.h"
#include "tetrascope/lod/simplify/border_intersection.h"

namespace tetrascope::lod {

std::vector<std::array<uint32_t, 3>> border_triangles(const storage::TetMesh& mesh) {
  // a face is on the border when no other tet holds it (§4.2.4 uses a hash table of faces;
  // here the faces are bucketed by their lowest vertex and sorted within the bucket)
  const size_t nv = mesh.vertex_count(), nt = mesh.tet_count();
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};  // outward, opposite corner k
  std::vector<uint32_t> start(nv + 1, 0);
  for (size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k) {
      const uint32_t* v = &mesh.tets[4 * t];
      ++start[std::min({v[kFace[k][0]], v[kFace[k][1]], v[kFace[k][2]]}) + 1];
    }
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  struct Face {
    uint64_t key;  // the other two vertices, lower first
    uint32_t slot; // 4 * tet + corner
  };
  std::vector<Face> faces(4 * nt);
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t t = 0; t < nt; ++t)
      for (int k = 0; k < 4; ++k) {
        const uint32_t* v = &mesh.tets[4 * size_t{t}];
        uint32_t f[3] = {v[kFace[k][0]], v[kFace[k][1]], v[kFace[k][2]]};
        std::sort(f, f + 3);
        faces[fill[f[0]]++] = {uint64_t{f[1]} << 32 | f[2], 4 * t + k};
      }
  }
  std::vector<std::array<uint32_t, 3>> out;
  for (size_t v = 0; v < nv; ++v) {
    auto first = faces.begin() + start[v], last = faces.begin() + start[v + 1];
    std::sort(first, last, [](const Face& a, const Face& b) { return a.key < b.key; });
    for (auto it = first; it != last;) {
      auto next = it + 1;
      while (next != last && next->key == it->key) ++next;
      if (next - it == 1) {
        const uint32_t* tet = &mesh.tets[4 * size_t{it->slot / 4}];
        const int k = static_cast<int>(it->slot % 4);
        out.push_back({tet[kFace[k][0]], tet[kFace[k][1]], tet[kFace[k][2]]});
      }
      it = next;
    }
  }
  return out;
}

namespace detail {
namespace {

using Quadric = std::array<double, 10>;  // symmetric 4x4: a2 ab ac ad b2 bc bd c2 cd d2

double evaluate(const Quadric& q, const Point3& p) {
  const double x = p[0], y = p[1], z = p[2];
  return q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x + q[4] * y * y + 2 * q[5] * y * z + 2 * q[6] * y + q[7] * z * z +
         2 * q[8] * z + q[9];
}

Point3 normal_of(const Point3& a, const Point3& b, const Point3& c) {
  const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  return {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
}

double dot(const Point3& a, const Point3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

struct Entry {
  double cost, distance;  // cost: distance plus field term, both squared; distance: the quadric's
  uint32_t q, p, version_q, version_p;
  bool operator>(const Entry& o) const { return cost != o.cost ? cost > o.cost : (q != o.q ? q > o.q : p > o.p); }
};

class BorderSimplifier {
 public:
  BorderSimplifier(const std::vector<Point3>& positions, const std::vector<std::array<uint32_t, 3>>& triangles, const std::vector<uint8_t>& locked,
                   const BorderField& field)
      : positions_(positions), triangles_(triangles), locked_(locked), field_(field) {
    const size_t nv = positions.size();
    star_.resize(nv);
    alive_.assign(triangles.size(), 1);
    used_.assign(nv, 0);
    fixed_.assign(nv, 0);
    version_.assign(nv, 0);
    refused_.assign(nv, {});
    quadric_.assign(nv, Quadric{});
    regions_.assign(nv, Box3{});
    mark_.assign(triangles.size(), 0);
    for (uint32_t t = 0; t < triangles.size(); ++t) {
      const auto& f = triangles[t];
      const Point3 n = normal_of(positions[f[0]], positions[f[1]], positions[f[2]]);
      const double length = std::sqrt(dot(n, n));
      Box3 box;
      for (uint32_t v : f) box.add(positions[v]);
      for (uint32_t v : f) {
        star_[v].push_back(t);
        used_[v] = 1;
        regions_[v].add(box);
      }
      if (length <= 0) continue;
      const double a = n[0] / length, b = n[1] / length, c = n[2] / length, d = -dot({a, b, c}, positions[f[0]]);
      const Quadric k{a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d};
      for (uint32_t v : f)
        for (int i = 0; i < 10; ++i) quadric_[v][i] += k[i];
    }
    // vertices on a non-manifold edge, or whose star is not one disk, stay
    for (uint32_t v = 0; v < nv; ++v) {
      if (!used_[v]) continue;
      if (!locked_.empty() && locked_[v]) {
        fixed_[v] = 1;
        continue;
      }
      std::vector<uint32_t> ring;
      for (uint32_t t : star_[v])
        for (uint32_t w : triangles_[t])
          if (w != v) ring.push_back(w);
      std::sort(ring.begin(), ring.end());
      bool disk = ring.size() == 2 * star_[v].size();
      for (size_t i = 0; disk && i < ring.size(); i += 2) disk = ring[i] == ring[i + 1] && (i + 2 >= ring.size() || ring[i + 2] != ring[i]);
      fixed_[v] = !disk;
    }
    octree_.build(positions_, regions_, used_);
  }

  BorderSimplifyResult run(uint64_t target, double max_distance) {
    alive_count_ = triangles_.size();
    const double max_cost = max_distance * max_distance;
    for (uint32_t v = 0; v < positions_.size(); ++v)
      if (used_[v]) push_edges(v, true, kNoVertex);
    while (!queue_.empty() && (alive_count_ > target || queue_.top().cost <= field_.free_cost)) {
      const Entry e = queue_.top();
      queue_.pop();
      if (e.distance > max_cost) continue;
      if (version_[e.q] != e.version_q || version_[e.p] != e.version_p || !used_[e.q] || !used_[e.p]) continue;
      if (collapse(e.q, e.p)) {
        ++result_.collapses;
        // p's edges have new costs: all of them again, the old entries stale by version. The
        // ring's other edges keep their costs (their quadrics and values did not change), so
        // their entries stay valid; only the ones refused before are pushed again, since the
        // ring's new neighbourhood may let them pass now. (Bumping the ring's versions and
        // pushing every edge again gives the same collapses in the same order, with several
        // times the queue traffic: the queue's pops were half of this phase.)
        ring_of_p_.clear();
        for (uint32_t t : star_[e.p])
          for (uint32_t w : triangles_[t])
            if (w != e.p) ring_of_p_.push_back(w);
        std::sort(ring_of_p_.begin(), ring_of_p_.end());
        ring_of_p_.erase(std::unique(ring_of_p_.begin(), ring_of_p_.end()), ring_of_p_.end());
        ++version_[e.p];
        refused_[e.p].clear();
        refused_[e.q].clear();
        push_edges(e.p, false, kNoVertex);
        for (uint32_t w : ring_of_p_) retry_refused(w);
      } else {
        refused_[e.q].push_back(e.p);
        refused_[e.p].push_back(e.q);
      }
    }
    for (uint32_t t = 0; t < triangles_.size(); ++t)
      if (alive_[t]) result_.triangles.push_back(triangles_[t]);
    return std::move(result_);
  }

 private:
  // the cheaper direction of every edge from v (each edge is pushed from both ends; stale
  // entries are skipped by version)
  // both directions of the edges from v to its neighbours (above v only with `higher_only`;
  // never to `skip`)
  void push_edges(uint32_t v, bool higher_only, uint32_t skip) {
    ring_.clear();
    for (uint32_t t : star_[v])
      for (uint32_t w : triangles_[t])
        if (w != v && w != skip && (!higher_only || w > v)) ring_.push_back(w);
    std::sort(ring_.begin(), ring_.end());
    ring_.erase(std::unique(ring_.begin(), ring_.end()), ring_.end());
    for (uint32_t w : ring_)
      for (auto [q, p] : {std::pair{v, w}, std::pair{w, v}}) push_edge(q, p);
  }

  // the refused collapses of the edges at v, pushed again (both directions; an entry whose
  // edge is gone or whose other end moved is skipped)
  void retry_refused(uint32_t v) {
    retry_.swap(refused_[v]);
    refused_[v].clear();
    std::sort(retry_.begin(), retry_.end());
    retry_.erase(std::unique(retry_.begin(), retry_.end()), retry_.end());
    for (uint32_t w : retry_) {
      if (!used_[w] || !used_[v] || !adjacent(v, w)) continue;
      for (auto [q, p] : {std::pair{v, w}, std::pair{w, v}}) push_edge(q, p);
    }
    retry_.clear();
  }

  bool adjacent(uint32_t v, uint32_t w) const {
    for (uint32_t t : star_[v])
      for (uint32_t x : triangles_[t])
        if (x == w) return true;
    return false;
  }

  void push_edge(uint32_t q, uint32_t p) {
    if (fixed_[q]) return;
    Quadric sum = quadric_[q];
    for (int i = 0; i < 10; ++i) sum[i] += quadric_[p][i];
    const double distance = std::max(0.0, evaluate(sum, positions_[p]));
    double change = 0;  // q's values are dropped for p's
    for (size_t c = 0; c < field_.channels; ++c) {
      const double d = double(field_.values[size_t{q} * field_.channels + c]) - field_.values[size_t{p} * field_.channels + c];
      change += d * d;
    }
    queue_.push({distance + field_.weight * field_.weight * change, distance, q, p, version_[q], version_[p]});
  }

  bool collapse(uint32_t q, uint32_t p) {
    // link condition: p and q share exactly the two opposite vertices of their two triangles
    shared_.clear();
    changed_.clear();
    for (uint32_t t : star_[q]) {
      const auto& f = triangles_[t];
      if (f[0] == p || f[1] == p || f[2] == p) shared_.push_back(t);
      else changed_.push_back(t);
    }
    if (shared_.size() != 2) return refuse(result_.refused_topology);
    std::vector<uint32_t>& ring_q = ring_q_;
    ring_q.clear();
    for (uint32_t t : star_[q])
      for (uint32_t w : triangles_[t])
        if (w != q) ring_q.push_back(w);
    std::sort(ring_q.begin(), ring_q.end());
    ring_q.erase(std::unique(ring_q.begin(), ring_q.end()), ring_q.end());
    int common = 0;
    for (uint32_t t : star_[p])
      for (uint32_t w : triangles_[t])
        if (w != p && w != q && std::binary_search(ring_q.begin(), ring_q.end(), w)) ++common;
    if (common != 4) return refuse(result_.refused_topology);  // each common vertex seen twice around p
    if (changed_.empty()) return refuse(result_.refused_topology);
    // geometry: no triangle flips or degenerates
    new_.clear();
    for (uint32_t t : changed_) {
      std::array<uint32_t, 3> f = triangles_[t];
      const Point3 before = normal_of(positions_[f[0]], positions_[f[1]], positions_[f[2]]);
      for (uint32_t& w : f)
        if (w == q) w = p;
      const Point3 after = normal_of(positions_[f[0]], positions_[f[1]], positions_[f[2]]);
      const double b2 = dot(before, before), a2 = dot(after, after);
      if (!(dot(before, after) > 0.2 * std::sqrt(a2 * b2)) || !(a2 > 1e-6 * b2)) return refuse(result_.refused_geometry);
      new_.push_back(f);
    }
    // intersections: every triangle whose vertex region meets the new triangles' box
    Box3 region;
    new_box_.clear();
    for (const auto& f : new_) {
      Box3 box;
      for (uint32_t w : f) box.add(positions_[w]);
      new_box_.push_back(box);
      region.add(box);
    }
    ++stamp_;
    for (uint32_t t : star_[q]) mark_[t] = stamp_;
    bool hit = false;
    octree_.query(region, [&](uint32_t w) {
      if (hit) return;
      for (uint32_t t : star_[w]) {
        if (mark_[t] == stamp_) continue;
        mark_[t] = stamp_;
        Box3 box;
        for (uint32_t x : triangles_[t]) box.add(positions_[x]);
        if (!box.overlaps(region)) continue;
        for (size_t i = 0; i < new_.size(); ++i)
          if (box.overlaps(new_box_[i]) && triangle_pair_intersects(positions_, new_[i], triangles_[t])) {
            hit = true;
            return;
          }
      }
    });
    for (size_t i = 0; i < new_.size() && !hit; ++i)
      for (size_t j = i + 1; j < new_.size() && !hit; ++j) hit = triangle_pair_intersects(positions_, new_[i], new_[j]);
    if (hit) return refuse(result_.refused_intersection);
    // apply
    for (uint32_t t : shared_) {
      alive_[t] = 0;
      --alive_count_;
      for (uint32_t w : triangles_[t]) {
        auto& s = star_[w];
        s.erase(std::remove(s.begin(), s.end(), t), s.end());
      }
    }
    for (size_t i = 0; i < changed_.size(); ++i) {
      triangles_[changed_[i]] = new_[i];
      star_[p].push_back(changed_[i]);
    }
    star_[q].clear();
    used_[q] = 0;
    for (int i = 0; i < 10; ++i) quadric_[p][i] += quadric_[q][i];
    octree_.remove(q);
    // p's region: the tight box of its triangles now (it holds every triangle around p)
    Box3 tight;
    for (uint32_t t : star_[p])
      for (uint32_t w : triangles_[t]) tight.add(positions_[w]);
    octree_.grow(p, tight);
    return true;
  }

  bool refuse(uint64_t& counter) {
    ++counter;
    return false;
  }

  const std::vector<Point3>& positions_;
  std::vector<std::array<uint32_t, 3>> triangles_;
  const std::vector<uint8_t>& locked_;
  const BorderField& field_;
  std::vector<std::vector<uint32_t>> star_;
  std::vector<std::vector<uint32_t>> refused_;  // per vertex: the other ends of its refused collapses since its last change
  std::vector<uint8_t> alive_, used_, fixed_;
  std::vector<uint32_t> version_, mark_;
  uint32_t stamp_ = 0;
  std::vector<Quadric> quadric_;
  std::vector<Box3> regions_;
  RegionOctree octree_;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue_;
  static constexpr uint32_t kNoVertex = 0xFFFFFFFFu;
  std::vector<uint32_t> shared_, changed_, ring_q_, ring_, ring_of_p_, retry_;
  std::vector<std::array<uint32_t, 3>> new_;
  std::vector<Box3> new_box_;
  uint64_t alive_count_ = 0;
  BorderSimplifyResult result_;
};

}  // namespace

BorderSimplifyResult simplify_border(const std::vector<Point3>& positions, const std::vector<std::array<uint32_t, 3>>& triangles,
                                     const std::vector<uint8_t>& locked, uint64_t target_triangles, double max_distance, const BorderField& field) {
  BorderSimplifier simplifier(positions, triangles, locked, field);
  return simplifier.run(target_triangles, max_distance);
}

}  // namespace detail
}  // namespace tetrascope::lod
