// One edge collapse of the tetrahedral simplifier (simplify.cpp): the link condition with a
// virtual vertex for the boundary (Dey et al., "Topology preserving edge contraction", 1999),
// the borders locked by the multi-triangulation, no flipped or collapsed tets, and the
// attributes at the new position interpolated in the tets around the edge.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "simplifier.h"

namespace tetrascope::lod::detail {

// Lk(p) ∩ Lk(q) = Lk(pq), with a virtual vertex * joined to every boundary face (Dey et al.,
// "Topology preserving edge contraction", 1999). Simplices of Lk(p) that contain q are left
// out of the intersection: a vertex or edge reached only through them lies in Lk(pq) anyway.
// The link is kept as three sorted sets of integer keys (vertices, edges, triangles).
void Simplifier::link_of(Worker& w, uint32_t v, uint32_t other, LinkSets& link, LinkSets* edge_link) {
  link.vertices.clear();
  link.edges.clear();
  link.triangles.clear();
  w.scratch_edges.clear();
  auto edge = [](uint32_t a, uint32_t b) { return a < b ? uint64_t{a} << 32 | b : uint64_t{b} << 32 | a; };
  for (uint32_t t : star_[v]) {
    const uint32_t* tet = &tets_[4 * t];
    std::array<uint32_t, 3> rest{};
    int n = 0;
    bool has_other = false;
    for (int k = 0; k < 4; ++k) {
      if (tet[k] == v) continue;
      has_other |= tet[k] == other;
      rest[n++] = tet[k];
    }
    std::sort(rest.begin(), rest.end());
    if (has_other) {
      if (edge_link) {
        uint32_t e[2], m = 0;
        for (uint32_t u : rest)
          if (u != other) e[m++] = u;
        edge_link->edges.push_back(edge(e[0], e[1]));
        edge_link->vertices.push_back(e[0]);
        edge_link->vertices.push_back(e[1]);
      }
    } else {
      link.triangles.push_back(rest);
    }
    for (int i = 0; i < 3; ++i) {
      if (rest[i] != other) link.vertices.push_back(rest[i]);
      for (int j = i + 1; j < 3; ++j) w.scratch_edges.push_back(edge(rest[i], rest[j]));
    }
  }
  // every face through v is v + an edge of an opposite triangle; it lies on the boundary
  // when that edge is opposite v in one tet only
  std::sort(w.scratch_edges.begin(), w.scratch_edges.end());
  bool boundary = false;
  for (size_t i = 0; i < w.scratch_edges.size();) {
    size_t j = i + 1;
    while (j < w.scratch_edges.size() && w.scratch_edges[j] == w.scratch_edges[i]) ++j;
    const uint32_t a = static_cast<uint32_t>(w.scratch_edges[i] >> 32), b = static_cast<uint32_t>(w.scratch_edges[i]);
    if (a != other && b != other) link.edges.push_back(w.scratch_edges[i]);
    if (j - i == 1) {  // boundary face (v, a, b): virtual triangle (a, b, *)
      boundary = true;
      if (a != other) link.edges.push_back(edge(a, kNone));
      if (b != other) link.edges.push_back(edge(b, kNone));
      if (a != other && b != other) {
        link.triangles.push_back({a, b, kNone});
      } else if (edge_link) {  // boundary face through the edge: (r, *) in Lk(pq)
        const uint32_t r = a == other ? b : a;
        edge_link->edges.push_back(edge(r, kNone));
        edge_link->vertices.push_back(r);
        edge_link->vertices.push_back(kNone);
      }
    }
    i = j;
  }
  if (boundary) link.vertices.push_back(kNone);
  auto unique_sorted = [](auto& x) {
    std::sort(x.begin(), x.end());
    x.erase(std::unique(x.begin(), x.end()), x.end());
  };
  unique_sorted(link.vertices);
  unique_sorted(link.edges);
  unique_sorted(link.triangles);
}

// Would collapsing `gone` onto the locked `keep` turn a boundary face (gone, x, y) with x and y
// locked into a boundary face of locked vertices only? Locked vertices are the borders the
// multi-triangulation shares with neighbouring segments; a neighbour may create the same face
// from its side, and the two segments would then close a gap of the domain between them.
bool Simplifier::creates_locked_boundary_face(Worker& w, uint32_t keep, uint32_t gone) {
  auto& edges = w.scratch_edges;
  edges.clear();
  for (uint32_t t : star_[gone]) {
    const uint32_t* tet = &tets_[4 * t];
    uint32_t rest[3], n = 0;
    for (int k = 0; k < 4; ++k)
      if (tet[k] != gone) rest[n++] = tet[k];
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j) edges.push_back(rest[i] < rest[j] ? uint64_t{rest[i]} << 32 | rest[j] : uint64_t{rest[j]} << 32 | rest[i]);
  }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    const uint32_t a = static_cast<uint32_t>(edges[i] >> 32), b = static_cast<uint32_t>(edges[i]);
    if (j - i == 1 && a != keep && b != keep && locked_[a] && locked_[b]) return true;
    i = j;
  }
  return false;
}

bool Simplifier::link_condition(Worker& w, uint32_t p, uint32_t q) {
  LinkSets& pq = w.link_pq;
  pq.vertices.clear();
  pq.edges.clear();
  link_of(w, p, q, w.link_p, &pq);
  link_of(w, q, p, w.link_q, nullptr);
  std::sort(pq.vertices.begin(), pq.vertices.end());
  std::sort(pq.edges.begin(), pq.edges.end());
  // every common simplex must lie in Lk(pq); Lk(pq) holds no triangles
  auto contained = [](const auto& a, const auto& b, const auto& allowed) {
    for (size_t i = 0, j = 0; i < a.size() && j < b.size();) {
      if (a[i] < b[j]) {
        ++i;
      } else if (b[j] < a[i]) {
        ++j;
      } else {
        if (!std::binary_search(allowed.begin(), allowed.end(), a[i])) return false;
        ++i;
        ++j;
      }
    }
    return true;
  };
  static const std::vector<std::array<uint32_t, 3>> kNoTriangles;
  return contained(w.link_p.vertices, w.link_q.vertices, pq.vertices) && contained(w.link_p.edges, w.link_q.edges, pq.edges) &&
         contained(w.link_p.triangles, w.link_q.triangles, kNoTriangles);
}

bool Simplifier::geometry_ok(uint32_t p, uint32_t q, const double* position) {
  for (uint32_t v : {p, q}) {
    for (uint32_t t : star_[v]) {
      const uint32_t* tet = &tets_[4 * t];
      bool both = false;
      for (int k = 0; k < 4; ++k) both |= tet[k] == (v == p ? q : p);
      if (both) continue;  // removed by the collapse
      const double* before[4];
      const double* after[4];
      for (int k = 0; k < 4; ++k) {
        before[k] = &position_[3 * size_t{tet[k]}];
        after[k] = (tet[k] == p || tet[k] == q) ? position : before[k];
      }
      double old_volume, new_volume;
      double new_quality = quality(after[0], after[1], after[2], after[3], &new_volume);
      if (new_volume > 0 && new_quality >= options_.min_quality) continue;  // fine whatever it was before
      double old_quality = quality(before[0], before[1], before[2], before[3], &old_volume);
      if (old_quality <= 1e-12) {
        if (new_volume < 0) return false;  // a degenerate tet may stay degenerate, never flip
        continue;
      }
      if (new_volume <= 0) return false;
      if (new_quality < options_.min_quality && new_quality < 0.5 * old_quality) return false;
    }
  }
  return true;
}

void Simplifier::interpolate(uint32_t p, uint32_t q, const double* position, double* values) const {
  // linear interpolation in the tet (of the current stars of p and q) that holds the point,
  // or the one it is least outside of
  double best = -std::numeric_limits<double>::infinity();
  uint32_t best_tet = kNone;
  double best_bary[4] = {1, 0, 0, 0};
  for (uint32_t v : {p, q}) {
    for (uint32_t t : star_[v]) {
      const uint32_t* tet = &tets_[4 * t];
      const double* P[4];
      for (int k = 0; k < 4; ++k) P[k] = &position_[3 * size_t{tet[k]}];
      double total;
      quality(P[0], P[1], P[2], P[3], &total);
      if (std::fabs(total) <= 0) continue;
      double bary[4], lowest = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 4; ++k) {
        const double* Q[4] = {P[0], P[1], P[2], P[3]};
        Q[k] = position;
        double part;
        quality(Q[0], Q[1], Q[2], Q[3], &part);
        bary[k] = part / total;
        lowest = std::min(lowest, bary[k]);
      }
      if (lowest > best) {
        best = lowest;
        best_tet = t;
        std::copy(bary, bary + 4, best_bary);
      }
      if (lowest >= 0) break;
    }
    if (best >= 0) break;
  }
  if (best_tet == kNone) {
    for (size_t i = 0; i < floats_; ++i) values[i] = 0.5 * (values_[p * floats_ + i] + values_[q * floats_ + i]);
    return;
  }
  double sum = 0;
  for (double& b : best_bary) {
    b = std::max(b, 0.0);
    sum += b;
  }
  for (double& b : best_bary) b /= sum;
  for (size_t i = 0; i < floats_; ++i) {
    double v = 0;
    for (int k = 0; k < 4; ++k) v += best_bary[k] * values_[tets_[4 * best_tet + k] * floats_ + i];
    values[i] = v;
  }
}

bool Simplifier::try_collapse(Worker& w, uint32_t p, uint32_t q) {
  w.deferred_cost = -1;
  if (!w.remember_refused) return collapse(w, p, q);
  // an edge refused once is not tried again until a collapse changes one of its ends (the
  // independent runs seed the same edges again; the global queue never does)
  const uint64_t key = uint64_t{p} << 32 | q, stamp = uint64_t{version_[p]} << 32 | version_[q];
  if (auto it = w.refused.find(key); it != w.refused.end() && it->second == stamp) return false;
  const bool ok = collapse(w, p, q);
  if (!ok && w.deferred_cost < 0) w.refused[key] = stamp;  // a deferred edge may come back
  return ok;
}

bool Simplifier::collapse(Worker& w, uint32_t p, uint32_t q) {
  if (!best_candidates(p, q, w.candidates)) return false;
  if (options_.max_error > 0 && w.candidates.front().cost > options_.max_error) return false;
  // the placement first: it refuses more collapses than the link condition, for less work
  const Candidate* chosen = nullptr;
  for (const Candidate& c : w.candidates) {
    if (geometry_ok(p, q, c.position.data())) {
      chosen = &c;
      break;
    }
  }
  if (!chosen) {
    ++w.counts.refused_geometry;
    return false;
  }
  if (!link_condition(w, p, q)) {
    ++w.counts.refused_topology;
    return false;
  }
  if (chosen->cost > w.cost_limit) {  // the valid placement costs more than this edge was queued at
    w.deferred_cost = chosen->cost;
    return false;
  }
  // keep the vertex the candidate sits on (a locked one stays bit-identical), else p
  uint32_t keep = chosen->kind == 2 ? q : p, gone = keep == p ? q : p;
  if (locked_[keep] && creates_locked_boundary_face(w, keep, gone)) {
    ++w.counts.refused_topology;
    return false;
  }
  std::vector<double> values(floats_);
  if (chosen->kind == 1 || chosen->kind == 2) {
    for (size_t i = 0; i < floats_; ++i) values[i] = values_[keep * floats_ + i];
  } else {
    // attributes outside the quadrics: interpolated at the new position; those in the
    // quadrics: the values that minimise the quadric error (Garland and Zhou), which keeps
    // the field error lower than interpolating in the already coarsened mesh
    interpolate(p, q, chosen->position.data(), values.data());
    for (size_t c = 0; c < channels_.size(); ++c) {
      const Channel& ch = channels_[c];
      const double n = chosen->point[3 + c];
      if (ch.scale > 0) values[ch.value] = ch.vector ? (n - 0.5) / (0.5 * ch.scale) : n / ch.scale + ch.offset;
    }
  }
  // apply
  if (options_.record_collapses) {
    w.log.push_back({keep, gone, static_cast<float>(chosen->cost), {static_cast<float>(chosen->position[0]), static_cast<float>(chosen->position[1]), static_cast<float>(chosen->position[2])}});
    w.log_values.insert(w.log_values.end(), values.begin(), values.end());
  }
  for (int k = 0; k < 3; ++k) position_[3 * size_t{keep} + k] = chosen->position[k];
  for (size_t i = 0; i < floats_; ++i) values_[keep * floats_ + i] = values[i];
  quadric::add(quadrics_.at(keep), quadrics_.at(gone), d_);
  for (uint32_t t : star_[gone]) {
    uint32_t* tet = &tets_[4 * t];
    bool has_keep = false;
    for (int k = 0; k < 4; ++k) has_keep |= tet[k] == keep;
    if (has_keep) {  // the tet around the edge disappears
      tet_alive_[t] = 0;
      alive_tets_.fetch_sub(1, std::memory_order_relaxed);
      ++w.removed;
      for (int k = 0; k < 4; ++k) {
        if (tet[k] == gone) continue;
        auto& s = star_[tet[k]];
        s.erase(std::find(s.begin(), s.end(), t));
      }
    } else {
      for (int k = 0; k < 4; ++k)
        if (tet[k] == gone) tet[k] = keep;
      star_[keep].push_back(t);
    }
  }
  star_[gone].clear();
  vertex_alive_[gone] = 0;
  ++version_[keep];
  ++version_[gone];
  ++w.counts.collapses;
  marked_[keep] = marked_[gone] = 1;
  if (options_.independent_stars)
    for (uint32_t t : star_[keep])
      for (int k = 0; k < 4; ++k) marked_[tets_[4 * t + k]] = 1;
  return true;
}

}  // namespace tetrascope::lod::detail
