// The simplifier's state and its parts, private to lod/ (the API is simplify.h):
//   simplify.cpp           setup (channels, quadrics), candidate placements, run, compaction
//   simplify_collapse.cpp  one edge collapse: link condition, locked borders, geometry, attributes
//   simplify_queues.cpp    the collapse queues: one global queue, independent runs, and the
//                          split into regions that two threads simplify at once
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <queue>
#include <unordered_map>
#include <vector>

#include "tetrascope/lod/simplify/quadric.h"
#include "tetrascope/lod/simplify/simplify.h"

namespace tetrascope::lod::detail {

constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr uint8_t kNoRegion = 0xFF;

struct Channel {
  size_t value;      // index into the per-vertex attribute values
  double offset, scale;
  bool vector;       // vector component: 0.5 * v * scale + 0.5
};

struct Candidate {
  double cost;
  std::array<double, 3> position;
  int kind;  // 0 optimum, 1 at p, 2 at q, 3 midpoint
  std::array<double, kMaxQuadricDimension> point{};  // the point in R^(3+A) (normalised)
};

struct QueueEntry {
  double cost;
  uint32_t p, q, version_p, version_q;
  bool operator>(const QueueEntry& o) const {
    if (cost != o.cost) return cost > o.cost;
    if (p != o.p) return p > o.p;
    return q > o.q;
  }
};
using MinQueue = std::priority_queue<QueueEntry, std::vector<QueueEntry>, std::greater<QueueEntry>>;

// Shape quality of tet abcd in R^3 (the first three coordinates); its signed volume in *volume.
double quality(const double* a, const double* b, const double* c, const double* e, double* volume);

class Simplifier {
 public:
  Simplifier(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked);
  SimplifyReport run();

 private:
  void normalised(uint32_t v, double* x) const;
  void normalised_at(const double* position, const double* values, double* x) const;
  std::vector<uint32_t> neighbours(uint32_t v) const;
  bool best_candidates(uint32_t p, uint32_t q, std::vector<Candidate>& out) const;
  struct LinkSets {
    std::vector<uint32_t> vertices;
    std::vector<uint64_t> edges;
    std::vector<std::array<uint32_t, 3>> triangles;
  };
  // What one thread of collapses owns: its queue's scratch, counters and stop rule. Workers
  // run at once on disjoint regions (see run_regions), so they never touch the same vertex.
  struct Worker {
    uint8_t region = 0;
    uint64_t remove_limit = 0;  // stop after removing this many tets (0: no limit of its own)
    uint64_t removed = 0;
    SimplifyReport counts;
    std::vector<Candidate> candidates;
    LinkSets link_p, link_q, link_pq;  // scratch of link_condition
    std::vector<uint64_t> scratch_edges;
    bool remember_refused = false;
    std::unordered_map<uint64_t, uint64_t> refused;  // edge -> versions of its ends when refused
    double cost_limit = std::numeric_limits<double>::infinity();  // a collapse may cost at most this
    double deferred_cost = -1;  // set when a collapse was put off because its valid placement costs more
    std::vector<SimplifyCollapse> log;  // SimplifyOptions::record_collapses
    std::vector<float> log_values;
  };
  void link_of(Worker& w, uint32_t v, uint32_t other, LinkSets& link, LinkSets* edge_link);
  bool link_condition(Worker& w, uint32_t p, uint32_t q);
  bool creates_locked_boundary_face(Worker& w, uint32_t keep, uint32_t gone);
  bool geometry_ok(uint32_t p, uint32_t q, const double* position);
  void interpolate(uint32_t p, uint32_t q, const double* position, double* values) const;
  bool try_collapse(Worker& w, uint32_t p, uint32_t q);
  bool collapse(Worker& w, uint32_t p, uint32_t q);
  void push_edges_of(Worker& w, uint32_t v, MinQueue& queue, bool independent_only);
  void push(Worker& w, uint32_t p, uint32_t q, MinQueue& queue);
  void compact();
  // the live mesh, compacted into `out`, and per output vertex the vertex it continues
  void compacted(storage::TetMesh& out, std::vector<uint32_t>& source) const;
  // the snapshots (SimplifyOptions::snapshot_tets) the run has reached; `last`: all left
  void take_snapshots(bool last);
  bool done(const Worker& w) const {
    return (options_.target_tets && alive_tets_.load(std::memory_order_relaxed) <= options_.target_tets) || (w.remove_limit && w.removed >= w.remove_limit);
  }
  void add_values_and_channels();
  void setup_topology(const std::vector<uint8_t>& locked);
  double add_tet_quadrics();
  void add_boundary_quadrics(double length);
  void add_vertex_quadrics(double length);
  void run_queue(Worker& w);
  void run_regions(int threads);
  void run_independent(Worker& w);
  void merge_counts(Worker& w);

  storage::TetMesh& mesh_;
  SimplifyOptions options_;
  int d_ = 3;
  size_t floats_ = 0;  // attribute values per vertex
  std::vector<Channel> channels_;
  double origin_[3] = {0, 0, 0}, extent_ = 1;
  std::vector<double> position_, values_;
  std::vector<uint32_t> tets_;
  std::vector<uint8_t> tet_alive_, vertex_alive_, locked_, marked_;
  std::vector<std::vector<uint32_t>> star_;
  std::vector<uint32_t> version_;
  QuadricSet quadrics_;
  std::atomic<uint64_t> alive_tets_{0};
  SimplifyReport report_;
  std::vector<uint8_t> snapshot_taken_;  // per SimplifyOptions::snapshot_tets
  std::vector<uint8_t> region_;  // per vertex: the worker that may collapse its edges, or kNoRegion
};

}  // namespace tetrascope::lod::detail
