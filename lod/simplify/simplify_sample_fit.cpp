// The sampler's vertex values by least squares: the output's linear interpolant fitted to the
// input's vertex values (an L2 projection at the input vertices), rather than the samples'
// own values. Each input vertex is located in the output (a kept one is its own output
// vertex; any other, the output tet holding it, found by walking from a located neighbour,
// or the last one before the border with the weights clamped); the normal
// equations W^T W a = W^T f, with a small pull towards the sampled values that keeps them
// definite, are solved per component by conjugate gradients with a Jacobi preconditioner.
// Locked output vertices keep their values bit-identical; tensors keep theirs.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "simplify_sample.h"
#include "tet_locator.h"

namespace tetrascope::lod::detail {
namespace {

constexpr int kMaxIterations = 40;
constexpr double kTolerance = 1e-7;  // relative residual of the normal equations
constexpr double kPull = 1e-3;       // the pull towards the sampled values, times the mean diagonal

// Per input vertex: up to 4 output vertices and their weights (unused slots weigh 0).
struct Rows {
  std::vector<std::array<uint32_t, 4>> vertex;
  std::vector<std::array<float, 4>> weight;
};

constexpr int kMaxWalk = 512;

// Per output tet and corner: the tet across the face opposite that corner (kNoTet on the border).
std::vector<uint32_t> face_neighbours(const storage::TetMesh& out) {
  struct Face {
    std::array<uint32_t, 3> key;
    uint32_t slot;
  };
  std::vector<Face> faces(out.tets.size());
  for (uint32_t s = 0; s < faces.size(); ++s) {
    const uint32_t t = s / 4, k = s % 4;
    std::array<uint32_t, 3> f;
    for (uint32_t j = 0, n = 0; j < 4; ++j)
      if (j != k) f[n++] = out.tets[4 * size_t{t} + j];
    std::sort(f.begin(), f.end());
    faces[s] = {f, s};
  }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  std::vector<uint32_t> across(out.tets.size(), kNoTet);
  for (size_t i = 0; i + 1 < faces.size(); ++i)
    if (faces[i].key == faces[i + 1].key) {
      across[faces[i].slot] = faces[i + 1].slot / 4;
      across[faces[i + 1].slot] = faces[i].slot / 4;
    }
  return across;
}

// Walks from tet t towards p, across the face p is farthest beyond; the tet holding p, or the
// last one before the border (or a flat tet, or the step limit), with p's weights clamped to it.
uint32_t walk(const TetLocator& locator, const std::vector<uint32_t>& across, uint32_t t, const Vec3& p, double w[4]) {
  for (int step = 0; step < kMaxWalk; ++step) {
    if (!locator.weights(t, p, w)) break;
    const int k = static_cast<int>(std::min_element(w, w + 4) - w);
    if (w[k] >= -1e-9 || across[4 * size_t{t} + k] == kNoTet) break;
    t = across[4 * size_t{t} + k];
  }
  double sum = 0;
  for (int k = 0; k < 4; ++k) sum += (w[k] = std::isfinite(w[k]) ? std::max(0.0, w[k]) : 0.0);
  if (!(sum > 0)) w[0] = 1, w[1] = w[2] = w[3] = 0, sum = 1;
  for (int k = 0; k < 4; ++k) w[k] /= sum;
  return t;
}

// Locates every used input vertex in out: a kept one is its own output vertex; the others are
// reached breadth first over the input's tets from the kept ones, each walk starting in the
// tet where an already located neighbour lies.
Rows locate_inputs(const storage::TetMesh& input, const storage::TetMesh& out, const std::vector<uint32_t>& source_vertex) {
  const size_t nv = input.vertex_count(), nt = input.tet_count();
  std::vector<uint32_t> tet_of(nv, kNoTet), row_of(nv, kNoTet);
  std::vector<uint32_t> first(nv + 1, 0), star(input.tets.size());
  for (uint32_t v : input.tets) ++first[v + 1];
  for (size_t v = 0; v < nv; ++v) first[v + 1] += first[v];
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (uint32_t t = 0; t < nt; ++t)
      for (int k = 0; k < 4; ++k) star[fill[input.tets[4 * size_t{t} + k]]++] = t;
  }
  Rows rows;
  std::vector<uint32_t> queue;
  std::vector<uint32_t> out_tet(out.vertex_count(), kNoTet);
  for (uint32_t t = 0; t < out.tet_count(); ++t)
    for (int k = 0; k < 4; ++k) out_tet[out.tets[4 * size_t{t} + k]] = t;
  for (uint32_t o = 0; o < source_vertex.size(); ++o) {
    const uint32_t v = source_vertex[o];
    if (v >= nv || first[v] == first[v + 1] || out_tet[o] == kNoTet) continue;
    tet_of[v] = out_tet[o];
    row_of[v] = static_cast<uint32_t>(rows.vertex.size());
    rows.vertex.push_back({o, o, o, o});
    rows.weight.push_back({1, 0, 0, 0});
    queue.push_back(v);
  }
  const TetLocator locator(out);
  const std::vector<uint32_t> across = face_neighbours(out);
  auto add = [&](uint32_t v, uint32_t t, const double w[4]) {
    tet_of[v] = t;
    row_of[v] = static_cast<uint32_t>(rows.vertex.size());
    rows.vertex.push_back({out.tets[4 * size_t{t}], out.tets[4 * size_t{t} + 1], out.tets[4 * size_t{t} + 2], out.tets[4 * size_t{t} + 3]});
    rows.weight.push_back({float(w[0]), float(w[1]), float(w[2]), float(w[3])});
    queue.push_back(v);
  };
  double w[4];
  for (uint32_t v = 0; v < nv; ++v) {  // no kept vertex in a component: one located directly
    if (first[v] == first[v + 1] || tet_of[v] != kNoTet) continue;
    if (queue.empty()) add(v, locator.nearest({input.x[v], input.y[v], input.z[v]}, w), w);
    for (size_t head = 0; head < queue.size(); ++head) {
      const uint32_t u = queue[head];
      for (uint32_t i = first[u]; i < first[u + 1]; ++i)
        for (int k = 0; k < 4; ++k) {
          const uint32_t x = input.tets[4 * size_t{star[i]} + k];
          if (tet_of[x] != kNoTet) continue;
          add(x, walk(locator, across, tet_of[u], {input.x[x], input.y[x], input.z[x]}, w), w);
        }
    }
    queue.clear();
  }
  // rows in input vertex order, as targets() lists the values
  Rows ordered;
  for (uint32_t v = 0; v < nv; ++v)
    if (row_of[v] != kNoTet) {
      ordered.vertex.push_back(rows.vertex[row_of[v]]);
      ordered.weight.push_back(rows.weight[row_of[v]]);
    }
  return ordered;
}

// The input rows' targets for one component, or false when a value is not finite.
bool targets(const storage::TetMesh& input, size_t attribute, uint32_t component, std::vector<double>& f) {
  const auto& a = input.attributes[attribute];
  const uint32_t c = a.info.components;
  std::vector<uint8_t> used(input.vertex_count(), 0);
  for (uint32_t v : input.tets) used[v] = 1;
  f.clear();
  for (size_t v = 0; v < used.size(); ++v) {
    if (!used[v]) continue;
    const double value = a.values[v * c + component];
    if (!std::isfinite(value)) return false;
    f.push_back(value);
  }
  return true;
}

class NormalEquations {
 public:
  NormalEquations(const Rows& rows, const std::vector<uint8_t>& fixed, size_t unknowns) : rows_(rows), fixed_(fixed), diagonal_(unknowns, 0.0) {
    for (size_t i = 0; i < rows.vertex.size(); ++i)
      for (int k = 0; k < 4; ++k) diagonal_[rows.vertex[i][k]] += double(rows.weight[i][k]) * rows.weight[i][k];
    double sum = 0;
    for (double d : diagonal_) sum += d;
    pull_ = kPull * std::max(1e-12, sum / double(std::max<size_t>(1, unknowns)));
    for (double& d : diagonal_) d += pull_;
  }

  // y = (W^T W + pull) x, with the fixed vertices' rows and columns left out (x there: 0)
  void apply(const std::vector<double>& x, std::vector<double>& y) const {
    std::fill(y.begin(), y.end(), 0.0);
    for (size_t i = 0; i < rows_.vertex.size(); ++i) {
      const auto& v = rows_.vertex[i];
      const auto& w = rows_.weight[i];
      const double r = w[0] * x[v[0]] + w[1] * x[v[1]] + w[2] * x[v[2]] + w[3] * x[v[3]];
      for (int k = 0; k < 4; ++k) y[v[k]] += w[k] * r;
    }
    for (size_t j = 0; j < y.size(); ++j) y[j] = fixed_[j] ? 0.0 : y[j] + pull_ * x[j];
  }

  // b = W^T (f - W a0): the right side for the correction to a0
  void right_side(const std::vector<double>& f, const std::vector<double>& a0, std::vector<double>& b) const {
    std::fill(b.begin(), b.end(), 0.0);
    for (size_t i = 0; i < rows_.vertex.size(); ++i) {
      const auto& v = rows_.vertex[i];
      const auto& w = rows_.weight[i];
      const double r = f[i] - (w[0] * a0[v[0]] + w[1] * a0[v[1]] + w[2] * a0[v[2]] + w[3] * a0[v[3]]);
      for (int k = 0; k < 4; ++k) b[v[k]] += w[k] * r;
    }
    for (size_t j = 0; j < b.size(); ++j)
      if (fixed_[j]) b[j] = 0;
  }

  double diagonal(size_t j) const { return diagonal_[j]; }

 private:
  const Rows& rows_;
  const std::vector<uint8_t>& fixed_;
  std::vector<double> diagonal_;
  double pull_ = 0;
};

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

// Preconditioned conjugate gradients for the correction d to a0; returns iterations taken.
int solve(const NormalEquations& system, const std::vector<double>& b, std::vector<double>& d) {
  const size_t n = b.size();
  std::vector<double> r = b, z(n), p(n), q(n);
  std::fill(d.begin(), d.end(), 0.0);
  for (size_t j = 0; j < n; ++j) z[j] = r[j] / system.diagonal(j);
  p = z;
  double rz = dot(r, z);
  const double stop = kTolerance * kTolerance * std::max(dot(b, b), 1e-300);
  int it = 0;
  for (; it < kMaxIterations && dot(r, r) > stop; ++it) {
    system.apply(p, q);
    const double pq = dot(p, q);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    for (size_t j = 0; j < n; ++j) d[j] += alpha * p[j], r[j] -= alpha * q[j];
    for (size_t j = 0; j < n; ++j) z[j] = r[j] / system.diagonal(j);
    const double rz_next = dot(r, z);
    const double beta = rz_next / rz;
    rz = rz_next;
    for (size_t j = 0; j < n; ++j) p[j] = z[j] + beta * p[j];
  }
  return it;
}

}  // namespace

uint64_t fit_values(const storage::TetMesh& input, storage::TetMesh& out, const std::vector<uint32_t>& source_vertex, const std::vector<uint8_t>& fixed) {
  const size_t n = out.vertex_count();
  if (out.tet_count() == 0 || input.tet_count() == 0 || n == 0) return 0;
  const Rows rows = locate_inputs(input, out, source_vertex);
  const NormalEquations system(rows, fixed, n);
  std::vector<double> f, a0(n), b(n), d(n);
  uint64_t iterations = 0;
  for (size_t a = 0; a < out.attributes.size() && a < input.attributes.size(); ++a) {
    auto& attribute = out.attributes[a];
    if (attribute.info.kind != storage::AttributeKind::kValue) continue;  // tensors keep their values; derived scalars follow them
    const uint32_t c = attribute.info.components;
    for (uint32_t k = 0; k < c; ++k) {
      if (!targets(input, a, k, f)) continue;
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (double value : f) lo = std::min(lo, value), hi = std::max(hi, value);
      bool finite = true;
      for (size_t j = 0; j < n; ++j) finite = finite && std::isfinite(a0[j] = attribute.values[j * c + k]);
      if (!finite) continue;
      system.right_side(f, a0, b);
      iterations += solve(system, b, d);
      for (size_t j = 0; j < n; ++j) {
        if (fixed[j]) continue;
        // a fit overshoots near steps; the values stay in the input's range (vectors' components too)
        const double value = c == 1 ? std::clamp(a0[j] + d[j], lo, hi) : a0[j] + d[j];
        attribute.values[j * c + k] = static_cast<float>(value);
      }
    }
  }
  return iterations;
}

}  // namespace tetrascope::lod::detail
