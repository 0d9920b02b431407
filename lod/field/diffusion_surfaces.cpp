// Diffusion surfaces (dissertation §7.4.2–7.4.3): the anisotropy segmentation, the integration
// of a surface edge in a search plane, and the cut-border that grows a surface triangle by
// triangle (C, L, R, E, S, M, B), its gate the most convex border edge.
//
// Where this differs from §7.4.3: the integrated direction in the search plane is the cut of
// the search plane with the tangent plane (m × n, n the minor eigenvector), the same direction
// as T n⊥ of the text without its length; edges have one length (options.edge) rather than a
// length scaled by the eigenvalues, so that the surface's points are spaced evenly; a border
// vertex a proposed triangle covers is looked up in a uniform grid of the border's vertices
// (the text's octree of border edges); a triangle that would overlap the surface, put an edge
// in a third triangle or (S) leave a short loop turning clockwise ends the gate as a border (B)
// instead, and the small holes so left are closed by ears at the end.
#include "tetrascope/lod/field/diffusion_surfaces.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <queue>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

#include "tet_locator.h"
#include "vtk_polydata.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::lod {

namespace {

constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr double kPi = std::numbers::pi;
constexpr double kCornerAngle = 70 * kPi / 180;  // a free angle below this closes the corner (L, R)
constexpr double kTriangleAngle = 60 * kPi / 180;
constexpr double kCoverScale = 1.3;              // a proposed triangle grown this much looks for border vertices
constexpr double kSnap = 0.5;                    // a new vertex this many edge lengths from a border vertex is that vertex
constexpr size_t kShortLoop = 8;                 // loops of at most this many vertices are checked for folds
constexpr double kOverlapShrink = 0.05;          // triangles shrunk this much about their centres before the overlap test
constexpr size_t kHoleLoop = 32;                 // holes left with at most this many border edges are closed at the end
constexpr double kSliverArea = 0.1;              // a hole of three edges and less area (in edge lengths squared) is a sliver
constexpr double kSeedApart = 0.5;               // a seed this many edges from an earlier surface is on it
constexpr double kDenseSeedApart = 2;            // dense seeding leaves this many edges between surfaces
constexpr int kEdgeSubsteps = 4;                 // midpoint-rule steps along one integrated edge

// The tensor's frame at a point: major (e1), medium (e2), minor (normal) eigenvectors, by the
// eigenvalues' magnitudes, and Westin's measures.
struct Frame {
  Vec3 e1{}, e2{}, normal{};
  double cl = 0, cp = 0;
  bool inside = false;
};

// ccw angle about n from u to w (both projected onto the plane normal to n), in [0, 2π).
double angle_about(const Vec3& n, Vec3 u, Vec3 w) {
  u = u - n * dot(u, n);
  w = w - n * dot(w, n);
  const double t = std::atan2(dot(n, cross(u, w)), dot(u, w));
  return t < 0 ? t + 2 * kPi : t;
}

Vec3 rotate_about(const Vec3& n, Vec3 u, double angle) {
  u = normalise(u - n * dot(u, n));
  return u * std::cos(angle) + cross(n, u) * std::sin(angle);
}

uint64_t edge_key(uint32_t a, uint32_t b) { return a < b ? (uint64_t{a} << 32) | b : (uint64_t{b} << 32) | a; }

// A uniform hash grid of points (ids), cell `size`.
class PointGrid {
 public:
  explicit PointGrid(double size) : size_(size) {}
  void add(const Vec3& p, uint32_t id) { cells_[key(cell(p[0]), cell(p[1]), cell(p[2]))].push_back(id); }
  // Calls f(id) for every id whose cell meets the box [lo, hi].
  template <class F>
  void visit(const Vec3& lo, const Vec3& hi, F&& f) const {
    for (int64_t i = cell(lo[0]); i <= cell(hi[0]); ++i)
      for (int64_t j = cell(lo[1]); j <= cell(hi[1]); ++j)
        for (int64_t k = cell(lo[2]); k <= cell(hi[2]); ++k)
          if (const auto it = cells_.find(key(i, j, k)); it != cells_.end())
            for (const uint32_t id : it->second) f(id);
  }

 private:
  int64_t cell(double v) const { return static_cast<int64_t>(std::floor(v / size_)); }
  static uint64_t key(int64_t i, int64_t j, int64_t k) {
    return (uint64_t(i) & 0x1FFFFF) | ((uint64_t(j) & 0x1FFFFF) << 21) | ((uint64_t(k) & 0x1FFFFF) << 42);
  }
  double size_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
};

// A directed edge of the cut-border: the surface lies on its right, the free side on its left
// (about the vertices' normals); loops are doubly linked.
struct BorderEdge {
  uint32_t a = 0, b = 0;
  uint32_t prev = kNone, next = kNone;
  uint32_t version = 0;
  bool alive = true, fixed = false;  // fixed: a B edge, a border of the finished surface
  bool domain = false;               // a B edge where the planar region or the domain ends
};

struct EdgeEnd {
  Vec3 p{}, normal{};
  double cp = 0;
  bool ok = false;
};

}  // namespace

const char* surface_operation_name(SurfaceOperation op) {
  switch (op) {
    case SurfaceOperation::create: return "C";
    case SurfaceOperation::left: return "L";
    case SurfaceOperation::right: return "R";
    case SurfaceOperation::end: return "E";
    case SurfaceOperation::split: return "S";
    case SurfaceOperation::merge: return "M";
    case SurfaceOperation::border: return "B";
    case SurfaceOperation::kCount: break;
  }
  return "?";
}

namespace {

const storage::Attribute& tensor_attribute(const storage::TetMesh& mesh, const std::string& name) {
  const storage::Attribute* a = mesh.find_attribute(name);
  if (!a || a->info.kind != storage::AttributeKind::kTensor || a->info.components != 6 || a->values.size() < 6 * mesh.vertex_count()) {
    std::string names;
    for (const auto& at : mesh.attributes)
      if (at.info.kind == storage::AttributeKind::kTensor) names += (names.empty() ? "" : ", ") + at.info.name;
    throw std::invalid_argument("'" + name + "' is not a symmetric tensor attribute" + (names.empty() ? std::string(" (the mesh has none)") : " (tensors: " + names + ")"));
  }
  return *a;
}

}  // namespace

Anisotropy classify_anisotropy(double cl, double cp, double min_linear, double min_planar) {
  if (cl >= min_linear && cl >= cp) return Anisotropy::linear;
  if (cp >= min_planar) return Anisotropy::planar;
  if (cl >= min_linear) return Anisotropy::linear;
  return Anisotropy::isotropic;
}

std::vector<storage::SymmetricTensor> tensors_at(const storage::TetMesh& mesh, const std::string& tensor, std::span<const Vec3> points) {
  const storage::Attribute& a = tensor_attribute(mesh, tensor);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<storage::SymmetricTensor> out(points.size(), storage::SymmetricTensor{nan, nan, nan, nan, nan, nan});
  if (mesh.tet_count() == 0) return out;
  const detail::TetLocator locator(mesh);
  for (size_t i = 0; i < points.size(); ++i) {
    double w[4];
    const uint32_t t = locator.containing(points[i], w, 1e-9);
    if (t != detail::kNoTet) out[i] = storage::interpolate_tensor(a.values.data(), &mesh.tets[4 * size_t(t)], w);
  }
  return out;
}

AnisotropySegmentation segment_anisotropy(const storage::TetMesh& mesh, const std::string& tensor, double min_linear, double min_planar) {
  const storage::Attribute& a = tensor_attribute(mesh, tensor);
  AnisotropySegmentation s;
  s.vertex_class.resize(mesh.vertex_count());
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const auto q = storage::tensor_quantities(storage::tensor_from_symmetric(&a.values[6 * v]));
    const double cl = q[size_t(storage::TensorQuantity::kLinear)], cp = q[size_t(storage::TensorQuantity::kPlanar)];
    s.vertex_class[v] = std::isfinite(cl) && std::isfinite(cp) ? classify_anisotropy(cl, cp, min_linear, min_planar) : Anisotropy::isotropic;
    ++s.vertices[size_t(s.vertex_class[v])];
  }
  double total = 0;
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    const uint32_t* v = &mesh.tets[4 * t];
    const auto at = [&](int i) { return Vec3{mesh.x[v[i]], mesh.y[v[i]], mesh.z[v[i]]}; };
    const double volume = std::abs(dot(at(1) - at(0), cross(at(2) - at(0), at(3) - at(0)))) / 6;
    total += volume;
    for (int i = 0; i < 4; ++i) s.volume_share[size_t(s.vertex_class[v[i]])] += volume / 4;
  }
  if (total > 0)
    for (double& share : s.volume_share) share /= total;
  return s;
}

struct DiffusionSurfaceTracer::Impl {
  const storage::TetMesh& mesh;
  const float* field;
  detail::TetLocator locator;

  Impl(const storage::TetMesh& m, const float* f) : mesh(m), field(f), locator(m) {}

  Frame frame(const Vec3& p) const {
    Frame out;
    double w[4];
    const uint32_t t = locator.containing(p, w, 1e-9);
    if (t == detail::kNoTet) return out;
    const storage::SymmetricTensor tensor = storage::interpolate_tensor(field, &mesh.tets[4 * size_t{t}], w);
    const storage::Eigensystem e = storage::eigensystem(tensor);
    std::array<int, 3> order{0, 1, 2};  // by magnitude, largest first (stress tensors are indefinite)
    std::sort(order.begin(), order.end(), [&](int i, int j) { return std::fabs(e.values[size_t(i)]) > std::fabs(e.values[size_t(j)]); });
    const auto vec = [&](int i) { return Vec3{e.vectors[size_t(i)][0], e.vectors[size_t(i)][1], e.vectors[size_t(i)][2]}; };
    const auto q = storage::tensor_quantities(tensor);
    out.e1 = vec(order[0]), out.e2 = vec(order[1]), out.normal = vec(order[2]);
    out.cl = q[size_t(storage::TensorQuantity::kLinear)], out.cp = q[size_t(storage::TensorQuantity::kPlanar)];
    out.inside = std::isfinite(out.cl) && std::isfinite(out.cp);
    return out;
  }

  DiffusionSurfaces trace(std::span<const Vec3> seeds, const DiffusionSurfaceOptions& options, bool dense) const;
};

namespace {

// One surface grown from a seed by the cut-border.
class Grower {
 public:
  Grower(const DiffusionSurfaceTracer::Impl& field, const DiffusionSurfaceOptions& o, double edge, DiffusionSurfaces& out, uint64_t triangle_room)
      : field_(field), o_(o), h_(edge), cos_bend_(std::cos(o.max_bend_degrees * kPi / 180)), out_(out), border_grid_(edge), vertex_grid_(edge), triangle_grid_(edge), room_(triangle_room), first_vertex_(uint32_t(out.x.size())) {}

  // False when no first edge could be integrated from the seed.
  bool grow(const Vec3& seed, const Frame& at);
  uint64_t triangles() const { return triangles_; }
  bool truncated() const { return truncated_; }

 private:
  Vec3 pos(uint32_t v) const { return {out_.x[v], out_.y[v], out_.z[v]}; }
  Vec3 normal(uint32_t v) const { return {out_.nx[v], out_.ny[v], out_.nz[v]}; }
  uint32_t add_vertex(const EdgeEnd& e);
  uint32_t add_edge(uint32_t a, uint32_t b);
  void link(uint32_t e1, uint32_t e2) { edges_[e1].next = e2, edges_[e2].prev = e1; }
  void kill(uint32_t e) {
    edges_[e].alive = false;
    --border_uses_[edges_[e].a - first_vertex_];
  }
  bool over_surface(const Vec3& p) const;
  void enqueue(uint32_t e);
  double free_angle_at_start(uint32_t e) const;
  double free_angle_at_end(uint32_t e) const;
  bool add_triangle(uint32_t x, uint32_t y, uint32_t z, bool check_overlap = true);
  bool overlaps_surface(uint32_t x, uint32_t y, uint32_t z) const;
  EdgeEnd integrate(const Vec3& from, const Vec3& from_normal, const Vec3& direction) const;
  uint32_t covered_border_edge(uint32_t gate, uint32_t third, const Vec3& c) const;
  void step(uint32_t gate);
  // B: the gate stays on the border; `domain`: the surface ends there (else no triangle fitted)
  void border(uint32_t gate, bool domain = false) {
    edges_[gate].fixed = true;
    edges_[gate].domain = domain;
    ++out_.operations[size_t(SurfaceOperation::border)];
  }
  void fill_holes();
  void fill_hole(std::vector<uint32_t> loop);
  void corner(uint32_t gate, bool left);
  void zip(uint32_t e);
  bool inverted_loop(uint32_t start, uint32_t first, uint32_t last, uint32_t end = kNone) const;
  void splice(uint32_t gate, uint32_t other, uint32_t v);

  const DiffusionSurfaceTracer::Impl& field_;
  const DiffusionSurfaceOptions& o_;
  double h_, cos_bend_;
  DiffusionSurfaces& out_;
  std::vector<BorderEdge> edges_;
  std::priority_queue<std::tuple<double, uint32_t, uint32_t>, std::vector<std::tuple<double, uint32_t, uint32_t>>, std::greater<>> queue_;
  std::unordered_map<uint64_t, uint8_t> edge_triangles_;
  PointGrid border_grid_;  // border edges by their start vertex
  PointGrid vertex_grid_;  // every vertex of the surface
  PointGrid triangle_grid_;  // every triangle of the surface, by its centre
  std::vector<uint32_t> border_uses_;  // per vertex (from the surface's first), live border edges starting there
  uint64_t room_, triangles_ = 0;
  uint32_t first_vertex_ = 0;
  bool truncated_ = false;
};

uint32_t Grower::add_vertex(const EdgeEnd& e) {
  out_.x.push_back(float(e.p[0])), out_.y.push_back(float(e.p[1])), out_.z.push_back(float(e.p[2]));
  out_.nx.push_back(float(e.normal[0])), out_.ny.push_back(float(e.normal[1])), out_.nz.push_back(float(e.normal[2]));
  out_.planar.push_back(float(e.cp));
  const uint32_t v = uint32_t(out_.x.size() - 1);
  vertex_grid_.add(e.p, v);
  border_uses_.push_back(0);
  return v;
}

// Whether p lies on the surface grown so far: within kSnap edges of a vertex no live border edge starts at.
bool Grower::over_surface(const Vec3& p) const {
  bool over = false;
  const Vec3 r{kSnap * h_, kSnap * h_, kSnap * h_};
  vertex_grid_.visit(p - r, p + r, [&](uint32_t v) { over = over || (border_uses_[v - first_vertex_] == 0 && length(pos(v) - p) < kSnap * h_); });
  return over;
}

uint32_t Grower::add_edge(uint32_t a, uint32_t b) {
  edges_.push_back({a, b});
  ++border_uses_[a - first_vertex_];
  const uint32_t id = uint32_t(edges_.size() - 1);
  border_grid_.add(pos(a), id);
  return id;
}

double Grower::free_angle_at_start(uint32_t e) const {
  const BorderEdge& g = edges_[e];
  const uint32_t p = edges_[g.prev].a;
  if (p == g.b) return 2 * kPi;
  return angle_about(normal(g.a), pos(g.b) - pos(g.a), pos(p) - pos(g.a));
}

double Grower::free_angle_at_end(uint32_t e) const {
  const BorderEdge& g = edges_[e];
  const uint32_t n = edges_[g.next].b;
  if (n == g.a) return 2 * kPi;
  return angle_about(normal(g.b), pos(n) - pos(g.b), pos(g.a) - pos(g.b));
}

void Grower::enqueue(uint32_t e) {
  BorderEdge& g = edges_[e];
  if (!g.alive || g.fixed) return;
  queue_.emplace(std::min(free_angle_at_start(e), free_angle_at_end(e)), e, ++g.version);
}

// Whether triangle (x, y, z) overlaps a triangle of the surface near it: both shrunk a little
// about their centres (so that neighbours sharing an edge or a corner only touch), projected
// onto the plane of (x, y, z), separated by none of their edges' normals; a triangle more
// than half an edge off that plane does not count.
bool Grower::overlaps_surface(uint32_t x, uint32_t y, uint32_t z) const {
  const std::array<Vec3, 3> t = {pos(x), pos(y), pos(z)};
  const Vec3 unit = normalise(cross(t[1] - t[0], t[2] - t[0]), {0, 0, 0});
  if (length(unit) == 0) return true;
  const Vec3 u = normalise(t[1] - t[0]), w = cross(unit, u);
  const auto shrunk = [&](const std::array<Vec3, 3>& c) {
    const Vec3 centre = (c[0] + c[1] + c[2]) * (1.0 / 3);
    std::array<std::array<double, 2>, 3> f;
    for (size_t i = 0; i < 3; ++i) {
      const Vec3 p = centre + (c[i] - centre) * (1 - kOverlapShrink);
      f[i] = {dot(p - t[0], u), dot(p - t[0], w)};
    }
    return f;
  };
  const auto separated = [](const std::array<std::array<double, 2>, 3>& a, const std::array<std::array<double, 2>, 3>& b) {
    for (const auto* poly : {&a, &b})
      for (size_t i = 0; i < 3; ++i) {
        const auto &p = (*poly)[i], &q = (*poly)[(i + 1) % 3];
        const double nx = q[1] - p[1], ny = p[0] - q[0];
        double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300;
        for (const auto& c : a) amin = std::min(amin, nx * c[0] + ny * c[1]), amax = std::max(amax, nx * c[0] + ny * c[1]);
        for (const auto& c : b) bmin = std::min(bmin, nx * c[0] + ny * c[1]), bmax = std::max(bmax, nx * c[0] + ny * c[1]);
        if (amax < bmin || bmax < amin) return true;
      }
    return false;
  };
  const auto mine = shrunk(t);
  Vec3 lo = t[0], hi = t[0];
  for (const Vec3& p : t)
    for (size_t k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]) - h_, hi[k] = std::max(hi[k], p[k]) + h_;
  bool overlap = false;
  triangle_grid_.visit(lo, hi, [&](uint32_t f) {
    if (overlap) return;
    const uint32_t* v = &out_.triangles[3 * size_t{f}];
    const std::array<Vec3, 3> other = {pos(v[0]), pos(v[1]), pos(v[2])};
    for (const Vec3& p : other)
      if (std::fabs(dot(p - t[0], unit)) > 0.5 * h_) return;
    overlap = !separated(mine, shrunk(other));
  });
  return overlap;
}

bool Grower::add_triangle(uint32_t x, uint32_t y, uint32_t z, bool check_overlap) {
  for (const uint64_t k : {edge_key(x, y), edge_key(y, z), edge_key(z, x)})
    if (const auto it = edge_triangles_.find(k); it != edge_triangles_.end() && it->second >= 2) return false;
  if (check_overlap && overlaps_surface(x, y, z)) return false;
  for (const uint64_t k : {edge_key(x, y), edge_key(y, z), edge_key(z, x)}) ++edge_triangles_[k];
  out_.triangles.insert(out_.triangles.end(), {x, y, z});
  triangle_grid_.add((pos(x) + pos(y) + pos(z)) * (1.0 / 3), uint32_t(out_.triangles.size() / 3 - 1));
  ++triangles_;
  return true;
}

// From `from` along the surface, starting in `direction` (in the tangent plane there): the
// midpoint rule in kEdgeSubsteps steps along the cut of the search plane (through `from`,
// normal to the tangent plane, holding `direction`) with the tangent plane at each point.
// It fails (B) where the field is not planar, outside the domain, or turns too far.
EdgeEnd Grower::integrate(const Vec3& from, const Vec3& from_normal, const Vec3& direction) const {
  EdgeEnd end;
  const Vec3 m = normalise(cross(from_normal, direction), {0, 0, 0});
  if (length(m) == 0) return end;
  const double s = h_ / kEdgeSubsteps;
  Vec3 q = from, heading = normalise(direction);
  const auto tangent = [&](const Vec3& at, const Vec3& towards, Vec3& t) {
    const Frame f = field_.frame(at);
    if (!f.inside || f.cp < o_.min_planar || std::fabs(dot(f.normal, from_normal)) < cos_bend_) return false;
    t = cross(m, f.normal);
    if (length(t) < 0.2) return false;  // the tangent plane nearly holds the search plane's normal
    t = normalise(t);
    if (dot(t, towards) < 0) t = t * -1.0;
    return true;
  };
  for (int i = 0; i < kEdgeSubsteps; ++i) {
    Vec3 k1, k2;
    if (!tangent(q, heading, k1) || !tangent(q + k1 * (s / 2), k1, k2)) return end;
    q = q + k2 * s;
    heading = k2;
  }
  const Frame f = field_.frame(q);
  if (!f.inside || f.cp < o_.min_planar) return end;
  end.normal = dot(f.normal, from_normal) < 0 ? f.normal * -1.0 : f.normal;
  if (dot(end.normal, from_normal) < cos_bend_) return end;
  end.p = q, end.cp = f.cp, end.ok = true;
  return end;
}

// A live border edge whose start vertex the triangle (gate's ends, c) grown by kCoverScale
// covers (within half an edge of its plane), or that passes through that triangle (either
// end), or, for a new vertex c (third kNone), whose start lies within kSnap edges of c: of
// these the vertex nearest the gate's middle whose free wedge faces the gate; kNone if none.
// The gate's ends and `third` do not count.
uint32_t Grower::covered_border_edge(uint32_t gate, uint32_t third, const Vec3& c) const {
  const uint32_t a = edges_[gate].a, b = edges_[gate].b;
  const Vec3 centre = (pos(a) + pos(b) + c) * (1.0 / 3);
  const Vec3 A = centre + (pos(a) - centre) * kCoverScale, B = centre + (pos(b) - centre) * kCoverScale, C = centre + (c - centre) * kCoverScale;
  const Vec3 n = cross(B - A, C - A);
  const double area2 = dot(n, n);
  if (!(area2 > 0)) return kNone;
  Vec3 lo = A, hi = A;
  for (const Vec3& p : {B, C})
    for (int k = 0; k < 3; ++k) lo[size_t(k)] = std::min(lo[size_t(k)], p[size_t(k)]), hi[size_t(k)] = std::max(hi[size_t(k)], p[size_t(k)]);
  const Vec3 margin{h_, h_, h_};
  const Vec3 middle = (pos(a) + pos(b)) * 0.5;
  uint32_t best = kNone;
  double best_distance = 0;
  const Vec3 unit = normalise(n), u = normalise(B - A), w = cross(unit, u);
  const auto flat = [&](const Vec3& p) { return std::array<double, 2>{dot(p - A, u), dot(p - A, w)}; };
  const auto side = [](const std::array<double, 2>& o, const std::array<double, 2>& p, const std::array<double, 2>& q) {
    return (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
  };
  const std::array<std::array<double, 2>, 3> corners = {flat(A), flat(B), flat(C)};
  // a border edge through the grown triangle (in its plane, within an edge of it)
  const auto crosses = [&](const Vec3& p, const Vec3& q) {
    if (std::fabs(dot(p - A, unit)) > h_ || std::fabs(dot(q - A, unit)) > h_) return false;
    const auto fp = flat(p), fq = flat(q);
    for (int k = 0; k < 3; ++k) {
      const auto &c0 = corners[size_t(k)], &c1 = corners[size_t((k + 1) % 3)];
      if (side(c0, c1, fp) * side(c0, c1, fq) < 0 && side(fp, fq, c0) * side(fp, fq, c1) < 0) return true;
    }
    return false;
  };
  const auto mine = [&](uint32_t v) { return v == a || v == b || v == third; };
  const auto consider = [&](uint32_t id) {
    const BorderEdge& e = edges_[id];
    const Vec3 p = pos(e.a);
    if (!e.alive || mine(e.a) || dot(normal(e.a), normal(a)) < 0) return;
    // the gate must lie in the free wedge of this occurrence of the vertex
    const double wedge = angle_about(normal(e.a), pos(e.b) - p, pos(edges_[e.prev].a) - p);
    if (edges_[e.prev].a != e.b && angle_about(normal(e.a), pos(e.b) - p, middle - p) > wedge) return;
    const double d = length(p - middle);
    if (best == kNone || d < best_distance) best = id, best_distance = d;
  };
  border_grid_.visit(lo - margin, hi + margin, [&](uint32_t id) {
    const BorderEdge& e = edges_[id];
    if (!e.alive || mine(e.a)) return;
    const Vec3 p = pos(e.a);
    // near a new vertex, or inside: p's projection on the same side of all three edges
    const bool near = third == kNone && length(p - c) < kSnap * h_;
    const bool inside = std::fabs(dot(p - A, n)) <= 0.5 * h_ * std::sqrt(area2) && dot(cross(B - A, p - A), n) >= 0 && dot(cross(C - B, p - B), n) >= 0 &&
                        dot(cross(A - C, p - C), n) >= 0;
    if (near || inside) consider(id);
    if (!mine(e.b) && crosses(p, pos(e.b))) consider(id), consider(e.next);
  });
  return best;
}

// A new border edge x→y whose reverse y→x is on the border too: the edge has its two
// triangles, so both leave the border and their loops are joined (or split) at x and y.
void Grower::zip(uint32_t e) {
  if (!edges_[e].alive) return;
  const uint32_t x = edges_[e].a, y = edges_[e].b;
  uint32_t r = kNone;
  border_grid_.visit(pos(y), pos(y), [&](uint32_t id) {
    if (edges_[id].alive && edges_[id].a == y && edges_[id].b == x) r = id;
  });
  if (r == kNone) return;
  const uint32_t before_e = edges_[e].prev, after_e = edges_[e].next, before_r = edges_[r].prev, after_r = edges_[r].next;
  kill(e), kill(r);
  if (after_e == r && after_r == e) return;  // a loop of the two: closed
  if (after_e == r) {
    link(before_e, after_r);
    return enqueue(before_e), enqueue(after_r);
  }
  if (after_r == e) {
    link(before_r, after_e);
    return enqueue(before_r), enqueue(after_e);
  }
  link(before_e, after_r);
  link(before_r, after_e);
  for (const uint32_t n : {before_e, after_r, before_r, after_e}) enqueue(n);
}

// L (left) closes the corner at the gate's start with its previous edge, R at its end with the next.
void Grower::corner(uint32_t gate, bool left) {
  const BorderEdge g = edges_[gate];
  const uint32_t other = left ? g.prev : g.next;
  const uint32_t third = left ? edges_[g.prev].a : edges_[g.next].b;
  if (!add_triangle(g.a, g.b, third)) return border(gate);
  const uint32_t e = left ? add_edge(third, g.b) : add_edge(g.a, third);
  const uint32_t before = left ? edges_[other].prev : g.prev, after = left ? g.next : edges_[other].next;
  link(before, e);
  link(e, after);
  kill(gate), kill(other);
  ++out_.operations[size_t(left ? SurfaceOperation::left : SurfaceOperation::right)];
  for (const uint32_t x : {e, before, after}) enqueue(x);
  zip(e);
}

// Whether the loop of `start` followed by the border edges first..last (and `end` when given),
// if it has at most kShortLoop vertices, turns clockwise about start's normal.
bool Grower::inverted_loop(uint32_t start, uint32_t first, uint32_t last, uint32_t end) const {
  std::vector<Vec3> corners{pos(start)};
  for (uint32_t e = first;; e = edges_[e].next) {
    corners.push_back(pos(edges_[e].b));
    if (e == last || corners.size() > kShortLoop) break;
  }
  if (end != kNone) corners.push_back(pos(end));
  if (corners.size() > kShortLoop) return false;
  Vec3 area{0, 0, 0};
  for (size_t i = 1; i + 1 < corners.size(); ++i) area = area + cross(corners[i] - corners[0], corners[i + 1] - corners[0]);
  return dot(area, normal(start)) < 0;
}

// S or M: the triangle (gate's ends, v), v the start of border edge `other`: the loops are
// cut and joined at v (two loops from one: S; one from two: M).
void Grower::splice(uint32_t gate, uint32_t other, uint32_t v) {
  const BorderEdge g = edges_[gate];
  const uint32_t before_v = edges_[other].prev;
  bool same_loop = false;
  for (uint32_t e = g.next; e != gate; e = edges_[e].next)
    if (e == other) {
      same_loop = true;
      break;
    }
  // a split must leave two loops around free space: a short loop turning clockwise would be a fold
  if (same_loop && (inverted_loop(v, g.next, before_v) || inverted_loop(v, other, g.prev, g.a))) {
    const bool left = free_angle_at_start(gate) <= free_angle_at_end(gate);
    if (!(left ? edges_[g.prev].fixed : edges_[g.next].fixed)) return corner(gate, left);
    return border(gate);
  }
  if (dot(cross(pos(g.b) - pos(g.a), pos(v) - pos(g.a)), normal(g.a)) <= 0 || !add_triangle(g.a, g.b, v)) return border(gate);
  const uint32_t e1 = add_edge(g.a, v), e2 = add_edge(v, g.b);
  link(g.prev, e1);
  link(e1, other);
  link(before_v, e2);
  link(e2, g.next);
  kill(gate);
  ++out_.operations[size_t(same_loop ? SurfaceOperation::split : SurfaceOperation::merge)];
  for (const uint32_t x : {e1, e2, g.prev, g.next, before_v, other}) enqueue(x);
  zip(e1);
  zip(e2);
}

void Grower::step(uint32_t gate) {
  const BorderEdge g = edges_[gate];
  const BorderEdge &prev = edges_[g.prev], &next = edges_[g.next];
  const uint32_t a = g.a, b = g.b, p = prev.a, n = next.b;
  if (g.next == g.prev && p == b && edge_triangles_.count(edge_key(a, b)) && edge_triangles_[edge_key(a, b)] >= 2) {
    kill(gate), kill(g.next);  // a loop of two edges over one edge of two triangles: the surface closes there
    return;
  }
  const double alpha0 = free_angle_at_start(gate), alpha1 = free_angle_at_end(gate);
  const bool three = next.next == g.prev && n == p && g.next != g.prev;
  if (three && !prev.fixed && !next.fixed && std::min(alpha0, alpha1) < kCornerAngle) {  // a corner of a loop of three closes it
    if (!add_triangle(a, b, n)) return border(gate);
    kill(gate), kill(g.next), kill(g.prev);
    ++out_.operations[size_t(SurfaceOperation::end)];
    return;
  }
  if (alpha0 < kCornerAngle && alpha0 <= alpha1 && !prev.fixed && p != b) {
    if (const uint32_t c = covered_border_edge(gate, p, pos(p)); c != kNone && edges_[c].a != n) return splice(gate, c, edges_[c].a);
    return corner(gate, true);
  }
  if (alpha1 < kCornerAngle && !next.fixed && n != a) {
    if (const uint32_t c = covered_border_edge(gate, n, pos(n)); c != kNone && edges_[c].a != p) return splice(gate, c, edges_[c].a);
    return corner(gate, false);
  }
  const double parts = std::max(1.0, std::round(alpha0 / kTriangleAngle));
  const Vec3 direction = rotate_about(normal(a), pos(b) - pos(a), alpha0 >= 2 * kPi - 1e-9 ? kTriangleAngle : alpha0 / parts);
  const EdgeEnd end = integrate(pos(a), normal(a), direction);
  if (!end.ok) return border(gate, true);  // the integration left the planar region or the domain
  if (dot(cross(pos(b) - pos(a), end.p - pos(a)), normal(a)) <= 0 || length(end.p - pos(b)) < 0.2 * h_ || over_surface(end.p)) {
    // no room for a new vertex (a small hole): close the sharper corner, else end here
    const bool left = alpha0 <= alpha1;
    if (std::min(alpha0, alpha1) < kPi && !(left ? prev.fixed : next.fixed) && (left ? p != b : n != a)) return corner(gate, left);
    return border(gate);
  }
  if (const uint32_t c = covered_border_edge(gate, kNone, end.p); c != kNone) {
    const uint32_t v = edges_[c].a;
    if (v == p && !prev.fixed) return corner(gate, true);
    if (v == n && !next.fixed) return corner(gate, false);
    return splice(gate, c, v);
  }
  const uint32_t c = add_vertex(end);
  if (!add_triangle(a, b, c)) return border(gate);
  const uint32_t e1 = add_edge(a, c), e2 = add_edge(c, b);
  link(g.prev, e1);
  link(e1, e2);
  link(e2, g.next);
  kill(gate);
  ++out_.operations[size_t(SurfaceOperation::create)];
  for (const uint32_t x : {e1, e2, g.prev, g.next}) enqueue(x);
}

// Holes the cut-border left where no triangle fitted (loops of at most kHoleLoop edges, none a
// border of the planar region or the domain, turning counter-clockwise): closed by ears, each
// an E.
void Grower::fill_holes() {
  std::vector<bool> seen(edges_.size(), false);
  for (uint32_t start = 0; start < edges_.size(); ++start) {
    if (!edges_[start].alive || seen[start]) continue;
    std::vector<uint32_t> loop;
    bool domain = false;
    for (uint32_t e = start; !seen[e]; e = edges_[e].next) {
      seen[e] = true;
      loop.push_back(e);
      domain = domain || edges_[e].domain;
    }
    if (!domain && loop.size() >= 3 && loop.size() <= kHoleLoop) fill_hole(loop);
  }
}

void Grower::fill_hole(std::vector<uint32_t> loop) {
  std::vector<uint32_t> v;
  Vec3 n{0, 0, 0}, area{0, 0, 0};
  for (const uint32_t e : loop) v.push_back(edges_[e].a), n = n + normal(edges_[e].a);
  for (size_t i = 1; i + 1 < v.size(); ++i) area = area + cross(pos(v[i]) - pos(v[0]), pos(v[i + 1]) - pos(v[0]));
  // clockwise: a fold, not a hole; but a sliver of three edges (a vertex on the opposite edge) is closed
  const bool sliver = v.size() == 3 && length(area) < kSliverArea * h_ * h_;
  if (dot(area, n) <= 0 && !sliver) return;
  const auto convex = [&](uint32_t p, uint32_t c, uint32_t q) { return dot(cross(pos(c) - pos(p), pos(q) - pos(c)), n) > 0; };
  const auto inside = [&](uint32_t p, uint32_t c, uint32_t q, uint32_t x) {
    return convex(p, c, x) && convex(c, q, x) && convex(q, p, x);
  };
  if (sliver) {
    if (add_triangle(v[0], v[1], v[2], false)) ++out_.operations[size_t(SurfaceOperation::end)], v.clear();
  }
  while (v.size() >= 3) {
    bool clipped = false;
    for (size_t i = 0; i < v.size() && !clipped; ++i) {
      const uint32_t p = v[(i + v.size() - 1) % v.size()], c = v[i], q = v[(i + 1) % v.size()];
      if (v.size() > 3 && !convex(p, c, q)) continue;
      bool ear = true;
      for (const uint32_t x : v) ear = ear && (x == p || x == c || x == q || !inside(p, c, q, x));
      if (!ear || !add_triangle(p, c, q, false)) continue;
      ++out_.operations[size_t(SurfaceOperation::end)];
      v.erase(v.begin() + std::ptrdiff_t(i));
      clipped = true;
    }
    if (!clipped) return;
  }
  if (v.empty() || v.size() < 3)
    for (const uint32_t e : loop) kill(e);
}

bool Grower::grow(const Vec3& seed, const Frame& at) {
  EdgeEnd first = integrate(seed, at.normal, at.e1);
  if (!first.ok) first = integrate(seed, at.normal, at.e1 * -1.0);
  if (!first.ok) return false;
  const uint32_t x = add_vertex({seed, at.normal, at.cp, true}), y = add_vertex(first);
  const uint32_t e0 = add_edge(x, y), e1 = add_edge(y, x);
  link(e0, e1);
  link(e1, e0);
  enqueue(e0);
  enqueue(e1);
  while (!queue_.empty()) {
    if (triangles_ >= room_ || triangles_ >= o_.max_triangles_per_surface) {
      truncated_ = true;
      break;
    }
    const auto [key, e, version] = queue_.top();
    queue_.pop();
    if (!edges_[e].alive || edges_[e].fixed || edges_[e].version != version) continue;
    step(e);
  }
  if (!truncated_) fill_holes();
  return true;
}

}  // namespace

DiffusionSurfaces DiffusionSurfaceTracer::Impl::trace(std::span<const Vec3> seeds, const DiffusionSurfaceOptions& options, bool dense) const {
  DiffusionSurfaces out;
  if (mesh.tet_count() == 0) return out;
  const double edge = options.edge > 0 ? options.edge : locator.diagonal() / 48;
  PointGrid surface_points(kDenseSeedApart * edge);  // every surface vertex, to refuse seeds on an earlier surface
  for (size_t s = 0; s < seeds.size(); ++s) {
    ++out.seeds;
    const Frame at = frame(seeds[s]);
    bool near = false;
    const double apart = dense ? kDenseSeedApart * edge : kSeedApart * edge;
    const Vec3 r{apart, apart, apart};
    surface_points.visit(seeds[s] - r, seeds[s] + r, [&](uint32_t v) { near = near || length(Vec3{out.x[v], out.y[v], out.z[v]} - seeds[s]) < apart; });
    if (!at.inside || at.cp < options.min_planar || near || out.triangle_count() >= options.max_triangles) {
      ++out.seeds_refused;
      continue;
    }
    const size_t first_vertex = out.vertex_count();
    Grower grower(*this, options, edge, out, options.max_triangles - out.triangle_count());
    if (!grower.grow(seeds[s], at) || grower.triangles() == 0) {
      out.x.resize(first_vertex), out.y.resize(first_vertex), out.z.resize(first_vertex);
      out.nx.resize(first_vertex), out.ny.resize(first_vertex), out.nz.resize(first_vertex), out.planar.resize(first_vertex);
      ++out.seeds_refused;
      continue;
    }
    out.truncated = out.truncated || grower.truncated();
    out.surface_first.push_back(uint32_t(out.triangle_count()));
    out.surface_seed.push_back(uint32_t(s));
    for (size_t v = first_vertex; v < out.vertex_count(); ++v) surface_points.add({out.x[v], out.y[v], out.z[v]}, uint32_t(v));
  }
  return out;
}

DiffusionSurfaceTracer::DiffusionSurfaceTracer(const storage::TetMesh& mesh, const std::string& tensor)
    : impl_(new Impl(mesh, tensor_attribute(mesh, tensor).values.data())) {}

DiffusionSurfaceTracer::~DiffusionSurfaceTracer() { delete impl_; }

DiffusionSurfaces DiffusionSurfaceTracer::trace(std::span<const Vec3> seeds, const DiffusionSurfaceOptions& options) const {
  return impl_->trace(seeds, options, false);
}

DiffusionSurfaces DiffusionSurfaceTracer::trace_dense(uint32_t resolution, const DiffusionSurfaceOptions& options) const {
  if (resolution == 0 || impl_->mesh.tet_count() == 0) return {};
  const Vec3 lo = impl_->locator.lo(), hi = impl_->locator.hi();
  const double cell = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}) / resolution;
  std::array<uint32_t, 3> cells{};
  for (int k = 0; k < 3; ++k) cells[size_t(k)] = std::max<uint32_t>(1, uint32_t(std::ceil((hi[size_t(k)] - lo[size_t(k)]) / cell)));
  std::vector<Vec3> seeds;
  for (uint32_t k = 0; k < cells[2]; ++k)
    for (uint32_t j = 0; j < cells[1]; ++j)
      for (uint32_t i = 0; i < cells[0]; ++i) seeds.push_back({lo[0] + (i + 0.5) * cell, lo[1] + (j + 0.5) * cell, lo[2] + (k + 0.5) * cell});
  return impl_->trace(seeds, options, true);
}

void write_diffusion_surfaces_vtk(const std::filesystem::path& path, const DiffusionSurfaces& s, const std::string& title) {
  using detail::put_big_endian;
  std::ofstream file = detail::start_polydata(path, title, s.x, s.y, s.z);
  const size_t points = s.vertex_count(), triangles = s.triangle_count();
  file << "\nPOLYGONS " << triangles << " " << 4 * triangles << "\n";
  std::vector<int32_t> cells;
  cells.reserve(4 * triangles);
  for (size_t t = 0; t < triangles; ++t) cells.insert(cells.end(), {3, int32_t(s.triangles[3 * t]), int32_t(s.triangles[3 * t + 1]), int32_t(s.triangles[3 * t + 2])});
  put_big_endian(file, cells.data(), cells.size());
  file << "\nCELL_DATA " << triangles << "\nSCALARS surface int 1\nLOOKUP_TABLE default\n";
  std::vector<int32_t> surface(triangles);
  for (size_t k = 0; k + 1 < s.surface_first.size(); ++k)
    for (uint32_t t = s.surface_first[k]; t < s.surface_first[k + 1]; ++t) surface[t] = int32_t(k);
  put_big_endian(file, surface.data(), surface.size());
  file << "\nPOINT_DATA " << points << "\nNORMALS minor_eigenvector float\n";
  detail::put_triples(file, s.nx, s.ny, s.nz);
  file << "\nSCALARS cp float 1\nLOOKUP_TABLE default\n";
  put_big_endian(file, s.planar.data(), s.planar.size());
  file << "\n";
  if (!file) throw std::runtime_error("writing " + path.string() + " failed");
}

}  // namespace tetrascope::lod
