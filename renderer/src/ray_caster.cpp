// The CPU ray caster: one ray a pixel, in tiles over the cores. A ray enters the mesh through
// a boundary face (found in a bounding volume hierarchy of the boundary, nearer boxes first)
// or starts in the tet that holds the eye, then walks from tet to tet through the face it
// leaves by, with exact segment lengths, composing the GL path's pre-integrated table where a
// segment's value spans one of its bins and integrating the transfer function's finely
// tabulated extinction where the value is nearly constant (there, however long the segment,
// the table's interpolation between bins would veil thin opacity), until it is opaque or
// leaves the mesh (and finds where it enters again, for meshes with holes). Isosurfaces and
// slices are composed in the walk as the reference integrator does. A tet is two cache lines
// of floats, in the order of a Morton curve through the centroids; the walk computes in
// double relative to the tet's corner, so the float planes cost no precision where the ray
// is; segments whose values lie where the transfer function is clear are not integrated. The
// tables a segment reads are asked for a step of the walk before it is composed, and the
// prefix sums are kept compact (a block's start in double, the rest in float), so that the
// integration waits less on memory.
#include "tetrascope/renderer/ray_caster.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <stdexcept>
#include <thread>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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
constexpr uint32_t kPrefixBlock = 64;    // intervals of the extinction a block of the compact prefix sums spans
constexpr uint32_t kLeafFaces = 4;       // boundary faces in a leaf of the hierarchy at most

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
};

// The ray's parameter range inside a box (float corners), clipped to [tmin, tmax]: its start
// in *t_near, false when empty.
inline bool slab(const float lo[3], const float hi[3], const double o[3], const double inv[3], double tmin, double tmax, double* t_near) {
  for (int k = 0; k < 3; ++k) {
    const double a = (lo[k] - o[k]) * inv[k], b = (hi[k] - o[k]) * inv[k];
    tmin = std::max(tmin, std::min(a, b));
    tmax = std::min(tmax, std::max(a, b));
  }
  *t_near = tmin;
  return tmin <= tmax;
}

// Möller–Trumbore for a ray entering triangle abc, wound so that (b - a) x (c - a) points out
// of the mesh: the ray parameter where it meets it, or NaN (missed, or leaving by it).
inline double enter_triangle(const double o[3], const double d[3], const float a[3], const float b[3], const float c[3]) {
  const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  const double e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  const double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
  const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];  // -d.n: positive entering
  if (!(det > 1e-300)) return NAN;
  const double inv = 1 / det;
  const double s[3] = {o[0] - a[0], o[1] - a[1], o[2] - a[2]};
  const double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
  if (u < -1e-9 || u > 1 + 1e-9) return NAN;
  const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
  const double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
  if (v < -1e-9 || u + v > 1 + 1e-9) return NAN;
  return (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
}

// 2^(j/64), j = 0..63: the table of exp_minus
const std::array<double, 64> kExp2Sixtyfourths = [] {
  std::array<double, 64> t{};
  for (int j = 0; j < 64; ++j) t[j] = std::exp2(j / 64.0);
  return t;
}();

// e^-x for x >= 0 (0 past 700), to about 1e-13 relative: 2^(k/64) from a table times a
// polynomial on what is left (|u| <= ln 2 / 128).
inline double exp_minus(double x) {
  if (!(x < 700)) return 0;
  constexpr double kRound = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
  const double y = -x * (64 * 1.4426950408889634);
  const double k = (y + kRound) - kRound;
  const double u = (y - k) * (0.6931471805599453 / 64);
  const double p = 1 + u * (1 + u * (0.5 + u * (1.0 / 6 + u * (1.0 / 24 + u * (1.0 / 120)))));
  const int64_t n = static_cast<int64_t>(k);
  return p * kExp2Sixtyfourths[static_cast<size_t>(n & 63)] * std::bit_cast<double>(static_cast<uint64_t>((n >> 6) + 1023) << 52);
}

// ln(1 + x) for x >= 0, to about 1e-10: the exponent of 1 + x, and 2 atanh(z) on the rest.
inline double ln_1p(double x) {
  const double y = 1 + x;
  const uint64_t bits = std::bit_cast<uint64_t>(y);
  int64_t e = static_cast<int64_t>(bits >> 52) - 1023;
  double m = std::bit_cast<double>((bits & 0x000FFFFFFFFFFFFFull) | 0x3FF0000000000000ull);  // [1, 2)
  if (m > 1.4142135623730951) {
    m *= 0.5;
    ++e;
  }
  const double z = (m - 1) / (m + 1), z2 = z * z;  // |z| <= 0.172
  const double atanh = z * (1 + z2 * (1.0 / 3 + z2 * (1.0 / 5 + z2 * (1.0 / 7 + z2 * (1.0 / 9 + z2 * (1.0 / 11))))));
  // ln(1 + x) = e ln 2 + ln m; where 1 + x rounds, the difference restores what was lost
  return e * 0.6931471805599453 + 2 * atanh + (x - (y - 1)) / y;
}

// Where each tet's centroid falls on a Morton curve over the mesh's box (10 bits an axis).
uint32_t morton(const Vec3& p, const storage::Bounds& b) {
  uint32_t code = 0;
  uint32_t cell[3];
  for (int k = 0; k < 3; ++k) {
    const double extent = b.max[k] - b.min[k];
    const double u = extent > 0 ? (p[k] - b.min[k]) / extent : 0;
    cell[k] = static_cast<uint32_t>(std::clamp(u * 1024, 0.0, 1023.0));
  }
  for (int bit = 9; bit >= 0; --bit)
    for (int k = 0; k < 3; ++k) code = (code << 1) | ((cell[k] >> bit) & 1);
  return code;
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
    float lo[3], hi[3];
    uint32_t first = 0, count = 0;  // leaf: triangles [first, first + count); inner: count 0, children first, first + 1
  };
  struct Triangle {
    float a[3], b[3], c[3];  // wound so that (b - a) x (c - a) points out of the mesh
    uint32_t face;           // 4 * cell + face
  };
  std::vector<Node> nodes;
  std::vector<Triangle> triangles;  // leaves' order
};

namespace {

// The boundary faces (4 * cell + face) in a binary hierarchy of boxes, split at the median of
// the longest axis of their centres; `point` gives a face's corners.
template <class Bvh, class Corners>
void build_hierarchy(Bvh& bvh, const std::vector<uint32_t>& faces, const Corners& corners) {
  std::vector<Box> boxes(faces.size());
  std::vector<Vec3> centre(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    for (const Vec3& p : corners(faces[i])) boxes[i].add(p);
    for (int k = 0; k < 3; ++k) centre[i][k] = 0.5 * (boxes[i].lo[k] + boxes[i].hi[k]);
  }
  std::vector<uint32_t> order(faces.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  struct Task {
    uint32_t node, first, count;
  };
  bvh.nodes.push_back({});
  std::vector<Task> stack{{0, 0, static_cast<uint32_t>(order.size())}};
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    Box box, centres;
    for (uint32_t i = task.first; i < task.first + task.count; ++i) {
      box.add(boxes[order[i]]);
      centres.add(centre[order[i]]);
    }
    for (int k = 0; k < 3; ++k) {  // the faces' corners are floats: their box is exact in float
      bvh.nodes[task.node].lo[k] = static_cast<float>(box.lo[k]);
      bvh.nodes[task.node].hi[k] = static_cast<float>(box.hi[k]);
    }
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (centres.hi[k] - centres.lo[k] > centres.hi[axis] - centres.lo[axis]) axis = k;
    if (task.count <= kLeafFaces || !(centres.hi[axis] > centres.lo[axis])) {
      bvh.nodes[task.node].first = task.first;
      bvh.nodes[task.node].count = task.count;
      continue;
    }
    const uint32_t half = task.count / 2;
    std::nth_element(order.begin() + task.first, order.begin() + task.first + half, order.begin() + task.first + task.count,
                     [&](uint32_t a, uint32_t b) { return centre[a][axis] < centre[b][axis]; });
    const uint32_t left = static_cast<uint32_t>(bvh.nodes.size());
    bvh.nodes.push_back({});
    bvh.nodes.push_back({});
    bvh.nodes[task.node].first = left;
    bvh.nodes[task.node].count = 0;
    stack.push_back({left, task.first, half});
    stack.push_back({left + 1, task.first + half, task.count - half});
  }
  bvh.triangles.resize(faces.size());
  for (size_t i = 0; i < order.size(); ++i) {
    auto& tri = bvh.triangles[i];
    const auto p = corners(faces[order[i]]);
    for (int k = 0; k < 3; ++k) {
      tri.a[k] = static_cast<float>(p[0][k]);
      tri.b[k] = static_cast<float>(p[1][k]);
      tri.c[k] = static_cast<float>(p[2][k]);
    }
    tri.face = faces[order[i]];
  }
}

}  // namespace

RayCaster::RayCaster(const SceneMesh& mesh) : mesh_(mesh), bvh_(std::make_unique<Bvh>()) {
  const size_t T = mesh.tets.size() / 4;
  auto point = [&](uint32_t v) { return Vec3{mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2]}; };
  // the cells along a Morton curve of the centroids
  std::vector<std::pair<uint32_t, uint32_t>> keyed(T);
  for (size_t t = 0; t < T; ++t) {
    Vec3 c{0, 0, 0};
    for (int k = 0; k < 4; ++k) c = c + point(mesh.tets[4 * t + k]) * 0.25;
    keyed[t] = {morton(c, mesh.bounds), static_cast<uint32_t>(t)};
  }
  std::sort(keyed.begin(), keyed.end());
  source_.resize(T);
  std::vector<uint32_t> cell_of(T);
  for (uint32_t i = 0; i < T; ++i) {
    source_[i] = keyed[i].second;
    cell_of[keyed[i].second] = i;
  }
  const std::vector<uint32_t> opposite = pair_faces(mesh.tets).opposite;
  cells_.resize(T);
  for (uint32_t i = 0; i < T; ++i) {
    const size_t t = source_[i];
    Cell& cell = cells_[i];
    Vec3 p[4];
    double s[4];
    for (int k = 0; k < 4; ++k) {
      p[k] = point(mesh.tets[4 * t + k]);
      s[k] = mesh.value[mesh.tets[4 * t + k]];
    }
    for (int f = 0; f < 4; ++f) {
      const Vec3& a = p[kTetFace[f][0]];
      Vec3 n = cross(p[kTetFace[f][1]] - a, p[kTetFace[f][2]] - a);
      if (dot(n, p[f] - a) > 0) n = n * -1.0;  // outward whatever the tet's orientation
      n = normalise(n, {0, 0, 0});
      cell.nx[f] = static_cast<float>(n[0]);
      cell.ny[f] = static_cast<float>(n[1]);
      cell.nz[f] = static_cast<float>(n[2]);
      cell.offset[f] = static_cast<float>(dot(n, p[0] - a));
      const uint32_t across = opposite[4 * t + f];
      cell.across[f] = across == kNoOppositeFace ? kNoOppositeFace : 4 * cell_of[across / 4] + across % 4;
    }
    for (int k = 0; k < 3; ++k) cell.corner[k] = static_cast<float>(p[0][k]);
    cell.value = static_cast<float>(s[0]);
    Vec3 g;
    double c;
    cell.flat = !linear_field(p, s, &g, &c);
    for (int k = 0; k < 3; ++k) cell.gradient[k] = cell.flat ? 0.0f : static_cast<float>(g[k]);
  }
  std::vector<uint32_t> faces;
  for (uint32_t i = 0; i < T; ++i)
    for (uint32_t f = 0; f < 4; ++f)
      if (cells_[i].across[f] == kNoOppositeFace) faces.push_back(4 * i + f);
  build_hierarchy(*bvh_, faces, [&](uint32_t face) {
    const size_t t = source_[face / 4];
    const uint32_t f = face % 4;
    std::array<Vec3, 3> c{point(mesh.tets[4 * t + kTetFace[f][0]]), point(mesh.tets[4 * t + kTetFace[f][1]]), point(mesh.tets[4 * t + kTetFace[f][2]])};
    if (dot(cross(c[1] - c[0], c[2] - c[0]), point(mesh.tets[4 * t + f]) - c[0]) > 0) std::swap(c[1], c[2]);  // outward
    return c;
  });
}

RayCaster::~RayCaster() = default;

std::string RayCaster::unsupported(const RenderSettings& s) {
  if (s.surface || s.wireframe || s.box) return "surfaces, wireframes and boxes";
  if (s.points) return "point-based isosurfaces";
  if (s.tensor_points) return "tensor points";
  if (s.lines) return "stream lines";
  if (s.use_iso_color_attribute) return "isosurfaces coloured by another attribute";
  if (!s.dvr) return "isosurfaces or slices without the volume";
  if (s.volume == view::VolumeMethod::projected) return "--volume projected";
  return "";
}

// The nearest boundary face the ray enters by at a parameter from `after` on (less a rounding,
// so that a ray leaving by an unpaired face finds a face at the same place: internal
// boundaries between regions), `left` (the face it left by) aside: 4 * cell + face, or kNone.
// The nearer child box is searched first, so that the farther is mostly cut off.
uint32_t RayCaster::enter(const Vec3& origin, const Vec3& direction, double after, double* t_hit, uint32_t left) const {
  const double o[3] = {origin[0], origin[1], origin[2]}, d[3] = {direction[0], direction[1], direction[2]};
  after -= 1e-9 * mesh_.diagonal / std::max(1e-300, std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
  const double inv[3] = {1 / d[0], 1 / d[1], 1 / d[2]};
  double best = INFINITY, t_near;
  uint32_t found = kNone;
  *t_hit = best;
  const std::vector<Bvh::Node>& nodes = bvh_->nodes;
  if (nodes.empty() || bvh_->triangles.empty() || !slab(nodes[0].lo, nodes[0].hi, o, inv, after, best, &t_near)) return kNone;
  struct Pending {
    uint32_t node;
    double t_near;
  } stack[64];
  int top = 0;
  stack[top++] = {0, t_near};
  while (top > 0) {
    const Pending pending = stack[--top];
    if (pending.t_near > best) continue;
    const Bvh::Node& node = nodes[pending.node];
    if (node.count == 0) {
      const Bvh::Node &a = nodes[node.first], &b = nodes[node.first + 1];
      double ta, tb;
      const bool hit_a = slab(a.lo, a.hi, o, inv, after, best, &ta), hit_b = slab(b.lo, b.hi, o, inv, after, best, &tb);
      if (top + 2 > 64) continue;  // deeper than any median split of 2^32 faces
      if (hit_a && hit_b) {
        const bool a_first = ta <= tb;
        stack[top++] = a_first ? Pending{node.first + 1, tb} : Pending{node.first, ta};
        stack[top++] = a_first ? Pending{node.first, ta} : Pending{node.first + 1, tb};
      } else if (hit_a) {
        stack[top++] = {node.first, ta};
      } else if (hit_b) {
        stack[top++] = {node.first + 1, tb};
      }
      continue;
    }
    for (uint32_t i = node.first; i < node.first + node.count; ++i) {
      const Bvh::Triangle& tri = bvh_->triangles[i];
      const double h = enter_triangle(o, d, tri.a, tri.b, tri.c);
      if (h >= after && h < best && tri.face != left) {
        best = h;
        found = tri.face;
      }
    }
  }
  *t_hit = best;
  return found;
}

// Near cells `from` and `also`, the cell that holds the point o + t d: a search across the
// interior faces whose planes the point is outside of, nearest cells first (at most 48); kNone
// when none holds it (the point is outside the mesh, or farther than that).
uint32_t RayCaster::walk_to(uint32_t from, uint32_t also, const Vec3& o, const Vec3& d, double t) const {
  const Vec3 p{o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
  uint32_t queue[48];
  size_t head = 0, tail = 0;
  auto push = [&](uint32_t cell) {
    if (cell == kNone || tail == 48) return;
    for (size_t i = 0; i < tail; ++i)
      if (queue[i] == cell) return;
    queue[tail++] = cell;
  };
  push(from);
  push(also);
  while (head < tail) {
    const uint32_t at = queue[head++];
    const Cell& c = cells_[at];
    const double q[3] = {p[0] - c.corner[0], p[1] - c.corner[1], p[2] - c.corner[2]};
    bool outside = false;
    for (int f = 0; f < 4; ++f) {
      if (!(c.nx[f] * q[0] + c.ny[f] * q[1] + c.nz[f] * q[2] + c.offset[f] > 0)) continue;
      outside = true;
      if (c.across[f] != kNoOppositeFace) push(c.across[f] / 4);
    }
    if (!outside && !c.flat) return at;
  }
  return kNone;
}

// The cell that holds `p`, or kNone (every cell's planes, once a frame, for an eye inside the
// mesh's box).
uint32_t RayCaster::locate(const Vec3& p) const {
  const double margin_of_box = 1e-9 * mesh_.diagonal;
  for (int k = 0; k < 3; ++k)
    if (p[k] < mesh_.bounds.min[k] - margin_of_box || p[k] > mesh_.bounds.max[k] + margin_of_box) return kNone;  // outside every tet
  uint32_t best = kNone;
  double best_margin = -INFINITY;
  for (uint32_t at = 0; at < cells_.size(); ++at) {
    const Cell& c = cells_[at];
    if (c.flat) continue;
    const double q[3] = {p[0] - c.corner[0], p[1] - c.corner[1], p[2] - c.corner[2]};
    double margin = INFINITY;
    for (int f = 0; f < 4; ++f) margin = std::min(margin, -(c.nx[f] * q[0] + c.ny[f] * q[1] + c.nz[f] * q[2] + c.offset[f]));
    if (margin >= 0) return at;
    if (margin > best_margin) {
      best_margin = margin;
      best = at;
    }
  }
  // within a rounding of a face: the nearest cell
  return best_margin > -1e-9 * mesh_.diagonal ? best : kNone;
}

// The tables the rays read, compact so that more of them stays in the cache: the prefix sums
// by blocks of kPrefixBlock steps, a block's start in double and the rest in float less it (a
// nearly constant segment's difference of two reads keeps about 1e-7 of a block's integral,
// against 1e-7 of the whole range's in plain float).
void RayCaster::compact_tables() const {
  const uint32_t blocks = kClassified / kPrefixBlock;
  prefix_base_.resize(blocks);
  prefix_fine_.resize(size_t{blocks} * (kPrefixBlock + 1));
  for (uint32_t b = 0; b < blocks; ++b) {
    prefix_base_[b] = integrals_[b * kPrefixBlock];
    for (uint32_t j = 0; j <= kPrefixBlock; ++j)
      for (int c = 0; c < 4; ++c) prefix_fine_[b * (kPrefixBlock + 1) + j][c] = static_cast<float>(integrals_[b * kPrefixBlock + j][c] - prefix_base_[b][c]);
  }
}

// What a frame's rays compose: the colour range, the tables of the transfer function and the
// isosurfaces.
struct RayCaster::Shading {
  double lo = 0, hi = 1, scale = 1, unit = 1;
  const PreintegrationTable* table = nullptr;
  const float* extinction = nullptr;
  const std::array<float, 3>* colors = nullptr;
  const std::array<double, 4>* integrals = nullptr;  // of extinction, and of colour times extinction, from value 0
  const std::array<double, 4>* prefix_base = nullptr;  // the integrals at each block's start
  const std::array<float, 4>* prefix_fine = nullptr;   // less that, kPrefixBlock + 1 values a block
  std::array<double, 4> below{}, above{};           // their rates past the range's ends
  const uint32_t* lit_bins = nullptr;
  double table_bins = 1, length_axis = 1;  // length_axis: (lengths - 1) / ln(1 + max length / length scale)
  double inverse_length_scale = 1;
  std::vector<double> isos;  // normalised, ascending, distinct
  std::vector<std::array<double, 3>> iso_rgb;
  double iso_opacity = 1;
  // Whether the transfer function is clear (no opacity) over every value from a to b
  // (normalised) that the table or the fine extinction would read for them.
  bool clear(double a, double b) const {
    const uint32_t last = table->n - 2;
    const double lo_value = std::clamp(std::min(a, b), 0.0, 1.0) * table_bins, hi_value = std::clamp(std::max(a, b), 0.0, 1.0) * table_bins;
    const uint32_t first_bin = std::min(static_cast<uint32_t>(lo_value), last), last_bin = std::min(static_cast<uint32_t>(hi_value), last);
    return lit_bins[last_bin + 1] == lit_bins[first_bin];
  }
};

namespace {

using Float4 = float __attribute__((vector_size(16)));
using Int4 = int32_t __attribute__((vector_size(16)));

inline Float4 load4(const float* v) {
  Float4 r;
  std::memcpy(&r, v, sizeof r);
  return r;
}

// The integrals of extinction and of colour times extinction over the normalised values from 0
// to s: the tabulated prefix sums, linear past the range's ends (where the transfer function
// holds its end values).
template <class Shading>
inline void integrals_to(const Shading& sh, double s, double out[4]) {
  if (!(s > 0)) {
    for (int k = 0; k < 4; ++k) out[k] = sh.below[k] * s;
    return;
  }
  if (!(s < 1)) {
    for (int k = 0; k < 4; ++k) out[k] = sh.integrals[kClassified][k] + sh.above[k] * (s - 1);
    return;
  }
  const double x = s * kClassified;
  const uint32_t i = std::min(static_cast<uint32_t>(x), kClassified - 1);
  const float f = static_cast<float>(x - i);
  const uint32_t block = i / kPrefixBlock;
  const float* fine = sh.prefix_fine[block * (kPrefixBlock + 1) + i % kPrefixBlock].data();
  const Float4 a = load4(fine), b = load4(fine + 4), within = a + f * (b - a);
  for (int k = 0; k < 4; ++k) out[k] = sh.prefix_base[block][k] + within[k];
}

// The least and the greatest of four lanes, in every lane.
inline Float4 min_of_lanes(Float4 v) {
  Float4 other = __builtin_shufflevector(v, v, 1, 0, 3, 2);
  Float4 least = v < other ? v : other;
  other = __builtin_shufflevector(least, least, 2, 3, 0, 1);
  return least < other ? least : other;
}
inline Float4 max_of_lanes(Float4 v) {
  Float4 other = __builtin_shufflevector(v, v, 1, 0, 3, 2);
  Float4 most = v > other ? v : other;
  other = __builtin_shufflevector(most, most, 2, 3, 0, 1);
  return most > other ? most : other;
}

// The lanes of a comparison that hold, as bits 0..3.
inline unsigned lane_bits(Int4 m) {
#if defined(__SSE2__)
  return static_cast<unsigned>(_mm_movemask_ps(std::bit_cast<__m128>(m)));
#else
  return static_cast<unsigned>((m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8));
#endif
}

// The pre-integrated table at (sf, sb, length), trilinear, four channels at once in float
// (the table's own precision).
template <class Shading>
inline void from_table(const Shading& sh, double sf, double sb, double length, double out[4]) {
  const PreintegrationTable& table = *sh.table;
  const uint32_t n = table.n, L = table.lengths;
  const double u = std::clamp(sf, 0.0, 1.0) * (n - 1), v = std::clamp(sb, 0.0, 1.0) * (n - 1);
  const double w = std::min(ln_1p(std::max(length, 0.0) * sh.inverse_length_scale) * sh.length_axis, double(L - 1));
  const uint32_t i0 = std::min(static_cast<uint32_t>(u), n - 2), j0 = std::min(static_cast<uint32_t>(v), n - 2), m0 = std::min(static_cast<uint32_t>(w), L - 2);
  const float fu = static_cast<float>(u - i0), fv = static_cast<float>(v - j0), fw = static_cast<float>(w - m0);
  const float* c = &table.rgba[((size_t{m0} * n + j0) * n + i0) * 4];
  const size_t row = size_t{n} * 4, plane = row * n;
  auto lerp = [&](const float* at) {
    const Float4 a = load4(at);
    return a + fu * (load4(at + 4) - a);
  };
  const Float4 near = lerp(c) + fv * (lerp(c + row) - lerp(c));
  const Float4 far = lerp(c + plane) + fv * (lerp(c + plane + row) - lerp(c + plane));
  const Float4 r = near + fw * (far - near);
  for (int k = 0; k < 4; ++k) out[k] = r[k];
}

// The colour and opacity of a segment from value sf to sb (normalised) of `length`. A segment
// whose value spans a bin of the pre-integrated table or more reads the table (as the GL path
// does). A nearly constant one (most of them, in fine meshes and over long paths) takes its
// optical depth exactly from the prefix sums of the finely tabulated extinction (a kink of the
// transfer function inside it is no blur, and however long it is, thin opacity is not veiled)
// and its colour as the extinction-weighted mean over its values; one within a step of that
// grid reads the extinction and colour at its middle. Where the transfer function is clear
// over the segment's values, nothing is integrated.
template <class Shading>
void integrate(const Shading& sh, double sf, double sb, double length, double out[4]) {
  for (int k = 0; k < 4; ++k) out[k] = 0;
  const double span = std::fabs(sb - sf);
  if (span * sh.table_bins >= 1) {
    if (!sh.clear(sf, sb)) from_table(sh, sf, sb, length, out);
    return;
  }
  double depth, rgb[3];
  if (span * kClassified < 1) {
    const double x = std::clamp(0.5 * (sf + sb), 0.0, 1.0) * kClassified;
    const uint32_t i = std::min(static_cast<uint32_t>(x), kClassified - 1);
    depth = std::max(0.0, (sh.extinction[i] + (x - i) * (sh.extinction[i + 1] - sh.extinction[i])) * length);
    if (!(depth > 0)) return;  // clear
    const double y = x * (double(kColors) / kClassified);
    const uint32_t j = std::min(static_cast<uint32_t>(y), kColors - 1);
    const auto &c0 = sh.colors[j], &c1 = sh.colors[j + 1];
    for (int k = 0; k < 3; ++k) rgb[k] = c0[k] + (y - j) * (c1[k] - c0[k]);
  } else {
    double a[4], b[4];
    integrals_to(sh, sf, a);
    integrals_to(sh, sb, b);
    const double optical = b[0] - a[0];  // of the sign of sb - sf
    if (optical == 0) return;            // clear
    depth = std::max(0.0, length * optical / (sb - sf));
    const double per_optical = 1 / optical;
    for (int k = 0; k < 3; ++k) rgb[k] = std::min(std::max((b[k + 1] - a[k + 1]) * per_optical, 0.0), 1.0);
  }
  const double alpha = 1 - exp_minus(depth);
  for (int k = 0; k < 3; ++k) out[k] = rgb[k] * alpha;
  out[3] = alpha;
}

// The face a ray leaves a cell by, from q (where it is, less the cell's corner) along d,
// `entry` aside: of the faces ahead (n.d > 0), the one it reaches first, and in *dt the
// parameter to it from q (negative where rounding put q past it). -1: none ahead.
template <class Cell>
int exit_face_double(const Cell& c, const double q[3], const double d[3], uint32_t entry, double* dt) {
  double t[4];
  for (int f = 0; f < 4; ++f) {
    const double dn = c.nx[f] * d[0] + c.ny[f] * d[1] + c.nz[f] * d[2];
    const double distance = c.nx[f] * q[0] + c.ny[f] * q[1] + c.nz[f] * q[2] + c.offset[f];
    t[f] = dn > 0 && f != static_cast<int>(entry) ? -distance / dn : INFINITY;
  }
  const int a = t[1] < t[0] ? 1 : 0, b = t[3] < t[2] ? 3 : 2;
  const int exit = t[b] < t[a] ? b : a;
  *dt = t[exit];
  return *dt < INFINITY ? exit : -1;
}

// exit_face_double for the four faces at once in float: q is within the cell, so float's
// rounding is a tiny part of the cell. Where another face ahead is within that rounding of the
// nearest (a ray near an edge or a corner), the faces are compared again in double; the
// parameter to the face chosen is computed in double.
template <class Cell>
inline int exit_face(const Cell& c, const double q[3], const double d[3], const float df[3], uint32_t entry, double* dt) {
  constexpr float kRounding = 1e-5f;  // float's rounding in a plane's distance and its ratio, with a wide margin
  const Float4 nx = load4(c.nx), ny = load4(c.ny), nz = load4(c.nz), offset = load4(c.offset);
  const float qx = static_cast<float>(q[0]), qy = static_cast<float>(q[1]), qz = static_cast<float>(q[2]);
  const Float4 dn = nx * df[0] + ny * df[1] + nz * df[2];
  const Float4 distance = nx * qx + ny * qy + nz * qz + offset;
  const Int4 lanes = {0, 1, 2, 3};
  const Int4 ahead = (dn > 0) & (lanes != static_cast<int32_t>(entry));
  const Float4 inverse = 1.0f / dn;
  const Float4 infinite = {INFINITY, INFINITY, INFINITY, INFINITY};
  const Float4 t = ahead ? -distance * inverse : infinite;
  const Float4 nearest = min_of_lanes(t);
  if (!(nearest[0] < INFINITY)) return -1;
  const int exit = std::countr_zero(lane_bits(t == nearest));
  // how far each face's parameter may be off: its distance's rounding over n.d, and its own;
  // a face ahead within that of the nearest (the exit itself aside) is a rival
  const float scale = std::fabs(qx) + std::fabs(qy) + std::fabs(qz) + std::fabs(c.offset[0]);
  const Float4 zero = {0, 0, 0, 0};
  const Float4 off = ahead ? kRounding * (scale * inverse + (t < 0 ? -t : t)) : zero;
  const Float4 widest = max_of_lanes(off);
  if (const unsigned close = lane_bits(ahead & (t - off <= nearest + widest)); (close & (close - 1)) != 0) return exit_face_double(c, q, d, entry, dt);
  // the parameter in double, as exact as the planes: where the ray leaves the mesh, another
  // region's face at the same place is found within a rounding of it
  const double dn_exit = c.nx[exit] * d[0] + c.ny[exit] * d[1] + c.nz[exit] * d[2];
  *dt = -(c.nx[exit] * q[0] + c.ny[exit] * q[1] + c.nz[exit] * q[2] + c.offset[exit]) / dn_exit;
  return exit;
}

// Of the faces but `entry`, the one the ray runs most into (a ray along a face or through an
// edge, where rounding left no face ahead).
template <class Cell>
int steepest_face(const Cell& c, const double d[3], uint32_t entry) {
  double most = -INFINITY;
  int exit = -1;
  for (int f = 0; f < 4; ++f) {
    const double dn = c.nx[f] * d[0] + c.ny[f] * d[1] + c.nz[f] * d[2];
    if (f != static_cast<int>(entry) && dn > most) {
      most = dn;
      exit = f;
    }
  }
  return exit;
}

// Where the ray is in its cell (q: the point at t_in less the cell's corner) and the face it
// leaves by, with in *dt the parameter from t_in to it; a ray along a face or through an edge
// (rounding left no face ahead) leaves where it is by the face it runs most into, rather than
// skipping to the boundary. -1: a flat cell with no face ahead.
template <class Ray, class Cell>
inline int leave(const Ray& ray, const Cell& cell, double q[3], double* dt) {
  for (int k = 0; k < 3; ++k) q[k] = ray.o[k] + ray.t_in * ray.d[k] - cell.corner[k];
  int exit = exit_face(cell, q, ray.d, ray.df, ray.entry, dt);
  if (exit < 0 && !cell.flat) {
    exit = steepest_face(cell, ray.d, ray.entry);
    *dt = 0;
  }
  *dt = std::max(*dt, 0.0);
  return exit;
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
      // the prefix sums over the fine grid (trapezoids; the colour read from its own grid)
      integrals_.resize(kClassified + 1);
      integrals_[0] = {0, 0, 0, 0};
      auto emitted = [&](uint32_t k) {
        const double y = double(k) * kColors / kClassified;
        const uint32_t j = std::min(static_cast<uint32_t>(y), kColors - 1);
        std::array<double, 4> e{extinction_[k], 0, 0, 0};
        for (int c = 0; c < 3; ++c) e[c + 1] = extinction_[k] * (colors_[j][c] + (y - j) * (colors_[j + 1][c] - colors_[j][c]));
        return e;
      };
      std::array<double, 4> previous = emitted(0);
      below_ = previous;
      for (uint32_t k = 0; k < kClassified; ++k) {
        const std::array<double, 4> next = emitted(k + 1);
        for (int c = 0; c < 4; ++c) integrals_[k + 1][c] = integrals_[k][c] + 0.5 * (previous[c] + next[c]) / kClassified;
        previous = next;
      }
      above_ = previous;
      compact_tables();
      // a bin of the table is lit when the extinction is not zero somewhere over its values,
      // widened by a step of the table's own grid (1/1024 of the range), which it rounds to
      const uint32_t bins = table_.n - 1;
      lit_bins_.assign(bins + 1, 0);
      for (uint32_t bin = 0; bin < bins; ++bin) {
        const double from = (double(bin) / bins - 1.0 / 1024) * kClassified, to = (double(bin + 1) / bins + 1.0 / 1024) * kClassified;
        const auto first = extinction_.begin() + static_cast<ptrdiff_t>(std::clamp(std::floor(from), 0.0, double(kClassified)));
        const auto last = extinction_.begin() + static_cast<ptrdiff_t>(std::clamp(std::ceil(to), 0.0, double(kClassified))) + 1;
        const bool lit = std::any_of(first, last, [](float e) { return e > 0; });
        lit_bins_[bin + 1] = lit_bins_[bin] + (lit ? 1 : 0);
      }
      table_key_ = key;
    }
  }
  sh.table = &table_;
  sh.extinction = extinction_.data();
  sh.colors = colors_.data();
  sh.integrals = integrals_.data();
  sh.prefix_base = prefix_base_.data();
  sh.prefix_fine = prefix_fine_.data();
  sh.below = below_;
  sh.above = above_;
  sh.lit_bins = lit_bins_.data();
  sh.table_bins = table_.n - 1;
  sh.length_axis = (table_.lengths - 1) / std::log1p(table_.max_length / table_.length_scale);
  sh.inverse_length_scale = 1 / table_.length_scale;
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

// A ray on its walk: where it is (the cell, the face it came in by: 4 for none, the cell
// before) and from which parameter.
struct RayCaster::Ray {
  double o[3], d[3];
  float df[3];  // d in float
  double dl;    // |d|
  uint32_t cell = kNone, entry = 4, previous = kNone;
  double t_in = 0;
  const EntryBins* bins = nullptr;  // the frame's, with the ray's tile and pixel; none: the hierarchy
  uint32_t tile = 0, x = 0, y = 0;
  Ray(const Vec3& origin, const Vec3& direction)
      : o{origin[0], origin[1], origin[2]},
        d{direction[0], direction[1], direction[2]},
        df{static_cast<float>(direction[0]), static_cast<float>(direction[1]), static_cast<float>(direction[2])},
        dl(std::sqrt(dot(direction, direction))) {}
  Vec3 origin() const { return {o[0], o[1], o[2]}; }
  Vec3 direction() const { return {d[0], d[1], d[2]}; }
};

// The ray's first cell: `eye_cell`, else the one whose boundary face it enters by (kNone: it
// misses the mesh).
void RayCaster::start(Ray& ray, uint32_t eye_cell) const {
  ray.cell = eye_cell;
  ray.entry = 4;
  ray.t_in = 0;
  if (eye_cell != kNone) return;
  const uint32_t face = enter(ray.origin(), ray.direction(), 0, &ray.t_in, kNone);
  ray.cell = face == kNone ? kNone : face / 4;
  ray.entry = face == kNone ? 4 : face % 4;
}

// Steps of no length (a ray through an edge or a vertex takes the face it runs most into, at
// the point where it is) can circle the cells around it: after kStillSteps of them the ray
// goes on from the cell that holds a point just ahead, else from where it enters again.
constexpr uint32_t kStillSteps = 64;

// Counts a step of length dt into `still` (steps in a row that did not advance): true, and
// the count reset, once they pass kStillSteps.
inline bool circling(double dt, uint32_t& still) {
  if (dt > 0) {
    still = 0;
    return false;
  }
  if (++still <= kStillSteps) return false;
  still = 0;
  return true;
}

void RayCaster::move_on(Ray& ray) const {
  const double t = ray.t_in + 1e-6 * mesh_.diagonal / ray.dl;
  if (const uint32_t ahead = walk_to(ray.cell, ray.previous, ray.origin(), ray.direction(), t); ahead != kNone) {
    ray.previous = ray.cell;
    ray.cell = ahead;
    ray.entry = 4;
    ray.t_in = t;
  } else {
    advance(ray, -1, ray.t_in);
  }
}

// From the ray's cell through face `exit` at t_out to the next cell: across the face, else
// (a boundary face) the cell that holds a point just ahead, else where the ray enters again.
// exit -1 (a flat cell): the boundary past this point.
void RayCaster::advance(Ray& ray, int exit, double t_out) const {
  const Vec3 o = ray.origin(), d = ray.direction();
  if (exit < 0) {
    const uint32_t face = enter(ray, ray.t_in + 1e-6 * mesh_.diagonal / ray.dl, &ray.t_in, kNone);
    ray.cell = face == kNone ? kNone : face / 4;
    ray.entry = face == kNone ? 4 : face % 4;
    return;
  }
  const uint32_t across = cells_[ray.cell].across[exit];
  ray.t_in = t_out;
  if (across != kNoOppositeFace) {
    ray.previous = ray.cell;
    ray.cell = across / 4;
    ray.entry = across % 4;
  } else if (const uint32_t ahead = walk_to(ray.cell, ray.previous, o, d, t_out + 1e-6 * mesh_.diagonal / ray.dl); ahead != kNone) {
    // a ray through an edge took the face of a cell it only grazed, and that face is on the
    // boundary: it is still inside, in the cell that holds a point just ahead
    ray.previous = ray.cell;
    ray.cell = ahead;
    ray.entry = 4;
  } else {  // out of the mesh: where does it come back in?
    const uint32_t face = enter(ray, t_out, &ray.t_in, 4 * ray.cell + static_cast<uint32_t>(exit));
    ray.cell = face == kNone ? kNone : face / 4;
    ray.entry = face == kNone ? 4 : face % 4;
  }
}

namespace {

// A segment of a ray through one cell: its values at both ends (normalised), its length and
// the cell's gradient along the ray (for the light on isosurfaces it crosses).
struct Segment {
  double s_in = 0, s_out = 0, length = 0;
  const float* gradient = nullptr;
};

// The segment from q (its start, less the cell's corner) along d for dt.
template <class Shading, class Cell>
inline Segment segment(const Shading& sh, const Cell& cell, const double q[3], const double d[3], double dl, double dt) {
  const float* g = cell.gradient;
  const double along = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
  const double s_in = (cell.value + g[0] * q[0] + g[1] * q[1] + g[2] * q[2] - sh.lo) * sh.scale;
  return {s_in, s_in + along * dt * sh.scale, dt * dl, g};
}

// Asks for the memory integrate will read for a segment (the prefix sums at its end, or the
// pre-integrated table's corners), one step of the walk before it is composed.
template <class Shading>
inline void prefetch(const Shading& sh, const Segment& seg) {
  const double span = std::fabs(seg.s_out - seg.s_in);
  if (span * sh.table_bins >= 1) {
    const PreintegrationTable& table = *sh.table;
    const uint32_t n = table.n, L = table.lengths;
    const double u = std::clamp(seg.s_in, 0.0, 1.0) * (n - 1), v = std::clamp(seg.s_out, 0.0, 1.0) * (n - 1);
    const double w = std::min(ln_1p(std::max(seg.length, 0.0) * sh.inverse_length_scale) * sh.length_axis, double(L - 1));
    const uint32_t i0 = std::min(static_cast<uint32_t>(u), n - 2), j0 = std::min(static_cast<uint32_t>(v), n - 2), m0 = std::min(static_cast<uint32_t>(w), L - 2);
    const float* c = &table.rgba[((size_t{m0} * n + j0) * n + i0) * 4];
    const size_t row = size_t{n} * 4, plane = row * n;
    for (const float* at : {c, c + row, c + plane, c + plane + row}) {
      __builtin_prefetch(at);
      __builtin_prefetch(at + 7);
    }
  } else if (span * kClassified >= 1 && seg.s_out > 0 && seg.s_out < 1) {
    const uint32_t i = std::min(static_cast<uint32_t>(seg.s_out * kClassified), kClassified - 1);
    const float* at = sh.prefix_fine[i / kPrefixBlock * (kPrefixBlock + 1) + i % kPrefixBlock].data();
    __builtin_prefetch(at);
    __builtin_prefetch(at + 7);
  }
}

// A segment composed into acc front to back: the volume, with the isosurfaces it crosses.
template <class Shading>
void compose(const Shading& sh, const Segment& seg, const double d[3], double dl, double acc[4]) {
  auto over = [&](const double c[4]) {
    const double keep = 1 - acc[3];
    for (int k = 0; k < 4; ++k) acc[k] += keep * c[k];
  };
  const double s_in = seg.s_in, s_out = seg.s_out, length = seg.length;
  double s0 = s_in, l0 = 0, c[4];
  if (!sh.isos.empty() && s_out != s_in) {
    const float* g = seg.gradient;
    const double along = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
    const bool rising = s_out > s_in;
    const double gn = std::sqrt(double(g[0]) * g[0] + double(g[1]) * g[1] + double(g[2]) * g[2]);
    const double light = 0.25 + 0.75 * (gn > 0 ? std::fabs(along) / (gn * dl) : 1.0);
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
}

}  // namespace

// One ray up to `stop` (a slice; +inf: none) from where it is: the colour and opacity composed
// into acc, the cells visited added to `visits`. Each segment is composed a step of the walk
// after it is found, so that the tables it reads are on their way meanwhile; a ray that turns
// opaque drops the segment found after it.
void RayCaster::trace(const Shading& sh, Ray& ray, double stop, double acc[4], uint64_t& visits) const {
  uint64_t guard = 4 * cells_.size() + 16;
  Segment pending;
  bool has_pending = false;
  auto compose_pending = [&] {
    if (has_pending) {
      compose(sh, pending, ray.d, ray.dl, acc);
      ++visits;
    }
    has_pending = false;
    return acc[3] < kOpaque;
  };
  uint32_t still = 0;  // steps in a row that did not advance
  while (ray.cell != kNone && ray.t_in < stop && guard-- > 0) {
    const Cell& cell = cells_[ray.cell];
    double q[3], dt;
    const int exit = leave(ray, cell, q, &dt);
    if (exit < 0) {  // a flat cell: look for the boundary past this point
      ++visits;
      advance(ray, -1, ray.t_in);
      continue;
    }
    if (circling(dt, still)) {
      move_on(ray);
      continue;
    }
    const double t_out = ray.t_in + dt, t_end = std::min(t_out, stop);
    const Segment next = segment(sh, cell, q, ray.d, ray.dl, t_end - ray.t_in);
    prefetch(sh, next);
    if (!compose_pending()) return;
    pending = next;
    has_pending = true;
    if (t_end >= stop) break;
    if (const uint32_t across = cell.across[exit]; across != kNoOppositeFace) {  // most steps
      ray.previous = ray.cell;
      ray.cell = across / 4;
      ray.entry = across % 4;
      ray.t_in = t_out;
    } else {
      advance(ray, exit, t_out);
    }
  }
  compose_pending();
}

std::vector<RayCaster::Step> RayCaster::walk(const Vec3& origin, const Vec3& direction) const {
  std::vector<Step> steps;
  Ray ray(origin, direction);
  start(ray, locate(origin));
  uint64_t guard = 4 * cells_.size() + 16;
  uint32_t still = 0;
  while (ray.cell != kNone && guard-- > 0) {
    double q[3], dt;
    const int exit = leave(ray, cells_[ray.cell], q, &dt);
    if (exit < 0) {
      advance(ray, -1, ray.t_in);
      continue;
    }
    if (circling(dt, still)) {
      move_on(ray);
      continue;
    }
    const double t_out = ray.t_in + dt;
    steps.push_back({source_[ray.cell], t_out});
    advance(ray, exit, t_out);
  }
  return steps;
}

// The boundary faces a frame's rays may enter by, binned by the tiles their projections
// cover: a ray tests its tile's faces whose pixel box holds it, with the same test as the
// hierarchy, so it finds the same face. Faces turned away from the eye are left out (no ray
// enters by them); a face across the eye's plane has no pixel box and is tested by every ray.
struct RayCaster::EntryBins {
  struct Entry {
    uint32_t triangle;        // into the hierarchy's triangles
    uint16_t x0, y0, x1, y1;  // the pixels it may cover (inclusive)
  };
  std::vector<uint32_t> first;   // per tile into entries, and the end
  std::vector<Entry> entries;
  std::vector<uint32_t> across;  // faces across the eye's plane
};

namespace {

constexpr size_t kMaxFacesAcrossTheEye = 64;  // more: every ray searches the hierarchy

// false: faces across the eye's plane are too many (the hierarchy is the better search)
template <class Triangle, class EntryBins>
bool bin_entries(const std::vector<Triangle>& triangles, const Frame& frame, uint32_t tiles_x, uint32_t tiles, EntryBins& bins) {
  const int W = static_cast<int>(frame.width), H = static_cast<int>(frame.height);
  std::vector<std::array<uint16_t, 4>> box(triangles.size());
  std::vector<uint8_t> kept(triangles.size(), 0);
  bins.first.assign(tiles + 1, 0);
  for (uint32_t i = 0; i < triangles.size(); ++i) {
    const Triangle& tri = triangles[i];
    const Vec3 a{tri.a[0], tri.a[1], tri.a[2]}, b{tri.b[0], tri.b[1], tri.b[2]}, c{tri.c[0], tri.c[1], tri.c[2]};
    const Vec3 outward = cross(b - a, c - a);
    if (dot(frame.ortho ? frame.forward : a - frame.eye, outward) >= 0) continue;  // turned away: never entered
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    int in_front = 0;
    for (const Vec3* p : {&a, &b, &c}) {
      double px, py;
      if (!frame.project(*p, &px, &py)) continue;
      ++in_front;
      lo[0] = std::min(lo[0], px), hi[0] = std::max(hi[0], px), lo[1] = std::min(lo[1], py), hi[1] = std::max(hi[1], py);
    }
    if (in_front == 0) continue;  // behind the eye: no ray reaches it
    if (in_front < 3) {
      bins.across.push_back(i);
      if (bins.across.size() > kMaxFacesAcrossTheEye) return false;
      continue;
    }
    // a pixel's ray meets the face only where its centre is within the projection (and a
    // rounding): a pixel's margin
    const double x0 = std::max(0.0, std::floor(lo[0]) - 1), x1 = std::min(W - 1.0, std::ceil(hi[0]) + 1);
    const double y0 = std::max(0.0, std::floor(lo[1]) - 1), y1 = std::min(H - 1.0, std::ceil(hi[1]) + 1);
    if (!(x0 <= x1 && y0 <= y1)) continue;
    box[i] = {static_cast<uint16_t>(x0), static_cast<uint16_t>(y0), static_cast<uint16_t>(x1), static_cast<uint16_t>(y1)};
    kept[i] = 1;
    for (uint32_t ty = box[i][1] / kTile; ty <= box[i][3] / kTile; ++ty)
      for (uint32_t tx = box[i][0] / kTile; tx <= box[i][2] / kTile; ++tx) ++bins.first[ty * tiles_x + tx + 1];
  }
  for (uint32_t t = 0; t < tiles; ++t) bins.first[t + 1] += bins.first[t];
  bins.entries.resize(bins.first[tiles]);
  std::vector<uint32_t> fill(bins.first.begin(), bins.first.end() - 1);
  for (uint32_t i = 0; i < triangles.size(); ++i) {
    if (!kept[i]) continue;
    for (uint32_t ty = box[i][1] / kTile; ty <= box[i][3] / kTile; ++ty)
      for (uint32_t tx = box[i][0] / kTile; tx <= box[i][2] / kTile; ++tx) bins.entries[fill[ty * tiles_x + tx]++] = {i, box[i][0], box[i][1], box[i][2], box[i][3]};
  }
  return true;
}

}  // namespace

// As enter, for the ray of pixel (x, y) in `tile`, among the faces binned there.
uint32_t RayCaster::enter_binned(const EntryBins& bins, uint32_t tile, uint32_t x, uint32_t y, const Vec3& origin, const Vec3& direction, double after,
                                 double* t_hit, uint32_t left) const {
  const double o[3] = {origin[0], origin[1], origin[2]}, d[3] = {direction[0], direction[1], direction[2]};
  after -= 1e-9 * mesh_.diagonal / std::max(1e-300, std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
  double best = INFINITY;
  uint32_t found = kNone;
  auto test = [&](uint32_t i) {
    const Bvh::Triangle& tri = bvh_->triangles[i];
    const double h = enter_triangle(o, d, tri.a, tri.b, tri.c);
    if (h >= after && h < best && tri.face != left) {
      best = h;
      found = tri.face;
    }
  };
  for (uint32_t k = bins.first[tile]; k < bins.first[tile + 1]; ++k) {
    const EntryBins::Entry& e = bins.entries[k];
    if (x >= e.x0 && x <= e.x1 && y >= e.y0 && y <= e.y1) test(e.triangle);
  }
  for (uint32_t i : bins.across) test(i);
  *t_hit = best;
  return found;
}

// The ray's way into the mesh from `after` on, `left` aside: among its pixel's binned faces
// where the frame has them, else in the hierarchy.
uint32_t RayCaster::enter(const Ray& ray, double after, double* t_hit, uint32_t left) const {
  return ray.bins ? enter_binned(*ray.bins, ray.tile, ray.x, ray.y, ray.origin(), ray.direction(), after, t_hit, left)
                  : enter(ray.origin(), ray.direction(), after, t_hit, left);
}

Image RayCaster::render(const RenderSettings& settings, FrameTimings* timings, unsigned threads) const {
  if (const std::string what = unsupported(settings); !what.empty()) throw std::invalid_argument("the CPU ray caster does not draw " + what + "; use the GL renderer");
  if (settings.width < 1 || settings.height < 1 || settings.width > kMaxImageSide || settings.height > kMaxImageSide)
    throw std::invalid_argument("image sides must be 1.." + std::to_string(kMaxImageSide));
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();  // the process's CPU time, every thread
  const uint32_t W = settings.width, H = settings.height;
  const Frame frame = camera_frame(settings.camera, W, H);
  Shading sh;
  shading(settings, sh);
  const SliceHits slices = slice_hits(mesh_, settings, sh.lo, sh.hi);
  // an eye inside the mesh: every ray of a perspective view starts in its tet
  const uint32_t eye_tet = frame.ortho ? kNone : locate(frame.eye);
  Image image{W, H, std::vector<uint8_t>(size_t{W} * H * 4), std::vector<float>(size_t{W} * H * 3)};
  const uint32_t tiles_x = (W + kTile - 1) / kTile, tiles = tiles_x * ((H + kTile - 1) / kTile);
  EntryBins bins;
  const bool binned = eye_tet == kNone && bin_entries(bvh_->triangles, frame, tiles_x, tiles, bins);
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
          uint32_t cell = eye_tet, entry = 4;
          double t_in = 0;
          if (cell == kNone) {
            const uint32_t face = binned ? enter_binned(bins, tile, x, y, o, d, 0, &t_in, kNone) : enter(o, d, 0, &t_in, kNone);
            cell = face == kNone ? kNone : face / 4;
            entry = face % 4;
          }
          if (cell != kNone) {
            Ray ray(o, d);
            ray.cell = cell;
            ray.entry = entry;
            ray.t_in = t_in;
            if (binned) {
              ray.bins = &bins;
              ray.tile = tile;
              ray.x = x;
              ray.y = y;
            }
            trace(sh, ray, slices.distance[pixel], acc, visits);
          }
          const std::array<float, 3> behind = std::isfinite(slices.distance[pixel]) ? slices.rgb[pixel] : settings.background;
          for (int k = 0; k < 3; ++k) {
            const double value = std::clamp(acc[k] + (1 - acc[3]) * behind[k], 0.0, 1.0);
            image.rgba[4 * pixel + k] = static_cast<uint8_t>(value * 255 + 0.5);
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
    timings->cpu_ms = 1e3 * double(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    timings->tets_drawn = visited.load();  // tet visits by rays
  }
  return image;
}

}  // namespace tetrascope::renderer
