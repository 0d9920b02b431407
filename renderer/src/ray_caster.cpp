// The CPU ray caster: one ray a pixel, in tiles over the cores. A ray enters the mesh through
// a boundary face (found in a bounding volume hierarchy of the boundary) or starts in the
// tet that holds the eye, then walks from tet to tet through the face it leaves by, with
// exact segment lengths, composing the GL path's pre-integrated table where a segment's value
// spans one of its bins and integrating the transfer function's finely tabulated extinction
// where the value is nearly constant (there, however long the segment, the table's
// interpolation between bins would veil thin opacity), until it is opaque or leaves the mesh
// (and finds where it enters again, for meshes with holes). Isosurfaces and slices are
// composed in the walk as the reference integrator does.
#include "tetrascope/renderer/ray_caster.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "camera_math.h"
#include "slice_hits.h"
#include "tet_field.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {
namespace {

constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr uint32_t kTile = 16;
constexpr double kOpaque = 0.999;  // a ray stops here (the reference: 0.9999)
constexpr uint32_t kClassified = 65536;  // intervals of the transfer function's extinction (its opacity: kinks matter)
constexpr uint32_t kColors = 4096;       // intervals of its colour
constexpr double kStepsPerRange = 1024;  // fine steps a segment spanning the colour range would take
constexpr int kMaxFineSteps = 8;         // = kStepsPerRange / the pre-integrated table's 128 bins

struct Box {
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  void add(const Vec3& p) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  void add(const Box& b) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], b.lo[k]);
      hi[k] = std::max(hi[k], b.hi[k]);
    }
  }
  // the ray's parameter range inside the box, [t0, t1] clipped to [tmin, tmax]; false: none
  bool slab(const Vec3& o, const Vec3& inv, double tmin, double tmax) const {
    for (int k = 0; k < 3; ++k) {
      double a = (lo[k] - o[k]) * inv[k], b = (hi[k] - o[k]) * inv[k];
      if (a > b) std::swap(a, b);
      tmin = std::max(tmin, a);
      tmax = std::min(tmax, b);
      if (tmin > tmax) return false;
    }
    return true;
  }
};

// Möller–Trumbore: the ray parameter where it meets triangle abc, or NaN.
double hit_triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, p = cross(d, e2);
  const double det = dot(e1, p);
  if (std::fabs(det) < 1e-300) return NAN;
  const double inv = 1 / det;
  const Vec3 s = o - a;
  const double u = dot(s, p) * inv;
  if (u < -1e-9 || u > 1 + 1e-9) return NAN;
  const Vec3 q = cross(s, e1);
  const double v = dot(d, q) * inv;
  if (v < -1e-9 || u + v > 1 + 1e-9) return NAN;
  return dot(e2, q) * inv;
}

}  // namespace

bool software_renderer(const std::string& description) {
  for (const char* name : {"llvmpipe", "softpipe", "swrast"})
    if (description.find(name) != std::string::npos) return true;
  return false;
}

bool known_backend(const std::string& name) { return name == "gl" || name == "cpu" || name == "auto"; }

struct RayCaster::Bvh {
  struct Node {
    Box box;
    uint32_t first = 0, count = 0;  // leaf: faces [first, first + count); inner: count 0, children first, first + 1
  };
  std::vector<Node> nodes;
  std::vector<uint32_t> faces;  // 4 * tet + face, leaves' order
};

RayCaster::RayCaster(const SceneMesh& mesh) : mesh_(mesh), bvh_(std::make_unique<Bvh>()) {
  const size_t T = mesh.tets.size() / 4;
  opposite_ = pair_faces(mesh.tets).opposite;
  cells_.resize(T);
  auto point = [&](uint32_t v) { return Vec3{mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2]}; };
  for (size_t t = 0; t < T; ++t) {
    Cell& cell = cells_[t];
    Vec3 p[4];
    for (int k = 0; k < 4; ++k) p[k] = point(mesh.tets[4 * t + k]);
    for (int f = 0; f < 4; ++f) {
      const Vec3& a = p[kTetFace[f][0]];
      Vec3 n = cross(p[kTetFace[f][1]] - a, p[kTetFace[f][2]] - a);
      if (dot(n, p[f] - a) > 0) n = n * -1.0;  // outward whatever the tet's orientation
      cell.plane[f] = {n[0], n[1], n[2], -dot(n, a)};
    }
    double s[4];
    for (int k = 0; k < 4; ++k) s[k] = mesh.value[mesh.tets[4 * t + k]];
    Vec3 g;
    double c;
    cell.flat = !linear_field(p, s, &g, &c);
    cell.gradient = cell.flat ? std::array<double, 4>{0, 0, 0, 0} : std::array<double, 4>{g[0], g[1], g[2], c};
  }
  // the boundary faces in a binary hierarchy of boxes, split at the median of the longest axis
  std::vector<uint32_t>& faces = bvh_->faces;
  for (uint32_t f = 0; f < opposite_.size(); ++f)
    if (opposite_[f] == kNoOppositeFace) faces.push_back(f);
  std::vector<Box> boxes(faces.size());
  std::vector<Vec3> centre(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    const uint32_t t = faces[i] / 4, f = faces[i] % 4;
    for (int k = 0; k < 3; ++k) boxes[i].add(point(mesh.tets[4 * size_t{t} + kTetFace[f][k]]));
    for (int k = 0; k < 3; ++k) centre[i][k] = 0.5 * (boxes[i].lo[k] + boxes[i].hi[k]);
  }
  std::vector<uint32_t> order(faces.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  struct Task {
    uint32_t node, first, count;
  };
  bvh_->nodes.push_back({});
  std::vector<Task> stack{{0, 0, static_cast<uint32_t>(order.size())}};
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    Box box, centres;
    for (uint32_t i = task.first; i < task.first + task.count; ++i) {
      box.add(boxes[order[i]]);
      centres.add(centre[order[i]]);
    }
    bvh_->nodes[task.node].box = box;
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (centres.hi[k] - centres.lo[k] > centres.hi[axis] - centres.lo[axis]) axis = k;
    if (task.count <= 4 || !(centres.hi[axis] > centres.lo[axis])) {
      bvh_->nodes[task.node].first = task.first;
      bvh_->nodes[task.node].count = task.count;
      continue;
    }
    const uint32_t half = task.count / 2;
    std::nth_element(order.begin() + task.first, order.begin() + task.first + half, order.begin() + task.first + task.count,
                     [&](uint32_t a, uint32_t b) { return centre[a][axis] < centre[b][axis]; });
    const uint32_t left = static_cast<uint32_t>(bvh_->nodes.size());
    bvh_->nodes.push_back({});
    bvh_->nodes.push_back({});
    bvh_->nodes[task.node].first = left;
    bvh_->nodes[task.node].count = 0;
    stack.push_back({left, task.first, half});
    stack.push_back({left + 1, task.first + half, task.count - half});
  }
  std::vector<uint32_t> sorted(faces.size());
  for (size_t i = 0; i < order.size(); ++i) sorted[i] = faces[order[i]];
  faces = std::move(sorted);
}

RayCaster::~RayCaster() = default;

std::string RayCaster::unsupported(const RenderSettings& s) {
  if (s.surface || s.wireframe || s.box) return "surfaces, wireframes and boxes";
  if (s.points) return "point-based isosurfaces";
  if (s.lines) return "stream lines";
  if (s.use_iso_color_attribute) return "isosurfaces coloured by another attribute";
  if (!s.dvr) return "isosurfaces or slices without the volume";
  if (s.volume == view::VolumeMethod::projected) return "--volume projected";
  return "";
}

// The nearest boundary face the ray enters by at a parameter from `after` on (less a rounding,
// so that a ray leaving by an unpaired face finds a face at the same place: internal
// boundaries between regions), `left` (the face it left by) aside: 4 * tet + face, or kNone.
uint32_t RayCaster::enter(const Vec3& o, const Vec3& d, double after, double* t_hit, uint32_t left) const {
  after -= 1e-9 * mesh_.diagonal / std::max(1e-300, std::sqrt(dot(d, d)));
  const Vec3 inv{1 / d[0], 1 / d[1], 1 / d[2]};
  double best = INFINITY;
  uint32_t found = kNone;
  uint32_t stack[64];
  int top = 0;
  if (bvh_->nodes.empty() || bvh_->faces.empty()) return kNone;
  stack[top++] = 0;
  auto point = [&](uint32_t v) { return Vec3{mesh_.xyz[3 * size_t{v}], mesh_.xyz[3 * size_t{v} + 1], mesh_.xyz[3 * size_t{v} + 2]}; };
  while (top > 0) {
    const Bvh::Node& node = bvh_->nodes[stack[--top]];
    if (!node.box.slab(o, inv, after, best)) continue;
    if (node.count == 0) {
      if (top + 2 > 64) continue;  // deeper than any median split of 2^32 faces
      stack[top++] = node.first;
      stack[top++] = node.first + 1;
      continue;
    }
    for (uint32_t i = node.first; i < node.first + node.count; ++i) {
      const uint32_t face = bvh_->faces[i], t = face / 4, f = face % 4;
      const double h = hit_triangle(o, d, point(mesh_.tets[4 * size_t{t} + kTetFace[f][0]]), point(mesh_.tets[4 * size_t{t} + kTetFace[f][1]]),
                                    point(mesh_.tets[4 * size_t{t} + kTetFace[f][2]]));
      if (h >= after && h < best && face != left) {
        // entering: the ray runs against the face's outward normal
        const auto& q = cells_[t].plane[f];
        if (q[0] * d[0] + q[1] * d[1] + q[2] * d[2] >= 0) continue;
        best = h;
        found = face;
      }
    }
  }
  *t_hit = best;
  return found;
}

// Near tets `from` and `also`, the tet that holds the point o + t d: a search across the
// interior faces whose planes the point is outside of, nearest tets first (at most 48); kNone
// when none holds it (the point is outside the mesh, or farther than that).
uint32_t RayCaster::walk_to(uint32_t from, uint32_t also, const Vec3& o, const Vec3& d, double t) const {
  const Vec3 p{o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
  uint32_t queue[48];
  size_t head = 0, tail = 0;
  auto push = [&](uint32_t tet) {
    if (tet == kNone || tail == 48) return;
    for (size_t i = 0; i < tail; ++i)
      if (queue[i] == tet) return;
    queue[tail++] = tet;
  };
  push(from);
  push(also);
  while (head < tail) {
    const uint32_t tet = queue[head++];
    const Cell& c = cells_[tet];
    bool outside = false;
    for (int f = 0; f < 4; ++f) {
      const auto& q = c.plane[f];
      const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
      if (!((q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3]) / std::max(n, 1e-300) > 0)) continue;
      outside = true;
      const uint32_t across = opposite_[4 * size_t{tet} + f];
      if (across != kNoOppositeFace) push(across / 4);
    }
    if (!outside && !c.flat) return tet;
  }
  return kNone;
}

// The tet that holds `p`, or kNone (every tet's planes, once a frame, for an eye inside the
// mesh's box).
uint32_t RayCaster::locate(const Vec3& p) const {
  const double margin_of_box = 1e-9 * mesh_.diagonal;
  for (int k = 0; k < 3; ++k)
    if (p[k] < mesh_.bounds.min[k] - margin_of_box || p[k] > mesh_.bounds.max[k] + margin_of_box) return kNone;  // outside every tet
  uint32_t best = kNone;
  double best_margin = -INFINITY;
  for (uint32_t t = 0; t < cells_.size(); ++t) {
    const Cell& c = cells_[t];
    if (c.flat) continue;
    double margin = INFINITY;
    for (int f = 0; f < 4; ++f) {
      const auto& q = c.plane[f];
      const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
      margin = std::min(margin, -(q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3]) / n);
    }
    if (margin >= 0) return t;
    if (margin > best_margin) {
      best_margin = margin;
      best = t;
    }
  }
  // within a rounding of a face: the nearest tet
  return best_margin > -1e-9 * mesh_.diagonal ? best : kNone;
}

// What a frame's rays compose: the colour range, the tables of the transfer function and the
// isosurfaces.
struct RayCaster::Shading {
  double lo = 0, hi = 1, scale = 1, unit = 1;
  const PreintegrationTable* table = nullptr;
  const std::vector<float>* extinction = nullptr;
  const std::vector<std::array<float, 3>>* colors = nullptr;
  double table_bins = 1, log_range = 1;
  std::vector<double> isos;  // normalised, ascending, distinct
  std::vector<std::array<double, 3>> iso_rgb;
  double iso_opacity = 1;
};

namespace {

// The colour and opacity of a segment from value sf to sb (normalised) of `length`. A segment
// whose value spans a bin of the pre-integrated table or more reads the table (as the GL path
// does); a nearly constant one (most of them, in fine meshes and over long paths) is integrated
// in up to kMaxFineSteps steps over the fine extinction, where a table interpolated between its
// bins would veil thin opacity near a kink.
template <class Shading>
void integrate(const Shading& sh, double sf, double sb, double length, double out[4]) {
  const double span = std::fabs(sb - sf);
  if (span * sh.table_bins >= 1) {
    const PreintegrationTable& table = *sh.table;
    const uint32_t n = table.n, L = table.lengths;
    const double u = std::clamp(sf, 0.0, 1.0) * (n - 1), v = std::clamp(sb, 0.0, 1.0) * (n - 1);
    const double w = std::clamp(std::log1p(static_cast<float>(std::max(length, 0.0) / table.length_scale)) / sh.log_range, 0.0, 1.0) * (L - 1);
    const uint32_t i0 = std::min(static_cast<uint32_t>(u), n - 2), j0 = std::min(static_cast<uint32_t>(v), n - 2), m0 = std::min(static_cast<uint32_t>(w), L - 2);
    const double fu = u - i0, fv = v - j0, fw = w - m0;
    for (int k = 0; k < 4; ++k) out[k] = 0;
    for (int dm = 0; dm < 2; ++dm)
      for (int dj = 0; dj < 2; ++dj) {
        const float* c = &table.rgba[((size_t{m0 + dm} * n + j0 + dj) * n + i0) * 4];
        const double weight = (dm ? fw : 1 - fw) * (dj ? fv : 1 - fv);
        for (int k = 0; k < 4; ++k) out[k] += weight * ((1 - fu) * c[k] + fu * c[4 + k]);
      }
    return;
  }
  const std::vector<float>& extinction = *sh.extinction;
  const std::vector<std::array<float, 3>>& colors = *sh.colors;
  const int steps = std::clamp(static_cast<int>(std::ceil(span * kStepsPerRange)), 1, kMaxFineSteps);
  const double dt = length / steps;
  double r = 0, g = 0, b = 0, keep = 1;  // keep: the transmittance so far
  for (int k = 0; k < steps; ++k) {
    const double s = std::clamp(sf + (sb - sf) * (k + 0.5) / steps, 0.0, 1.0);
    const double x = s * kClassified;
    const uint32_t i = std::min(static_cast<uint32_t>(x), kClassified - 1);
    const double depth = (extinction[i] + (x - i) * (extinction[i + 1] - extinction[i])) * dt;
    // 1 - exp(-depth): a series where it is small (most steps), else the library's
    const double alpha = depth < 0.03 ? depth * (1 - depth * (0.5 - depth * (1.0 / 6 - depth * (1.0 / 24)))) : -std::expm1(-depth);
    const double weight = keep * alpha;
    const double y = s * kColors;
    const uint32_t j = std::min(static_cast<uint32_t>(y), kColors - 1);
    const float f = static_cast<float>(y - j);
    const auto& c0 = colors[j];
    const auto& c1 = colors[j + 1];
    r += weight * (c0[0] + f * (c1[0] - c0[0]));
    g += weight * (c0[1] + f * (c1[1] - c0[1]));
    b += weight * (c0[2] + f * (c1[2] - c0[2]));
    keep *= 1 - alpha;
  }
  out[0] = r;
  out[1] = g;
  out[2] = b;
  out[3] = 1 - keep;
}

}  // namespace

// The frame's shading: the colour range, the tables (remade when the transfer function, its
// range or the unit distance change) and the isosurfaces.
void RayCaster::shading(const RenderSettings& settings, Shading& sh) const {
  const auto [lo, hi] = colour_range(mesh_, settings.tf);
  sh.lo = lo;
  sh.hi = hi;
  sh.scale = 1 / (hi - lo);
  sh.unit = settings.unit_distance > 0 ? settings.unit_distance : mesh_.diagonal / 100;
  const std::string key = settings.tf.key() + "|" + std::to_string(lo) + "|" + std::to_string(hi) + "|" + std::to_string(sh.unit);
  {
    // the pre-integrated table of the GL path, and the transfer function on a fine grid of
    // the colour range: extinction per unit length (from its own opacity at every grid value)
    // and colour
    std::lock_guard lock(table_mutex_);
    if (key != table_key_) {
      table_ = preintegrate(settings.tf, lo, hi, sh.unit, std::exp2(std::ceil(std::log2(std::max(mesh_.max_edge, 1e-30)))));
      extinction_.resize(kClassified + 1);
      for (uint32_t k = 0; k <= kClassified; ++k) {
        const double alpha = std::clamp(settings.tf.alpha(lo + (hi - lo) * k / kClassified), 0.0, 0.999999);
        extinction_[k] = static_cast<float>(-std::log1p(-alpha) / sh.unit);
      }
      colors_.resize(kColors + 1);
      for (uint32_t k = 0; k <= kColors; ++k) {
        const auto color = settings.tf.colors.empty() ? colormap(settings.tf.colormap, double(k) / kColors) : settings.tf.user_color(lo + (hi - lo) * k / kColors);
        colors_[k] = {color[0], color[1], color[2]};
      }
      table_key_ = key;
    }
  }
  sh.table = &table_;
  sh.extinction = &extinction_;
  sh.colors = &colors_;
  sh.table_bins = table_.n - 1;
  sh.log_range = std::log1p(table_.max_length / table_.length_scale);
  if (settings.iso)
    for (double v : settings.isovalues) sh.isos.push_back((v - lo) * sh.scale);
  std::sort(sh.isos.begin(), sh.isos.end());
  sh.isos.erase(std::unique(sh.isos.begin(), sh.isos.end()), sh.isos.end());
  sh.iso_opacity = std::clamp(settings.iso_opacity, 0.0, 1.0);
  for (double iv : sh.isos) {
    const auto c = settings.tf.colors.empty() ? colormap(settings.tf.colormap, std::clamp(iv, 0.0, 1.0)) : settings.tf.user_color(lo + std::clamp(iv, 0.0, 1.0) * (hi - lo));
    sh.iso_rgb.push_back({c[0], c[1], c[2]});
  }
}

// One ray from o along d, up to `stop` (a slice; +inf: none), starting in `eye_tet` (kNone: at
// the boundary face it enters by): the colour and opacity composed into acc, the tets visited
// added to `visits`.
void RayCaster::trace(const Shading& sh, const Vec3& o, const Vec3& d, double stop, uint32_t eye_tet, double acc[4], uint64_t& visits) const {
  const double dl = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  auto over = [&](const double c[4]) {
    const double keep = 1 - acc[3];
    for (int k = 0; k < 4; ++k) acc[k] += keep * c[k];
  };
  uint32_t tet = eye_tet, entry = 4, previous = kNone;
  double t_in = 0;
  if (tet == kNone) {
    const uint32_t face = enter(o, d, 0, &t_in, kNone);
    if (face == kNone) return;
    tet = face / 4;
    entry = face % 4;
  }
  uint64_t guard = 4 * cells_.size() + 16;
  while (tet != kNone && acc[3] < kOpaque && t_in < stop && guard-- > 0) {
    ++visits;
    const Cell& cell = cells_[tet];
    double t_out = INFINITY;
    int exit = -1;
    for (int f = 0; f < 4; ++f) {
      if (f == static_cast<int>(entry)) continue;
      const auto& q = cell.plane[f];
      const double dn = q[0] * d[0] + q[1] * d[1] + q[2] * d[2];
      if (dn <= 0) continue;
      const double t = -(q[0] * o[0] + q[1] * o[1] + q[2] * o[2] + q[3]) / dn;
      if (t < t_out) {
        t_out = t;
        exit = f;
      }
    }
    if (exit < 0 && !cell.flat) {
      // a ray along a face or through an edge (rounding left no face ahead): it leaves where
      // it is by the face it runs least into, rather than skipping to the boundary
      double most = -INFINITY;
      for (int f = 0; f < 4; ++f) {
        if (f == static_cast<int>(entry)) continue;
        const auto& q = cell.plane[f];
        const double dn = q[0] * d[0] + q[1] * d[1] + q[2] * d[2];
        if (dn > most) {
          most = dn;
          exit = f;
        }
      }
      t_out = t_in;
    }
    if (exit < 0) {  // a flat tet: look for the boundary past this point
      const uint32_t face = enter(o, d, t_in + 1e-6 * mesh_.diagonal / dl, &t_in, kNone);
      tet = face == kNone ? kNone : face / 4;
      entry = face == kNone ? 4 : face % 4;
      continue;
    }
    t_out = std::max(t_out, t_in);
    const double t_end = std::min(t_out, stop);
    const auto& g = cell.gradient;
    auto value_at = [&](double t) { return ((g[0] * (o[0] + t * d[0]) + g[1] * (o[1] + t * d[1]) + g[2] * (o[2] + t * d[2]) + g[3]) - sh.lo) * sh.scale; };
    const double s_in = value_at(t_in), s_out = value_at(t_end);
    const double length = (t_end - t_in) * dl;
    double s0 = s_in, l0 = 0, c[4];
    if (!sh.isos.empty() && s_out != s_in) {
      const bool rising = s_out > s_in;
      const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
      const double light = 0.25 + 0.75 * (gn > 0 ? std::fabs(g[0] * d[0] + g[1] * d[1] + g[2] * d[2]) / (gn * dl) : 1.0);
      for (size_t k = 0; k < sh.isos.size(); ++k) {
        const size_t at = rising ? k : sh.isos.size() - 1 - k;
        const double iv = sh.isos[at];
        if ((s0 < iv) == (s_out < iv)) continue;
        const double li = length * (iv - s_in) / (s_out - s_in);
        integrate(sh, s0, iv, li - l0, c);
        over(c);
        const double a = sh.iso_opacity;
        const double surface[4] = {sh.iso_rgb[at][0] * light * a, sh.iso_rgb[at][1] * light * a, sh.iso_rgb[at][2] * light * a, a};
        over(surface);
        s0 = iv;
        l0 = li;
      }
    }
    integrate(sh, s0, s_out, length - l0, c);
    over(c);
    if (t_end >= stop) break;
    const uint32_t across = opposite_[4 * size_t{tet} + exit];
    t_in = t_out;
    if (across != kNoOppositeFace) {
      previous = tet;
      tet = across / 4;
      entry = across % 4;
    } else if (const uint32_t ahead = walk_to(tet, previous, o, d, t_out + 1e-6 * mesh_.diagonal / dl); ahead != kNone) {
      // a ray through an edge took the face of a tet it only grazed, and that face is on the
      // boundary: it is still inside, in the tet that holds a point just ahead
      previous = tet;
      tet = ahead;
      entry = 4;
    } else {  // out of the mesh: where does it come back in?
      const uint32_t face = enter(o, d, t_out, &t_in, 4 * tet + static_cast<uint32_t>(exit));
      tet = face == kNone ? kNone : face / 4;
      entry = face == kNone ? 4 : face % 4;
    }
  }
}

Image RayCaster::render(const RenderSettings& settings, FrameTimings* timings, unsigned threads) const {
  if (const std::string what = unsupported(settings); !what.empty()) throw std::invalid_argument("the CPU ray caster does not draw " + what + "; use the GL renderer");
  if (settings.width < 1 || settings.height < 1 || settings.width > kMaxImageSide || settings.height > kMaxImageSide)
    throw std::invalid_argument("image sides must be 1.." + std::to_string(kMaxImageSide));
  const auto start = std::chrono::steady_clock::now();
  const uint32_t W = settings.width, H = settings.height;
  const Frame frame = camera_frame(settings.camera, W, H);
  Shading sh;
  shading(settings, sh);
  const SliceHits slices = slice_hits(mesh_, settings, sh.lo, sh.hi);
  // an eye inside the mesh: every ray of a perspective view starts in its tet
  const uint32_t eye_tet = frame.ortho ? kNone : locate(frame.eye);
  Image image{W, H, std::vector<uint8_t>(size_t{W} * H * 4), std::vector<float>(size_t{W} * H * 3)};
  const uint32_t tiles_x = (W + kTile - 1) / kTile, tiles = tiles_x * ((H + kTile - 1) / kTile);
  std::atomic<uint32_t> next{0};
  std::atomic<uint64_t> visited{0};
  // should_stop is asked by the calling thread between its tiles; the others stop with it
  std::atomic<bool> stopped{false};
  auto work = [&](bool asks) {
    uint64_t visits = 0;
    for (uint32_t tile; !stopped.load(std::memory_order_relaxed) && (tile = next.fetch_add(1)) < tiles;) {
      if (asks && settings.should_stop && settings.should_stop()) {
        stopped = true;
        break;
      }
      const uint32_t x0 = tile % tiles_x * kTile, y0 = tile / tiles_x * kTile;
      for (uint32_t y = y0; y < std::min(H, y0 + kTile); ++y)
        for (uint32_t x = x0; x < std::min(W, x0 + kTile); ++x) {
          const size_t pixel = size_t{y} * W + x;
          Vec3 o, d;
          frame.ray(static_cast<int>(x), static_cast<int>(y), &o, &d);
          double acc[4] = {0, 0, 0, 0};
          trace(sh, o, d, slices.distance[pixel], eye_tet, acc, visits);
          const std::array<float, 3> behind = std::isfinite(slices.distance[pixel]) ? slices.rgb[pixel] : settings.background;
          for (int k = 0; k < 3; ++k) {
            const double value = std::clamp(acc[k] + (1 - acc[3]) * behind[k], 0.0, 1.0);
            image.rgba[4 * pixel + k] = static_cast<uint8_t>(std::lround(value * 255));
            image.rgb[3 * pixel + k] = static_cast<float>(value);
          }
          image.rgba[4 * pixel + 3] = 255;
        }
    }
    visited += visits;
  };
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads = std::min(threads, std::max(1u, tiles));
  std::vector<std::thread> pool;
  for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work, false);
  work(true);
  for (auto& t : pool) t.join();
  if (timings) {
    timings->interrupted = stopped.load();
    timings->draw_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    timings->total_ms = timings->draw_ms;
    timings->tets_drawn = visited.load();  // tet visits by rays
  }
  return image;
}

}  // namespace tetrascope::renderer
