// The collapse queues of the tetrahedral simplifier (simplify.cpp): one global queue, cheapest
// edge first; independent edge collapses in runs under a re-estimated threshold (§4.1.1); and
// the split of one mesh into regions that two threads simplify at once.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "simplifier.h"
#include "tetrascope/core/parallel_for.h"

namespace tetrascope::lod::detail {

void Simplifier::push(Worker& w, uint32_t p, uint32_t q, MinQueue& queue) {
  if (region_[p] != w.region || region_[q] != w.region) return;  // another worker's, or frozen for now
  if (!best_candidates(p, q, w.candidates)) return;
  queue.push({w.candidates.front().cost, p, q, version_[p], version_[q]});
  w.counts.max_queue = std::max<uint64_t>(w.counts.max_queue, queue.size());
}

void Simplifier::push_edges_of(Worker& w, uint32_t v, MinQueue& queue, bool independent_only) {
  if (independent_only) {  // edges in the link of v whose ends are both unmarked (§4.1.1)
    std::vector<std::pair<uint32_t, uint32_t>> edges;
    for (uint32_t t : star_[v]) {
      uint32_t rest[3];
      int n = 0;
      for (int k = 0; k < 4; ++k)
        if (tets_[4 * t + k] != v) rest[n++] = tets_[4 * t + k];
      for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) edges.push_back({std::min(rest[i], rest[j]), std::max(rest[i], rest[j])});
    }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (auto [a, b] : edges)
      if (!marked_[a] && !marked_[b]) push(w, a, b, queue);
  } else {
    for (uint32_t u : neighbours(v)) push(w, std::min(v, u), std::max(v, u), queue);
  }
}

// One global queue over the edges whose ends are both in the worker's region: the cheapest
// edge first, until the target, the error limit or the worker's own removal limit.
void Simplifier::run_queue(Worker& w) {
  const uint32_t n = static_cast<uint32_t>(vertex_alive_.size());
  MinQueue queue;
  for (uint32_t v = 0; v < n; ++v) {
    if (!vertex_alive_[v] || region_[v] != w.region) continue;
    for (uint32_t u : neighbours(v))
      if (v < u) push(w, v, u, queue);
  }
  while (!queue.empty() && !done(w)) {
    QueueEntry e = queue.top();
    queue.pop();
    if (!vertex_alive_[e.p] || !vertex_alive_[e.q] || version_[e.p] != e.version_p || version_[e.q] != e.version_q) continue;
    if (options_.max_error > 0 && e.cost > options_.max_error) break;
    // collapse only at about the cost the edge was queued at; a dearer valid placement
    // goes back into the queue at its real cost
    w.cost_limit = e.cost + 1e-12 + 1e-9 * std::fabs(e.cost);
    if (try_collapse(w, e.p, e.q)) {
      if (options_.trace_costs && !options_.independent) report_.cost_trace.emplace_back(alive_tets_.load(std::memory_order_relaxed), e.cost);
      if (!options_.snapshot_tets.empty()) take_snapshots(false);
      uint32_t keep = vertex_alive_[e.p] ? e.p : e.q;
      push_edges_of(w, keep, queue, false);
    } else if (w.deferred_cost >= 0) {
      queue.push({w.deferred_cost, e.p, e.q, e.version_p, e.version_q});
    }
  }
}

// Both cores on one mesh: the vertices are split at the median along the longest axis; a
// vertex with a neighbour on the other side is frozen. A collapse only changes the tets
// around its two ends and the stars of their neighbours, and a worker's edges have both
// ends away from the cut, so the workers touch disjoint vertices and tets: no locks, and the
// result does not depend on timing. Each worker removes its share of the tets less a margin;
// then one queue over the whole mesh (cut included) finishes the job.
void Simplifier::run_regions(int threads) {
  const uint32_t n = static_cast<uint32_t>(vertex_alive_.size());
  storage::Bounds box = storage::compute_bounds(mesh_);
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (box.max[k] - box.min[k] > box.max[axis] - box.min[axis]) axis = k;
  std::vector<std::pair<double, uint32_t>> order(n);
  for (uint32_t v = 0; v < n; ++v) order[v] = {position_[3 * size_t{v} + axis], v};
  std::sort(order.begin(), order.end());
  for (uint32_t i = 0; i < n; ++i) region_[order[i].second] = static_cast<uint8_t>(uint64_t{i} * threads / n);
  std::vector<uint8_t> side = region_;
  for (uint32_t v = 0; v < n; ++v)
    for (uint32_t u : neighbours(v))
      if (side[u] != side[v]) region_[v] = kNoRegion;
  std::vector<uint64_t> tets_in(threads, 0);
  for (uint32_t t = 0; t < tet_alive_.size(); ++t) {
    uint8_t r = region_[tets_[4 * t]];
    bool inside = r != kNoRegion;
    for (int k = 1; k < 4; ++k) inside &= region_[tets_[4 * t + k]] == r;
    if (inside) ++tets_in[r];
  }
  const uint64_t total = alive_tets_.load();
  const uint64_t to_remove = options_.target_tets && options_.target_tets < total ? total - options_.target_tets : 0;
  std::vector<Worker> workers(threads);
  for (int r = 0; r < threads; ++r) {
    workers[r].region = static_cast<uint8_t>(r);
    // each region's share of the removals, less a margin left to the final pass across the cut
    workers[r].remove_limit = to_remove ? std::max<uint64_t>(1, static_cast<uint64_t>(0.97 * double(to_remove) * double(tets_in[r]) / double(total))) : 0;
  }
  parallel_for(workers.size(), static_cast<unsigned>(threads), [&](size_t r, unsigned) { run_queue(workers[r]); });
  for (Worker& w : workers) merge_counts(w);
  std::fill(region_.begin(), region_.end(), 0);
  Worker last;
  run_queue(last);
  merge_counts(last);
}

void Simplifier::merge_counts(Worker& w) {
  report_.collapses += w.counts.collapses;
  report_.collapse_log.insert(report_.collapse_log.end(), w.log.begin(), w.log.end());
  report_.collapse_values.insert(report_.collapse_values.end(), w.log_values.begin(), w.log_values.end());
  w.log.clear();
  w.log_values.clear();
  report_.refused_topology += w.counts.refused_topology;
  report_.refused_geometry += w.counts.refused_geometry;
  report_.runs += w.counts.runs;
  report_.max_queue = std::max(report_.max_queue, w.counts.max_queue);
}

void Simplifier::run_independent(Worker& w) {
  const uint32_t n = static_cast<uint32_t>(vertex_alive_.size());
  std::mt19937 rng(options_.seed);
  w.remember_refused = true;
  double threshold = 0;
  uint64_t idle_runs = 0;
  while (!done(w)) {
    ++w.counts.runs;
    std::fill(marked_.begin(), marked_.end(), 0);
    // threshold: the mean cost of a few random edges, re-estimated every run (§4.1.1)
    std::vector<uint32_t> alive;
    for (uint32_t t = 0; t < tet_alive_.size(); ++t)
      if (tet_alive_[t]) alive.push_back(t);
    if (alive.empty()) break;
    double sum = 0;
    std::vector<double> costs;
    for (int s = 0; s < 64; ++s) {
      uint32_t t = alive[rng() % alive.size()];
      int i = static_cast<int>(rng() % 4), j = (i + 1 + static_cast<int>(rng() % 3)) % 4;
      uint32_t a = tets_[4 * t + i], b = tets_[4 * t + j];
      if (best_candidates(std::min(a, b), std::max(a, b), w.candidates)) {
        sum += w.candidates.front().cost;
        costs.push_back(w.candidates.front().cost);
      }
    }
    // §4.1.1: the mean; with independent stars (a vertex hierarchy) a low quantile, so that
    // each run keeps to the cheapest edges and the collapses stay near the order of their cost
    double estimate = costs.empty() ? 0 : sum / static_cast<double>(costs.size());
    if (options_.independent_stars && !costs.empty()) {
      std::nth_element(costs.begin(), costs.begin() + costs.size() / 4, costs.end());
      estimate = costs[costs.size() / 4];
    }
    threshold = std::max(estimate, threshold * (idle_runs > 0 ? 4.0 : 1.0));
    if (threshold <= 0) threshold = std::numeric_limits<double>::min();
    if (options_.max_error > 0) threshold = std::min(threshold, options_.max_error);
    const uint64_t before = w.counts.collapses;
    MinQueue queue;
    std::vector<uint32_t> order(n);
    for (uint32_t v = 0; v < n; ++v) order[v] = v;
    std::shuffle(order.begin(), order.end(), rng);
    for (uint32_t seed_vertex : order) {
      if (done(w)) break;
      if (!vertex_alive_[seed_vertex] || marked_[seed_vertex]) continue;
      for (uint32_t u : neighbours(seed_vertex))
        if (!marked_[u]) push(w, std::min(seed_vertex, u), std::max(seed_vertex, u), queue);
      while (!queue.empty() && !done(w)) {
        QueueEntry e = queue.top();
        queue.pop();
        if (!vertex_alive_[e.p] || !vertex_alive_[e.q] || marked_[e.p] || marked_[e.q]) continue;
        if (version_[e.p] != e.version_p || version_[e.q] != e.version_q) continue;
        if (e.cost > threshold) continue;
        w.cost_limit = threshold;
        if (try_collapse(w, e.p, e.q)) push_edges_of(w, vertex_alive_[e.p] ? e.p : e.q, queue, true);
      }
      MinQueue().swap(queue);
    }
    if (w.counts.collapses == before) {
      ++idle_runs;
      if (options_.max_error > 0 && threshold >= options_.max_error) break;
      if (idle_runs > 40) break;  // nothing collapses any more: the mesh is as coarse as it can get
    } else {
      idle_runs = 0;
    }
  }
}

}  // namespace tetrascope::lod::detail
