// The vertex front (§5.2.2–5.2.3, §5.3.3): splits and collapses on the set of applied
// collapses, the view's estimate of the image error each split removes, and the front's mesh.
#include "tetrascope/lod/vertex/vertex_front.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <queue>
#include <stdexcept>

namespace tetrascope::lod {
namespace {

// The largest opacity over the values [lo, hi] of the criteria's table (which spans
// [c.lo, c.hi]; its end bins hold outside it).
double max_opacity(const FrontCriteria& c, double lo, double hi) {
  const size_t n = c.opacity.size();
  const double span = c.hi > c.lo ? c.hi - c.lo : 1;
  auto bin = [&](double v) { return static_cast<size_t>(std::clamp((v - c.lo) / span * double(n), 0.0, double(n - 1))); };
  const size_t a = bin(lo), b = bin(hi);
  double best = 0;
  for (size_t k = a; k <= b; ++k) best = std::max(best, double(c.opacity[k]));
  return best;
}

struct SphereTest {
  std::array<std::array<double, 4>, 6> planes{};  // normalised
  bool active = false;
  bool meets(const float* p, double r) const {
    if (!active) return true;
    for (const auto& q : planes)
      if (q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3] < -r) return false;
    return true;
  }
};

}  // namespace

FrontCriteria front_criteria(const VertexHierarchy& h, const view::TransferFunction& tf, std::span<const double> isovalues) {
  FrontCriteria c;
  if (h.attributes.empty()) return c;
  uint32_t a = 0;
  for (; a < h.attributes.size(); ++a)
    if (h.attributes[a].name == tf.attribute) break;
  if (a == h.attributes.size()) {
    if (!tf.attribute.empty()) throw std::invalid_argument("transfer function: no attribute '" + tf.attribute + "' in the store");
    a = 0;
  }
  c.attribute = static_cast<int>(a);
  // one component of a vector: the collapses' ranges are of the magnitude; the front goes by
  // error and view alone
  if (tf.component != view::kMagnitude && h.attributes[a].components > 1) return c;
  c.isovalues.assign(isovalues.begin(), isovalues.end());
  if (!c.isovalues.empty()) return c;
  if (tf.range) {
    c.lo = (*tf.range)[0];
    c.hi = (*tf.range)[1];
  } else {
    // the attribute's range over the hierarchy's leaves (0..1 for a hierarchy of no collapse)
    c.lo = std::numeric_limits<double>::infinity();
    c.hi = -c.lo;
    for (uint32_t i = 0; i < h.collapse_count(); ++i) {
      c.lo = std::min(c.lo, double(h.range_lo(i, a)));
      c.hi = std::max(c.hi, double(h.range_hi(i, a)));
    }
    if (!std::isfinite(c.lo)) c.lo = 0;
    if (!(c.hi > c.lo) || !std::isfinite(c.hi)) c.hi = c.lo + 1;
  }
  c.opacity.resize(kOpacityBins);
  for (uint32_t b = 0; b < kOpacityBins; ++b) c.opacity[b] = static_cast<float>(tf.alpha(c.lo + (b + 0.5) / kOpacityBins * (c.hi - c.lo)));
  return c;
}

VertexFront::VertexFront(const VertexHierarchy& hierarchy) : h_(hierarchy) {
  const uint32_t C = h_.collapse_count();
  parent_.assign(h_.vertex_count(), kNoCollapse);
  for (uint32_t i = 0; i < C; ++i)
    for (uint32_t child : h_.nodes[i].child) parent_[child] = i;
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t v = 0; v < h_.input_vertices; ++v)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], h_.positions[3 * size_t{v} + k]);
      hi[k] = std::max(hi[k], h_.positions[3 * size_t{v} + k]);
    }
  if (h_.input_vertices) diagonal_ = std::max(1e-30, std::sqrt(double(hi[0] - lo[0]) * (hi[0] - lo[0]) + double(hi[1] - lo[1]) * (hi[1] - lo[1]) + double(hi[2] - lo[2]) * (hi[2] - lo[2])));
  for (int k = 0; k < 3; ++k) {
    grid_lo_[k] = h_.input_vertices ? lo[k] : 0;
    grid_step_[k] = std::max(h_.input_vertices ? double(hi[k] - lo[k]) / kGrid : 1.0, 1e-30);
  }
  collapse_all();
  index_ = run_time_index(h_, parent_);
  sample_base_grid();
}

// The base mesh's values (a vector's length) at the grid's cell centres inside it.
void VertexFront::sample_base_grid() {
  const storage::TetMesh base = mesh();
  const size_t A = base.attributes.size();
  grid_values_.assign(size_t{kGrid} * kGrid * kGrid * A, NAN);
  std::vector<float> scalar(base.vertex_count() * A);
  for (size_t a = 0; a < A; ++a) {
    const uint32_t n = base.attributes[a].info.components;
    for (size_t v = 0; v < base.vertex_count(); ++v) {
      scalar[v * A + a] = attribute_scalar(&base.attributes[a].values[v * n], n);
    }
  }
  for (size_t t = 0; t < base.tet_count(); ++t) {
    const uint32_t* v = &base.tets[4 * t];
    double P[4][3];
    for (int k = 0; k < 4; ++k) {
      P[k][0] = base.x[v[k]];
      P[k][1] = base.y[v[k]];
      P[k][2] = base.z[v[k]];
    }
    // barycentric coordinates by the inverse of [b-a, c-a, d-a]
    double M[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) M[r][c] = P[c + 1][r] - P[0][r];
    const double det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) + M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
    if (!(std::fabs(det) > 0)) continue;
    double inv[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
        inv[r][c] = (M[r1][c1] * M[r2][c2] - M[r1][c2] * M[r2][c1]) / det;
      }
    int first[3], last[3];
    for (int k = 0; k < 3; ++k) {
      const double a = std::min({P[0][k], P[1][k], P[2][k], P[3][k]}), b = std::max({P[0][k], P[1][k], P[2][k], P[3][k]});
      first[k] = std::max(0, static_cast<int>(std::ceil((a - grid_lo_[k]) / grid_step_[k] - 0.5)));
      last[k] = std::min(kGrid - 1, static_cast<int>(std::floor((b - grid_lo_[k]) / grid_step_[k] - 0.5)));
    }
    for (int z = first[2]; z <= last[2]; ++z)
      for (int y = first[1]; y <= last[1]; ++y)
        for (int x = first[0]; x <= last[0]; ++x) {
          const double q[3] = {grid_lo_[0] + (x + 0.5) * grid_step_[0] - P[0][0], grid_lo_[1] + (y + 0.5) * grid_step_[1] - P[0][1], grid_lo_[2] + (z + 0.5) * grid_step_[2] - P[0][2]};
          double l[4];
          for (int r = 0; r < 3; ++r) l[r + 1] = inv[r][0] * q[0] + inv[r][1] * q[1] + inv[r][2] * q[2];
          l[0] = 1 - l[1] - l[2] - l[3];
          if (std::min({l[0], l[1], l[2], l[3]}) < -1e-9) continue;
          const size_t cell = (size_t{static_cast<uint32_t>(z)} * kGrid + y) * kGrid + x;
          for (size_t a = 0; a < A; ++a) {
            double value = 0;
            for (int k = 0; k < 4; ++k) value += l[k] * scalar[v[k] * A + a];
            grid_values_[cell * A + a] = static_cast<float>(value);
          }
        }
  }
}

float VertexFront::grid_at(const std::vector<float>& grid, const double* p, float outside) const {
  int c[3];
  for (int k = 0; k < 3; ++k) {
    const double f = (p[k] - grid_lo_[k]) / grid_step_[k];
    if (!(f >= 0 && f < kGrid)) return outside;
    c[k] = static_cast<int>(f);
  }
  return grid[(size_t{static_cast<uint32_t>(c[2])} * kGrid + c[1]) * kGrid + c[0]];
}

// Per cell centre, exp(-∫σ) from the eye: σ = -ln(1 - α) / unit distance of the transfer
// function's opacity at the base mesh's value there; with isovalues, σ of 4 a cell where the
// base mesh crosses one (opaque surfaces). Empty without a perspective camera or an attribute.
std::vector<float> VertexFront::transmittance(const FrontCriteria& c) const {
  if (!c.camera || c.camera->orthographic || c.attribute < 0 || (c.opacity.empty() && c.isovalues.empty()) || h_.attributes.empty()) return {};
  const size_t A = h_.attributes.size(), cells = size_t{kGrid} * kGrid * kGrid;
  const double unit = c.unit_distance > 0 ? c.unit_distance : diagonal_ / 100;
  std::vector<float> sigma(cells);
  const size_t a = static_cast<size_t>(c.attribute);
  if (!c.isovalues.empty()) {
    // isosurfaces are opaque: a cell whose value and a neighbour's straddle an isovalue holds one
    const double opaque = 4 / std::min({grid_step_[0], grid_step_[1], grid_step_[2]});
    for (int z = 0; z < kGrid; ++z)
      for (int y = 0; y < kGrid; ++y)
        for (int x = 0; x < kGrid; ++x) {
          const size_t cell = (size_t{static_cast<uint32_t>(z)} * kGrid + y) * kGrid + x;
          const float v = grid_values_[cell * A + a];
          bool crossed = false;
          const size_t steps[3] = {1, kGrid, size_t{kGrid} * kGrid};
          const bool inside[3] = {x + 1 < kGrid, y + 1 < kGrid, z + 1 < kGrid};
          for (int k = 0; k < 3 && !std::isnan(v); ++k) {
            if (!inside[k]) continue;
            const float w = grid_values_[(cell + steps[k]) * A + a];
            for (double iso : c.isovalues) crossed |= !std::isnan(w) && (v - iso) * (w - iso) <= 0;
          }
          sigma[cell] = crossed ? static_cast<float>(opaque) : 0.0f;
        }
  } else {
    for (size_t cell = 0; cell < cells; ++cell) {
      const float v = grid_values_[cell * A + a];
      const double alpha = std::isnan(v) ? 0.0 : std::min(max_opacity(c, v, v), 0.999);
      sigma[cell] = static_cast<float>(-std::log1p(-alpha) / unit);
    }
  }
  const double eye[3] = {c.camera->eye[0], c.camera->eye[1], c.camera->eye[2]};
  const double h = 0.5 * std::min({grid_step_[0], grid_step_[1], grid_step_[2]});
  std::vector<float> out(cells);
  for (int z = 0; z < kGrid; ++z)
    for (int y = 0; y < kGrid; ++y)
      for (int x = 0; x < kGrid; ++x) {
        const double q[3] = {grid_lo_[0] + (x + 0.5) * grid_step_[0], grid_lo_[1] + (y + 0.5) * grid_step_[1], grid_lo_[2] + (z + 0.5) * grid_step_[2]};
        const double d[3] = {q[0] - eye[0], q[1] - eye[1], q[2] - eye[2]};
        const double length = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        // the part of eye -> q inside the box, less the cell's own half
        double t0 = 0, t1 = std::max(0.0, 1 - h / std::max(length, 1e-300));
        for (int k = 0; k < 3 && t0 < t1; ++k) {
          if (std::fabs(d[k]) < 1e-300) continue;
          double enter = (grid_lo_[k] - eye[k]) / d[k], leave = (grid_lo_[k] + kGrid * grid_step_[k] - eye[k]) / d[k];
          if (enter > leave) std::swap(enter, leave);
          t0 = std::max(t0, enter);
          t1 = std::min(t1, leave);
        }
        double tau = 0;
        if (t1 > t0) {
          const int steps = std::max(1, static_cast<int>((t1 - t0) * length / h));
          const double dt = (t1 - t0) / steps;
          for (int s = 0; s < steps && tau < 30; ++s) {
            const double t = t0 + (s + 0.5) * dt, p[3] = {eye[0] + t * d[0], eye[1] + t * d[1], eye[2] + t * d[2]};
            tau += grid_at(sigma, p, 0) * dt * length;
          }
        }
        out[(size_t{static_cast<uint32_t>(z)} * kGrid + y) * kGrid + x] = static_cast<float>(std::exp(-tau));
      }
  return out;
}

void VertexFront::collapse_all() {
  const uint32_t C = h_.collapse_count();
  applied_.assign(C, 1);
  applied_after_.resize(C);
  for (uint32_t i = 0; i < C; ++i) applied_after_[i] = h_.after_offsets[i + 1] - h_.after_offsets[i];
  split_before_.assign(C, 0);
  tets_ = h_.base_tets();
}

void VertexFront::split_all() {
  for (uint32_t i = h_.collapse_count(); i-- > 0;)
    if (applied_[i]) apply_split(i);
}

void VertexFront::apply_split(uint32_t i) {
  applied_[i] = 0;
  tets_ += h_.nodes[i].fan;
  for (uint32_t k = h_.before_offsets[i]; k < h_.before_offsets[i + 1]; ++k) --applied_after_[h_.before[k]];
  for (uint32_t k = h_.after_offsets[i]; k < h_.after_offsets[i + 1]; ++k) ++split_before_[h_.after[k]];
}

void VertexFront::apply_collapse(uint32_t i) {
  applied_[i] = 1;
  tets_ -= h_.nodes[i].fan;
  for (uint32_t k = h_.before_offsets[i]; k < h_.before_offsets[i + 1]; ++k) ++applied_after_[h_.before[k]];
  for (uint32_t k = h_.after_offsets[i]; k < h_.after_offsets[i + 1]; ++k) --split_before_[h_.after[k]];
}

bool VertexFront::split(uint32_t i) {
  std::vector<uint32_t> stack{i};
  while (!stack.empty()) {
    const uint32_t x = stack.back();
    if (!applied_[x]) {
      stack.pop_back();
      continue;
    }
    bool forced = false;
    for (uint32_t k = h_.after_offsets[x]; k < h_.after_offsets[x + 1] && !forced; ++k)
      if (applied_[h_.after[k]]) {
        stack.push_back(h_.after[k]);
        forced = true;
      }
    if (forced) continue;
    apply_split(x);
    stack.pop_back();
  }
  return true;
}

bool VertexFront::collapse(uint32_t i) {
  if (applied_[i]) return true;
  if (split_before_[i] != 0) return false;
  apply_collapse(i);
  return true;
}

std::vector<double> VertexFront::errors(const FrontCriteria& c) const {
  const uint32_t C = h_.collapse_count(), V = h_.input_vertices;
  std::vector<double> e(C);
  SphereTest frustum;
  double eye[3] = {0, 0, 0};
  if (c.camera) {
    const view::Frustum f = view::view_frustum(*c.camera, 0, 1e30);
    for (int k = 0; k < 6; ++k) {
      const auto& q = f.planes[k];
      const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
      frustum.planes[k] = n > 0 ? std::array<double, 4>{q[0] / n, q[1] / n, q[2] / n, q[3] / n} : std::array<double, 4>{0, 0, 0, 1};
    }
    frustum.active = true;
    std::copy(c.camera->eye.begin(), c.camera->eye.end(), eye);
  }
  const bool perspective = c.camera && !c.camera->orthographic;
  const double nearest = diagonal_ / 100;
  const double unit = c.unit_distance > 0 ? c.unit_distance : diagonal_ / 100;
  const std::vector<float> seen = transmittance(c);
  for (uint32_t i = 0; i < C; ++i) {
    const float* p = &h_.positions[3 * (size_t{V} + i)];
    const double r = h_.nodes[i].radius;
    // the quadric error grows with the volume a collapse changes, the image error of a
    // shaded slab with its area times its thickness: one more factor of the radius
    double weight = h_.nodes[i].error * (r / diagonal_);
    bool clipped = false;
    for (const view::Plane& plane : c.clip) {
      const double n = std::sqrt(plane.normal[0] * plane.normal[0] + plane.normal[1] * plane.normal[1] + plane.normal[2] * plane.normal[2]);
      if (plane.side(p[0], p[1], p[2]) > r * n) clipped = true;
    }
    if (clipped) {
      e[i] = 0;
      continue;
    }
    if (!frustum.meets(p, r)) {  // out of view: never worth a tet (forced splits aside)
      e[i] = 0;
      continue;
    }
    if (perspective) {
      const double dx = p[0] - eye[0], dy = p[1] - eye[1], dz = p[2] - eye[2];
      const double z = std::max(std::sqrt(dx * dx + dy * dy + dz * dz) - r, nearest);
      weight *= (diagonal_ / z) * (diagonal_ / z);
      if (!seen.empty()) {
        // at the sphere's point nearest the eye
        const double distance = std::sqrt(dx * dx + dy * dy + dz * dz), back = distance > r ? r / distance : 1;
        const double q[3] = {p[0] - back * dx, p[1] - back * dy, p[2] - back * dz};
        weight *= std::max(double(grid_at(seen, q)), kOccludedWeight);
      }
    }
    if (c.attribute >= 0) {
      const double lo = h_.range_lo(i, static_cast<uint32_t>(c.attribute)), hi = h_.range_hi(i, static_cast<uint32_t>(c.attribute));
      double shown = 1;
      if (!c.isovalues.empty()) {
        shown = 0;
        for (double v : c.isovalues)
          if (v >= lo && v <= hi) shown = 1;
      } else if (!c.opacity.empty()) {
        shown = max_opacity(c, lo, hi);
        // the opacity of a slab as thick as the collapse's sphere
        shown = 1 - std::pow(1 - std::min(shown, 0.999), r / unit);
      }
      weight *= shown + kTransparentWeight;
    }
    for (const view::Plane& plane : c.slices) {
      const double n = std::sqrt(plane.normal[0] * plane.normal[0] + plane.normal[1] * plane.normal[1] + plane.normal[2] * plane.normal[2]);
      if (std::fabs(plane.side(p[0], p[1], p[2])) <= r * n) weight *= kFrontSliceWeight;
    }
    e[i] = weight;
  }
  return e;
}

// update()'s front in the simplification's order: the collapses a split of i needs split (i and, transitively, every applied collapse among
// the `after` of one in the set), with their summed estimate and tets; false when they pass
// `limit` tets.
bool VertexFront::package(uint32_t i, std::span<const double> own, uint64_t limit, Package& out) {
  out.members.clear();
  out.error = 0;
  out.tets = 0;
  if (++epoch_ == 0) {
    std::fill(seen_.begin(), seen_.end(), 0);
    epoch_ = 1;
  }
  std::vector<uint32_t>& stack = stack_;
  stack.assign(1, i);
  while (!stack.empty()) {
    const uint32_t x = stack.back();
    stack.pop_back();
    if (!applied_[x] || seen_[x] == epoch_) continue;
    seen_[x] = epoch_;
    out.members.push_back(x);
    out.error += std::max(0.0, own[x]);
    out.tets += h_.nodes[x].fan;
    if (out.tets > limit) return false;
    for (uint32_t k = h_.after_offsets[x]; k < h_.after_offsets[x + 1]; ++k)
      if (applied_[h_.after[k]] && seen_[h_.after[k]] != epoch_) stack.push_back(h_.after[k]);
  }
  return true;
}

FrontChanges VertexFront::update_packages(uint64_t budget) {
  FrontChanges changes;
  changes.budget = budget;
  collapse_all();
  const uint32_t C = h_.collapse_count();
  const std::vector<double>& own = own_;
  seen_.resize(C);
  // A split is ranked by the error its package removes (it and the splits it forces) per tet
  // the package adds, evaluated lazily: a collapse taken from the queue is measured against
  // the front of the moment (its first kPartial members while its key is an estimate, the
  // whole package once it comes first) and taken when it still ranks first, else queued again
  // at its measured rank.
  struct Entry {
    double rank;
    uint32_t collapse;
    bool whole;  // measured over its whole package
    bool operator<(const Entry& o) const { return rank < o.rank || (rank == o.rank && collapse < o.collapse); }  // ties: the later collapse first
  };
  std::priority_queue<Entry> queue;
  uint64_t all_tets = tets_;  // the input mesh's
  for (uint32_t i = 0; i < C; ++i) {
    all_tets += h_.nodes[i].fan;
    if (own[i] > 0) queue.push({own[i] / std::max<uint32_t>(h_.nodes[i].fan, 1), i, false});
  }
  changes.over_budget = tets_ > budget;
  constexpr uint64_t kPartial = 96;  // tets
  const uint64_t slack = budget / 200;  // within 0.5% of the budget the front stops looking
  Package p;
  while (!queue.empty()) {
    const Entry top = queue.top();
    const uint32_t i = top.collapse;
    queue.pop();
    if (!applied_[i]) continue;
    if (tets_ + slack >= budget && all_tets > budget) {
      changes.budget_limited = true;
      break;
    }
    if (all_tets <= budget) {  // every split fits: the order does not matter
      split(i);
      continue;
    }
    const bool whole = top.whole || package(i, own, kPartial, p);
    if (!top.whole) {
      const double rank = p.error / std::max<uint64_t>(p.tets, 1);
      if (!queue.empty() && rank < queue.top().rank) {
        queue.push({rank, i, whole});
        continue;
      }
    }
    const bool measured = !top.whole && whole;  // p already holds the whole package
    if (!(measured && p.tets <= budget - tets_) && !package(i, own, budget - tets_, p)) {  // it no longer fits: the budget only shrinks
      changes.budget_limited = true;
      continue;
    }
    const double rank = p.error / std::max<uint64_t>(p.tets, 1);
    if (!queue.empty() && rank < queue.top().rank) {
      queue.push({rank, i, true});
      continue;
    }
    for (uint32_t x : p.members)
      if (x != i) changes.forced_tets += h_.nodes[x].fan;
    split(i);
  }
  for (uint32_t i = 0; i < C; ++i)
    if (!applied_[i]) {
      ++changes.splits;
      if (own[i] <= 0) changes.unseen_tets += h_.nodes[i].fan;
    }
  changes.complete = !changes.budget_limited;
  changes.tets = tets_;
  for (uint32_t i = 0; i < C; ++i)
    if (applied_[i]) changes.estimated_error += own[i];
  return changes;
}

storage::TetMesh VertexFront::mesh(std::vector<uint32_t>* vertex_ids, const float* values) const {
  const float* source = values ? values : h_.values.data();
  const uint32_t V = h_.input_vertices, N = h_.vertex_count();
  std::vector<uint32_t> rep(N);
  for (uint32_t v = N; v-- > 0;) {
    const uint32_t p = parent_[v];
    rep[v] = p != kNoCollapse && applied_[p] ? rep[V + p] : v;
  }
  storage::TetMesh out;
  std::vector<uint32_t> index(N, kNoCollapse);
  std::vector<uint32_t> tets;
  tets.reserve(4 * tets_);
  for (size_t t = 0; t < h_.killer.size(); ++t) {
    const uint32_t v[4] = {rep[h_.tets[4 * t]], rep[h_.tets[4 * t + 1]], rep[h_.tets[4 * t + 2]], rep[h_.tets[4 * t + 3]]};
    if (v[0] == v[1] || v[0] == v[2] || v[0] == v[3] || v[1] == v[2] || v[1] == v[3] || v[2] == v[3]) continue;  // degenerate
    for (uint32_t u : v) {
      index[u] = 0;
      tets.push_back(u);
    }
  }
  std::vector<uint32_t> ids;
  for (uint32_t v = 0; v < N; ++v)
    if (index[v] == 0) {
      index[v] = static_cast<uint32_t>(ids.size());
      ids.push_back(v);
    }
  for (uint32_t& v : tets) v = index[v];
  out.tets = std::move(tets);
  out.x.resize(ids.size());
  out.y.resize(ids.size());
  out.z.resize(ids.size());
  for (size_t k = 0; k < ids.size(); ++k) {
    out.x[k] = h_.positions[3 * size_t{ids[k]}];
    out.y[k] = h_.positions[3 * size_t{ids[k]} + 1];
    out.z[k] = h_.positions[3 * size_t{ids[k]} + 2];
  }
  uint32_t first = 0;
  for (const auto& info : h_.attributes) {
    storage::Attribute a;
    a.info = info;
    a.values.resize(ids.size() * info.components);
    for (size_t k = 0; k < ids.size(); ++k)
      for (uint32_t j = 0; j < info.components; ++j) a.values[k * info.components + j] = source[size_t{ids[k]} * h_.value_floats + first + j];
    first += info.components;
    out.attributes.push_back(std::move(a));
  }
  if (vertex_ids) *vertex_ids = std::move(ids);
  return out;
}

}  // namespace tetrascope::lod
