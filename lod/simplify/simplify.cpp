// Tetrahedral simplification by full-edge collapses, dissertation §3.1.3-3.1.4 and §4.1:
// quadrics over position and normalised attributes (Garland and Zhou 2005), face quadrics on
// the domain boundary, edge quadrics on sharp boundary edges (§4.1.2), vertex distribution
// quadrics; the link condition with a virtual vertex for the boundary (Dey et al. 1999,
// simplify_collapse.cpp); no flipped or collapsed tets; independent edge collapses in runs
// under a re-estimated threshold (§4.1.1), or one global queue (simplify_queues.cpp).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "simplifier.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::lod {
namespace detail {

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

Simplifier::Simplifier(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked)
    : mesh_(mesh), options_(options), quadrics_(3, 0) {
  const size_t n = mesh.vertex_count();
  if (!locked.empty() && locked.size() != n) throw std::invalid_argument("locked flags must cover every vertex");
  if (options.target_tets == 0 && options.max_error <= 0) throw std::invalid_argument("give a target tet count, a ratio or a maximal error");
  if (!(options.attribute_weight > 0) || options.boundary_weight < 0 || options.feature_weight < 0 || options.vertex_weight < 0 || !(options.min_quality >= 0 && options.min_quality < 1)) {
    throw std::invalid_argument("weights must be >= 0 and the minimal quality in [0, 1)");
  }
  add_values_and_channels();
  setup_topology(locked);
  const double length = add_tet_quadrics();
  add_boundary_quadrics(length);
  if (options.vertex_weight > 0) add_vertex_quadrics(length);
  report_.tets_before = tets_.size() / 4;
  report_.vertices_before = n;
  if (!options.snapshot_tets.empty() && options.independent) throw std::invalid_argument("snapshots need one global queue (not independent runs)");
  report_.snapshots.resize(options.snapshot_tets.size());
  for (size_t k = 0; k < options.snapshot_tets.size(); ++k) report_.snapshots[k].target = options.snapshot_tets[k];
  snapshot_taken_.assign(options.snapshot_tets.size(), 0);
}

// Per-vertex values of all attributes, and the quadrics' channels over them.
void Simplifier::add_values_and_channels() {
  const storage::TetMesh& mesh = mesh_;
  const SimplifyOptions& options = options_;
  const size_t n = mesh.vertex_count();
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
    // a tensor's derived scalars are recomputed from it afterwards: weighed only when named
    if (options.attributes.empty() && attribute.info.kind == storage::AttributeKind::kTensorDerived) continue;
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
}

// Normalised positions, the tets, their stars and the locked flags.
void Simplifier::setup_topology(const std::vector<uint8_t>& locked) {
  const storage::TetMesh& mesh = mesh_;
  const SimplifyOptions& options = options_;
  const size_t n = mesh.vertex_count();
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
}

// Every tet's quadric added to its vertices'; returns the characteristic tet size.
double Simplifier::add_tet_quadrics() {
  const size_t n = mesh_.vertex_count();
  const size_t tet_count = tets_.size() / 4;
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
  return length;
}

// Boundary faces: face quadrics, and edge quadrics on sharp boundary edges.
void Simplifier::add_boundary_quadrics(double length) {
  const SimplifyOptions& options = options_;
  std::vector<double> q(quadric::stride(d_));
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
}

// Vertex distribution quadrics.
void Simplifier::add_vertex_quadrics(double length) {
  const size_t n = mesh_.vertex_count();
  std::vector<double> point(d_);
    for (uint32_t v = 0; v < n; ++v) {
    normalised(v, point.data());
    const double* pts[1] = {point.data()};
    quadric::subspace(quadrics_.at(v), pts, 1, d_, options_.vertex_weight * length * length * length);
  }
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

SimplifyReport Simplifier::run() {
  const auto start = std::chrono::steady_clock::now();
  region_.assign(vertex_alive_.size(), 0);
  // regions pay off only when each holds many tets; small meshes (and the MT's segments,
  // which it simplifies in parallel itself) take one thread
  take_snapshots(false);  // a count at or above the input's: the input, as a run to it would leave it
  const int threads = options_.independent || options_.trace_costs || !options_.snapshot_tets.empty() ? 1 : static_cast<int>(std::min<uint64_t>(std::max(options_.threads, 1u), alive_tets_.load() / std::max<uint64_t>(options_.min_tets_per_thread, 1)));
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
  take_snapshots(true);
  compact();
  report_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return std::move(report_);  // run() is called once: its snapshots are not copied
}

void Simplifier::take_snapshots(bool last) {
  const uint64_t alive = alive_tets_.load(std::memory_order_relaxed);
  for (size_t k = 0; k < options_.snapshot_tets.size(); ++k) {
    if (snapshot_taken_[k] || (!last && alive > options_.snapshot_tets[k])) continue;
    snapshot_taken_[k] = 1;
    compacted(report_.snapshots[k].mesh, report_.snapshots[k].source_vertex);
  }
}

void Simplifier::compact() {
  storage::TetMesh out;
  compacted(out, report_.source_vertex);
  report_.tets_after = out.tet_count();
  report_.vertices_after = out.vertex_count();
  mesh_ = std::move(out);
}

void Simplifier::compacted(storage::TetMesh& out, std::vector<uint32_t>& source) const {
  const size_t n = vertex_alive_.size();
  std::vector<uint32_t> remap(n, kNone);
  uint32_t next = 0;
  for (size_t v = 0; v < n; ++v)
    if (vertex_alive_[v] && !star_[v].empty()) remap[v] = next++;
  out = storage::TetMesh{};
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
  storage::refresh_tensor_attributes(out);  // interpolated tensors: kept PSD where the input was, derived scalars recomputed
  source.assign(next, 0);
  for (size_t v = 0; v < n; ++v)
    if (remap[v] != kNone) source[remap[v]] = static_cast<uint32_t>(v);
}

}  // namespace detail

SimplifyReport simplify(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked) {
  if (options.method == SimplifyMethod::kSample) {
    if (!options.snapshot_tets.empty()) throw std::invalid_argument("snapshots need the quadric simplifier");
    return simplify_sampled(mesh, options, locked);
  }
  detail::Simplifier simplifier(mesh, options, locked);
  return simplifier.run();
}

}  // namespace tetrascope::lod
