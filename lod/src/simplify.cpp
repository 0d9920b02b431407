// Tetrahedral simplification by full-edge collapses, dissertation §3.1.3-3.1.4 and §4.1:
// quadrics over position and normalised attributes (Garland and Zhou 2005), face quadrics on
// the domain boundary, edge quadrics on sharp boundary edges (§4.1.2), vertex distribution
// quadrics; the link condition with a virtual vertex for the boundary (Dey et al. 1999);
// no flipped or collapsed tets; independent edge collapses in runs under a re-estimated
// threshold (§4.1.1), or one global queue.
#include "tetrascope/lod/simplify.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <queue>
#include <random>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include "tetrascope/lod/quadric.h"
#include "tetrascope/storage/tet_topology.h"

namespace tetrascope::lod {
namespace {

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

double quality(const double* a, const double* b, const double* c, const double* e, double* volume) {
  double u[3], v[3], w[3];
  for (int k = 0; k < 3; ++k) {
    u[k] = b[k] - a[k];
    v[k] = c[k] - a[k];
    w[k] = e[k] - a[k];
  }
  double det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
  *volume = det / 6;
  const double* p[4] = {a, b, c, e};
  double sum = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      for (int k = 0; k < 3; ++k) sum += (p[i][k] - p[j][k]) * (p[i][k] - p[j][k]);
  double rms = std::sqrt(sum / 6);
  return rms > 0 ? 6 * std::sqrt(2.0) * (*volume) / (rms * rms * rms) : 0;
}

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
  bool done(const Worker& w) const {
    return (options_.target_tets && alive_tets_.load(std::memory_order_relaxed) <= options_.target_tets) || (w.remove_limit && w.removed >= w.remove_limit);
  }
  void run_queue(Worker& w);
  void run_regions(int threads);
  void run_independent(Worker& w);
  void merge_counts(const Worker& w);

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
  std::vector<uint8_t> region_;  // per vertex: the worker that may collapse its edges, or kNoRegion
};

Simplifier::Simplifier(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked)
    : mesh_(mesh), options_(options), quadrics_(3, 0) {
  const size_t n = mesh.vertex_count();
  if (!locked.empty() && locked.size() != n) throw std::invalid_argument("locked flags must cover every vertex");
  if (options.target_tets == 0 && options.max_error <= 0) throw std::invalid_argument("give a target tet count, a ratio or a maximal error");
  if (!(options.attribute_weight > 0) || options.boundary_weight < 0 || options.feature_weight < 0 || options.vertex_weight < 0 || !(options.min_quality >= 0 && options.min_quality < 1)) {
    throw std::invalid_argument("weights must be >= 0 and the minimal quality in [0, 1)");
  }
  // per-vertex values of all attributes; channels for the quadrics
  std::vector<size_t> first_value;
  for (const auto& a : mesh.attributes) {
    first_value.push_back(floats_);
    floats_ += a.info.components;
  }
  values_.resize(n * floats_);
  for (size_t a = 0, base = 0; a < mesh.attributes.size(); base += mesh.attributes[a].info.components, ++a) {
    const uint32_t c = mesh.attributes[a].info.components;
    for (size_t v = 0; v < n; ++v)
      for (uint32_t k = 0; k < c; ++k) values_[v * floats_ + base + k] = mesh.attributes[a].values[v * c + k];
  }
  for (const std::string& name : options.attributes) {
    if (!mesh.find_attribute(name)) throw std::invalid_argument("no attribute '" + name + "' in the mesh");
  }
  for (size_t a = 0; a < mesh.attributes.size(); ++a) {
    const auto& attribute = mesh.attributes[a];
    if (!options.attributes.empty() && std::find(options.attributes.begin(), options.attributes.end(), attribute.info.name) == options.attributes.end()) continue;
    const uint32_t c = attribute.info.components;
    if (channels_.size() + c > kMaxSimplifyAttributeChannels) {
      if (options.attributes.empty()) break;  // all attributes: as many as fit
      throw std::invalid_argument("too many attribute channels for the quadrics (at most " + std::to_string(kMaxSimplifyAttributeChannels) + ")");
    }
    if (!options.attribute_ranges.empty() && options.attribute_ranges.size() != mesh.attributes.size()) {
      throw std::invalid_argument("attribute_ranges must give one range per attribute");
    }
    const bool given = !options.attribute_ranges.empty();
    if (c == 1) {  // scalars to [0, 1]
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      if (given) {
        lo = options.attribute_ranges[a][0];
        hi = options.attribute_ranges[a][1];
      } else {
        for (float v : attribute.values) {
          if (std::isfinite(v)) {
            lo = std::min<double>(lo, v);
            hi = std::max<double>(hi, v);
          }
        }
      }
      channels_.push_back({first_value[a], std::isfinite(lo) ? lo : 0, hi > lo ? options.attribute_weight / (hi - lo) : 0, false});
    } else {  // vectors: the longest to length 1, then 0.5 v + 0.5 (§4.2.2)
      double longest = given ? options.attribute_ranges[a][1] : 0;
      for (size_t v = 0; v < n && !given; ++v) {
        double l2 = 0;
        for (uint32_t k = 0; k < c; ++k) l2 += double(attribute.values[v * c + k]) * attribute.values[v * c + k];
        if (std::isfinite(l2)) longest = std::max(longest, std::sqrt(l2));
      }
      for (uint32_t k = 0; k < c; ++k) channels_.push_back({first_value[a] + k, 0, longest > 0 ? options.attribute_weight / longest : 0, true});
    }
  }
  d_ = 3 + static_cast<int>(channels_.size());
  // positions, normalised to the unit cube for the quadrics
  position_.resize(3 * n);
  for (size_t v = 0; v < n; ++v) {
    position_[3 * v] = mesh.x[v];
    position_[3 * v + 1] = mesh.y[v];
    position_[3 * v + 2] = mesh.z[v];
  }
  storage::Bounds box = options.frame ? *options.frame : storage::compute_bounds(mesh);
  extent_ = std::max({box.max[0] - box.min[0], box.max[1] - box.min[1], box.max[2] - box.min[2], 1e-30});
  for (int k = 0; k < 3; ++k) origin_[k] = box.min[k];
  tets_ = mesh.tets;
  const size_t tet_count = tets_.size() / 4;
  tet_alive_.assign(tet_count, 1);
  alive_tets_ = tet_count;
  vertex_alive_.assign(n, 1);
  locked_ = locked.empty() ? std::vector<uint8_t>(n, 0) : locked;
  marked_.assign(n, 0);
  version_.assign(n, 0);
  star_.assign(n, {});
  for (uint32_t t = 0; t < tet_count; ++t)
    for (int k = 0; k < 4; ++k) star_[tets_[4 * t + k]].push_back(t);
  // quadrics
  quadrics_ = QuadricSet(d_, n);
  std::vector<double> q(quadric::stride(d_));
  double total_volume = 0;
  std::vector<double> point(4 * d_);
  for (uint32_t t = 0; t < tet_count; ++t) {
    const uint32_t* tet = &tets_[4 * t];
    for (int k = 0; k < 4; ++k) normalised(tet[k], &point[k * d_]);
    double volume;
    quality(&point[0], &point[d_], &point[2 * d_], &point[3 * d_], &volume);
    total_volume += std::fabs(volume);
    const double* pts[4] = {&point[0], &point[d_], &point[2 * d_], &point[3 * d_]};
    quadric::clear(q.data(), d_);
    // Weight: the tet's volume in R^(3+A) squared over its volume in space, i.e. volume x
    // (1 + |normalised gradient|^2): tets where the field changes fast count for more (as
    // the 4-D normal of Vo et al. 2007 weighs them).
    double hyper_volume = 0;
    if (!quadric::subspace(q.data(), pts, 4, d_, 0.0, &hyper_volume) || std::fabs(volume) <= 0) continue;
    const double weight = options_.gradient_weighting ? hyper_volume * hyper_volume / std::fabs(volume) : std::fabs(volume);
    if (!quadric::subspace(q.data(), pts, 4, d_, weight)) continue;
    for (int k = 0; k < 4; ++k) quadric::add(quadrics_.at(tet[k]), q.data(), d_);
  }
  const double length = std::cbrt(std::max(total_volume / std::max<size_t>(tet_count, 1), 1e-300));  // characteristic tet size
  // boundary faces: face quadrics, and edge quadrics on sharp boundary edges
  const std::vector<FaceVertices> boundary = boundary_faces_by_key(tets_);
  struct EdgeNormal {
    uint32_t a, b;
    double n[3];
  };
  std::vector<EdgeNormal> edge_normals;
  for (const auto& f : boundary) {
    double p[3][3];
    for (int i = 0; i < 3; ++i) normalised_at(&position_[3 * size_t{f[i]}], nullptr, p[i]);
    double u[3], v[3], nrm[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = p[1][k] - p[0][k];
      v[k] = p[2][k] - p[0][k];
    }
    nrm[0] = u[1] * v[2] - u[2] * v[1];
    nrm[1] = u[2] * v[0] - u[0] * v[2];
    nrm[2] = u[0] * v[1] - u[1] * v[0];
    double twice_area = std::sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
    if (twice_area <= 0) continue;
    for (double& c : nrm) c /= twice_area;
    if (options.boundary_weight > 0) {
      // the boundary triangle's plane in R^(3+A) (Garland and Zhou's face quadrics): keeps
      // both the domain and the field on it
      double full[3][kMaxQuadricDimension];
      for (int i = 0; i < 3; ++i) normalised(f[i], full[i]);
      const double* corners[3] = {full[0], full[1], full[2]};
      quadric::clear(q.data(), d_);
      if (quadric::subspace(q.data(), corners, 3, d_, 0.5 * twice_area * length * options.boundary_weight)) {
        for (uint32_t corner : f) quadric::add(quadrics_.at(corner), q.data(), d_);
      }
    }
    for (int e = 0; e < 3; ++e) {
      uint32_t a = f[e], c = f[(e + 1) % 3];
      edge_normals.push_back({std::min(a, c), std::max(a, c), {nrm[0], nrm[1], nrm[2]}});
    }
  }
  if (options.feature_weight > 0) {
    std::sort(edge_normals.begin(), edge_normals.end(), [](const EdgeNormal& x, const EdgeNormal& y) { return x.a != y.a ? x.a < y.a : x.b < y.b; });
    const double cos_limit = std::cos(options.feature_angle_degrees * M_PI / 180);
    for (size_t i = 0; i + 1 < edge_normals.size(); ++i) {
      const EdgeNormal &x = edge_normals[i], &y = edge_normals[i + 1];
      if (x.a != y.a || x.b != y.b) continue;
      double cosine = x.n[0] * y.n[0] + x.n[1] * y.n[1] + x.n[2] * y.n[2];
      if (cosine > cos_limit) continue;  // not sharp
      double pa[3], pb[3], e[3], mid[3], len2 = 0;
      normalised_at(&position_[3 * size_t{x.a}], nullptr, pa);
      normalised_at(&position_[3 * size_t{x.b}], nullptr, pb);
      for (int k = 0; k < 3; ++k) {
        e[k] = pb[k] - pa[k];
        mid[k] = 0.5 * (pa[k] + pb[k]);
        len2 += e[k] * e[k];
      }
      if (len2 <= 0) continue;
      double len = std::sqrt(len2), N[9];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) N[3 * r + c] = (r == c ? 1.0 : 0.0) - e[r] * e[c] / len2;
      quadric::clear(q.data(), d_);
      quadric::position_only(q.data(), N, mid, d_, len * length * length * options.feature_weight);
      quadric::add(quadrics_.at(x.a), q.data(), d_);
      quadric::add(quadrics_.at(x.b), q.data(), d_);
    }
  }
  if (options.vertex_weight > 0) {
    for (uint32_t v = 0; v < n; ++v) {
      normalised(v, point.data());
      const double* pts[1] = {point.data()};
      quadric::subspace(quadrics_.at(v), pts, 1, d_, options.vertex_weight * length * length * length);
    }
  }
  report_.tets_before = tet_count;
  report_.vertices_before = n;
}

void Simplifier::normalised_at(const double* position, const double* values, double* x) const {
  for (int k = 0; k < 3; ++k) x[k] = (position[k] - origin_[k]) / extent_;
  if (!values) return;
  for (size_t c = 0; c < channels_.size(); ++c) {
    const Channel& ch = channels_[c];
    double v = values[ch.value];
    if (!std::isfinite(v)) v = ch.vector ? 0 : ch.offset;
    x[3 + c] = ch.vector ? 0.5 * v * ch.scale + 0.5 : (v - ch.offset) * ch.scale;  // the +0.5 shift only moves the origin
  }
}

void Simplifier::normalised(uint32_t v, double* x) const { normalised_at(&position_[3 * size_t{v}], floats_ ? &values_[v * floats_] : nullptr, x); }

std::vector<uint32_t> Simplifier::neighbours(uint32_t v) const {
  std::vector<uint32_t> out;
  for (uint32_t t : star_[v])
    for (int k = 0; k < 4; ++k)
      if (tets_[4 * t + k] != v) out.push_back(tets_[4 * t + k]);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool Simplifier::best_candidates(uint32_t p, uint32_t q, std::vector<Candidate>& out) const {
  out.clear();
  if (locked_[p] && locked_[q]) return false;
  const bool fix_p = locked_[p], fix_q = locked_[q];
  double Q[quadric::stride(kMaxQuadricDimension)];
  quadric::clear(Q, d_);
  quadric::add(Q, quadrics_.at(p), d_);
  quadric::add(Q, quadrics_.at(q), d_);
  double xp[kMaxQuadricDimension], xq[kMaxQuadricDimension], x[kMaxQuadricDimension];
  normalised(p, xp);
  normalised(q, xq);
  auto world = [&](const double* n) { return std::array<double, 3>{origin_[0] + n[0] * extent_, origin_[1] + n[1] * extent_, origin_[2] + n[2] * extent_}; };
  if (fix_p || fix_q) {  // onto the locked end, which stays where it is
    uint32_t keep = fix_p ? p : q;
    out.push_back({quadric::evaluate(Q, keep == p ? xp : xq, d_), {position_[3 * keep], position_[3 * keep + 1], position_[3 * keep + 2]}, keep == p ? 1 : 2});
    return true;
  }
  if (quadric::minimise(Q, d_, x)) {
    out.push_back({quadric::evaluate(Q, x, d_), world(x), 0});
    std::copy(x, x + d_, out.back().point.begin());
  }
  out.push_back({quadric::evaluate(Q, xp, d_), {position_[3 * p], position_[3 * p + 1], position_[3 * p + 2]}, 1});
  out.push_back({quadric::evaluate(Q, xq, d_), {position_[3 * q], position_[3 * q + 1], position_[3 * q + 2]}, 2});
  for (int i = 0; i < d_; ++i) x[i] = 0.5 * (xp[i] + xq[i]);
  out.push_back({quadric::evaluate(Q, x, d_), world(x), 3});
  std::copy(x, x + d_, out.back().point.begin());
  std::stable_sort(out.begin(), out.end(), [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });
  return true;
}

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
  if (!link_condition(w, p, q)) {
    ++w.counts.refused_topology;
    return false;
  }
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
  return true;
}

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
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(threads);
  for (int r = 1; r < threads; ++r)
    pool.emplace_back([&, r] {
      try {
        run_queue(workers[r]);
      } catch (...) {
        errors[r] = std::current_exception();
      }
    });
  try {
    run_queue(workers[0]);
  } catch (...) {
    errors[0] = std::current_exception();
  }
  for (auto& t : pool) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
  for (const Worker& w : workers) merge_counts(w);
  std::fill(region_.begin(), region_.end(), 0);
  Worker last;
  run_queue(last);
  merge_counts(last);
}

void Simplifier::merge_counts(const Worker& w) {
  report_.collapses += w.counts.collapses;
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
    int samples = 0;
    for (int s = 0; s < 64; ++s) {
      uint32_t t = alive[rng() % alive.size()];
      int i = static_cast<int>(rng() % 4), j = (i + 1 + static_cast<int>(rng() % 3)) % 4;
      uint32_t a = tets_[4 * t + i], b = tets_[4 * t + j];
      if (best_candidates(std::min(a, b), std::max(a, b), w.candidates)) {
        sum += w.candidates.front().cost;
        ++samples;
      }
    }
    double estimate = samples ? sum / samples : 0;
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

SimplifyReport Simplifier::run() {
  const auto start = std::chrono::steady_clock::now();
  region_.assign(vertex_alive_.size(), 0);
  // regions pay off only when each holds many tets; small meshes (and the MT's segments,
  // which it simplifies in parallel itself) take one thread
  const int threads = options_.independent ? 1 : static_cast<int>(std::min<uint64_t>(std::max(options_.threads, 1u), alive_tets_.load() / std::max<uint64_t>(options_.min_tets_per_thread, 1)));
  if (options_.independent) {
    Worker w;
    run_independent(w);
    merge_counts(w);
  } else if (threads > 1) {
    run_regions(threads);
  } else {
    Worker w;
    run_queue(w);
    merge_counts(w);
  }
  report_.threads = std::max(threads, 1);
  compact();
  report_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report_;
}

void Simplifier::compact() {
  const size_t n = vertex_alive_.size();
  std::vector<uint32_t> remap(n, kNone);
  uint32_t next = 0;
  for (size_t v = 0; v < n; ++v)
    if (vertex_alive_[v] && !star_[v].empty()) remap[v] = next++;
  storage::TetMesh out;
  out.x.resize(next);
  out.y.resize(next);
  out.z.resize(next);
  for (size_t v = 0; v < n; ++v) {
    if (remap[v] == kNone) continue;
    out.x[remap[v]] = static_cast<float>(position_[3 * v]);
    out.y[remap[v]] = static_cast<float>(position_[3 * v + 1]);
    out.z[remap[v]] = static_cast<float>(position_[3 * v + 2]);
  }
  for (size_t a = 0, base = 0; a < mesh_.attributes.size(); base += mesh_.attributes[a].info.components, ++a) {
    const uint32_t c = mesh_.attributes[a].info.components;
    storage::Attribute attribute{mesh_.attributes[a].info, std::vector<float>(size_t{next} * c)};
    for (size_t v = 0; v < n; ++v) {
      if (remap[v] == kNone) continue;
      for (uint32_t k = 0; k < c; ++k) {
        // a vertex that never moved keeps its exact original value
        attribute.values[remap[v] * c + k] = static_cast<float>(values_[v * floats_ + base + k]);
      }
    }
    out.attributes.push_back(std::move(attribute));
  }
  for (size_t t = 0; t < tet_alive_.size(); ++t) {
    if (!tet_alive_[t]) continue;
    for (int k = 0; k < 4; ++k) out.tets.push_back(remap[tets_[4 * t + k]]);
  }
  report_.source_vertex.assign(next, 0);
  for (size_t v = 0; v < n; ++v)
    if (remap[v] != kNone) report_.source_vertex[remap[v]] = static_cast<uint32_t>(v);
  report_.tets_after = out.tet_count();
  report_.vertices_after = out.vertex_count();
  mesh_ = std::move(out);
}

}  // namespace

SimplifyReport simplify(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked) {
  Simplifier simplifier(mesh, options, locked);
  return simplifier.run();
}

}  // namespace tetrascope::lod
