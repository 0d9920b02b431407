// Stream lines through tetrahedral meshes, dissertation §7.3 (dense seeding §7.3.1, tetrahedral
// walk along face adjacency). Integration with Dormand–Prince RK5(4) (Dormand & Prince 1980,
// "A family of embedded Runge-Kutta formulae"), error per step relative to the local cell size.
// Through a symmetric tensor field the lines follow the major eigenvector (§7.4.2's stream
// tubes' axes), scaled by the linear anisotropy cl; an eigenvector has no sign, so every stage
// takes the sign that agrees with the step's first direction (sign continuity).
#include "tetrascope/lod/field/streamlines.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <thread>

#include "tet_locator.h"
#include "vtk_polydata.h"
#include "tetrascope/core/parallel_for.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::lod {

namespace {

constexpr uint32_t kNoTet = std::numeric_limits<uint32_t>::max();
constexpr int kMaxWalkTets = 256;           // a longer walk falls back to the grid
constexpr double kInsideEpsilon = 1e-9;     // barycentric slack for "inside"
constexpr int kMaxClipTets = 32;            // tets a boundary clip may cross
constexpr double kGrowthLimit = 5, kShrinkLimit = 0.2, kSafety = 0.9;

// Dormand–Prince 5(4): stage nodes' coefficients, the 5th-order weights (also stage 7, FSAL)
// and the difference of the 5th- and 4th-order weights (the error estimate).
constexpr double kA[7][6] = {
    {},
    {1.0 / 5},
    {3.0 / 40, 9.0 / 40},
    {44.0 / 45, -56.0 / 15, 32.0 / 9},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
    {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}};
constexpr double kE[7] = {71.0 / 57600, 0, -71.0 / 16695, 71.0 / 1920, -17253.0 / 339200, 22.0 / 525, -1.0 / 40};

// One direction of one line: positions and the tets holding them.
struct Trace {
  std::vector<Vec3> points;
  std::vector<uint32_t> tets;
  void clear() {
    points.clear();
    tets.clear();
  }
};

double parse_double(const std::string& text, const std::string& what) {
  if (text.empty()) throw std::invalid_argument(what + ": empty number");
  char* end = nullptr;
  errno = 0;
  double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v)) throw std::invalid_argument(what + ": '" + text + "' is not a finite number");
  return v;
}

uint32_t parse_count(const std::string& text, const std::string& what) {
  double v = parse_double(text, what);
  if (v < 1 || v > kMaxSeeds || v != std::floor(v)) throw std::invalid_argument(what + ": '" + text + "' must be a whole number from 1 to " + std::to_string(kMaxSeeds));
  return static_cast<uint32_t>(v);
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    size_t at = text.find(separator, start);
    parts.push_back(text.substr(start, at == std::string::npos ? std::string::npos : at - start));
    if (at == std::string::npos) return parts;
    start = at + 1;
  }
}

std::vector<double> numbers(const std::string& text, size_t expected, const std::string& what) {
  auto parts = split(text, ',');
  if (parts.size() != expected) throw std::invalid_argument(what + " expects " + std::to_string(expected) + " comma-separated numbers, got " + std::to_string(parts.size()));
  std::vector<double> out;
  for (auto& p : parts) out.push_back(parse_double(p, what));
  return out;
}

}  // namespace

const char* stop_reason_name(StopReason reason) {
  switch (reason) {
    case StopReason::boundary: return "boundary";
    case StopReason::zero_velocity: return "zero_velocity";
    case StopReason::max_length: return "max_length";
    case StopReason::max_steps: return "max_steps";
    case StopReason::lost: return "lost";
    case StopReason::point_budget: return "point_budget";
    default: return "unknown";
  }
}

SeedSpec parse_seeds(const std::string& text) {
  const size_t colon = text.find(':');
  if (colon == std::string::npos) throw std::invalid_argument("seeds '" + text + "': expected line:…, plane:…, points:… or dense:N");
  const std::string kind = text.substr(0, colon), body = text.substr(colon + 1);
  SeedSpec spec;
  if (kind == "line") {
    auto v = numbers(body, 7, "line seeds (x0,y0,z0,x1,y1,z1,N)");
    uint32_t n = parse_count(split(body, ',')[6], "line seed count");
    for (uint32_t i = 0; i < n; ++i) {
      double s = n == 1 ? 0 : double(i) / (n - 1);
      spec.points.push_back({v[0] + s * (v[3] - v[0]), v[1] + s * (v[4] - v[1]), v[2] + s * (v[5] - v[2])});
    }
  } else if (kind == "plane") {
    auto v = numbers(body, 11, "plane seeds (ox,oy,oz,ux,uy,uz,vx,vy,vz,NU,NV)");
    auto parts = split(body, ',');
    uint32_t nu = parse_count(parts[9], "plane seed count NU"), nv = parse_count(parts[10], "plane seed count NV");
    if (uint64_t{nu} * nv > kMaxSeeds) throw std::invalid_argument("plane seeds: NU x NV is over " + std::to_string(kMaxSeeds));
    for (uint32_t j = 0; j < nv; ++j)
      for (uint32_t i = 0; i < nu; ++i) {
        double s = nu == 1 ? 0 : double(i) / (nu - 1), t = nv == 1 ? 0 : double(j) / (nv - 1);
        spec.points.push_back({v[0] + s * v[3] + t * v[6], v[1] + s * v[4] + t * v[7], v[2] + s * v[5] + t * v[8]});
      }
  } else if (kind == "points") {
    for (const auto& point : split(body, ';')) {
      if (point.empty()) continue;
      auto v = numbers(point, 3, "point seed '" + point + "' (x,y,z)");
      spec.points.push_back({v[0], v[1], v[2]});
      if (spec.points.size() > kMaxSeeds) throw std::invalid_argument("more than " + std::to_string(kMaxSeeds) + " seed points");
    }
    if (spec.points.empty()) throw std::invalid_argument("points seeds: no point given");
  } else if (kind == "critical") {
    const auto parts = split(body, ',');
    if (parts.empty() || parts.size() > 2) throw std::invalid_argument("critical seeds (critical:K[,R]): expected a subdivision K and an optional radius R in cell sizes");
    spec.critical_subdivision = parse_count(parts[0], "critical-point sphere subdivision");
    if (spec.critical_subdivision > kMaxCriticalSubdivision) throw std::invalid_argument("critical-point sphere subdivision must be at most " + std::to_string(kMaxCriticalSubdivision));
    if (parts.size() == 2) {
      spec.critical_radius_cells = parse_double(parts[1], "critical-point sphere radius");
      if (!(spec.critical_radius_cells > 0 && spec.critical_radius_cells <= kMaxCriticalRadiusCells))
        throw std::invalid_argument("critical-point sphere radius must be above 0 and at most " + std::to_string(int(kMaxCriticalRadiusCells)) + " cell sizes");
    }
  } else if (kind == "dense") {
    spec.dense_resolution = parse_count(body, "dense seed resolution");
    if (spec.dense_resolution > kMaxDenseResolution) throw std::invalid_argument("dense seed resolution must be at most " + std::to_string(kMaxDenseResolution));
  } else {
    throw std::invalid_argument("seeds '" + text + "': unknown kind '" + kind + "' (line, plane, points, dense or critical)");
  }
  return spec;
}

struct StreamlineTracer::Impl {
  const storage::TetMesh& mesh;
  std::span<const uint32_t> opposite;
  const float* field = nullptr;
  bool tensor = false;  // field: 6 symmetric tensor components a vertex, traced along cl * e1
  std::string field_name;
  std::vector<const storage::Attribute*> scalars;
  double max_speed = 0, diagonal = 0;
  detail::TetLocator locator;
  Vec3 lo{}, hi{};

  Impl(const storage::TetMesh& m, std::span<const uint32_t> opp) : mesh(m), opposite(opp), locator(m) {}

  Vec3 position(uint32_t v) const { return {mesh.x[v], mesh.y[v], mesh.z[v]}; }

  // Barycentric coordinates of p in tet t (b[f] < 0: p is beyond face f); false if degenerate.
  bool barycentric(uint32_t t, const Vec3& p, double b[4]) const { return locator.weights(t, p, b); }

  // The major eigenvector of the tensor interpolated at b, times cl (its sign arbitrary).
  Vec3 major_direction(uint32_t t, const double b[4]) const {
    const storage::SymmetricTensor tensor_at = storage::interpolate_tensor(field, &mesh.tets[4 * size_t{t}], b);
    const storage::Eigensystem e = storage::eigensystem(tensor_at);
    const double cl = storage::tensor_quantities(tensor_at)[size_t(storage::TensorQuantity::kLinear)];
    return Vec3{e.vectors[0][0], e.vectors[0][1], e.vectors[0][2]} * cl;
  }

  Vec3 interpolate(uint32_t t, const double b[4]) const {
    if (tensor) return major_direction(t, b);
    Vec3 v{0, 0, 0};
    for (int i = 0; i < 4; ++i) {
      const float* f = field + 3 * size_t{mesh.tets[4 * size_t{t} + i]};
      v = v + Vec3{f[0], f[1], f[2]} * b[i];
    }
    return v;
  }

  // A length scale of tet t: the edge of a cube of 6x its volume, at least a tenth of its longest edge.
  double cell_size(uint32_t t) const {
    const uint32_t* v = &mesh.tets[4 * size_t{t}];
    Vec3 p[4] = {position(v[0]), position(v[1]), position(v[2]), position(v[3])};
    double volume = std::abs(dot(p[1] - p[0], cross(p[2] - p[0], p[3] - p[0])));
    double longest = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) longest = std::max(longest, length(p[i] - p[j]));
    return std::max({std::cbrt(volume), 0.1 * longest, 1e-12 * diagonal});
  }

  uint32_t locate(const Vec3& p) const {
    if (mesh.tet_count() == 0) return kNoTet;
    for (int k = 0; k < 3; ++k)
      if (!(p[k] >= lo[k] && p[k] <= hi[k])) return kNoTet;
    double b[4];
    return locator.containing(p, b, kInsideEpsilon);
  }

  // The tet containing p by a walk from tet t along the most negative barycentric coordinate;
  // kNoTet when the walk leaves through the boundary. A walk that does not settle (a cycle in
  // a badly shaped region) falls back to the grid.
  uint32_t walk(const Vec3& p, uint32_t t, double b[4]) const {
    if (!std::isfinite(p[0] + p[1] + p[2])) {
      // a stage after a non-finite field value: stay, so the step's error is not finite and the line ends as lost
      b[0] = b[1] = b[2] = b[3] = std::numeric_limits<double>::quiet_NaN();
      return t;
    }
    uint32_t previous = kNoTet;
    for (int step = 0; step < kMaxWalkTets; ++step) {
      barycentric(t, p, b);
      int leave = -1;
      bool beyond_boundary = false;
      double most = -kInsideEpsilon;
      for (int f = 0; f < 4; ++f) {
        if (b[f] >= most) continue;
        const uint32_t next = opposite[4 * size_t{t} + f];
        if (next == kNoOppositeFace) {
          beyond_boundary = true;
          continue;
        }
        if (next / 4 == previous && b[f] > -1e-3) continue;  // no ping-pong across a shared face
        most = b[f];
        leave = f;
      }
      if (leave < 0) {
        if (!beyond_boundary) return t;
        return kNoTet;
      }
      previous = t;
      t = opposite[4 * size_t{t} + leave] / 4;
    }
    const uint32_t found = locate(p);
    if (found != kNoTet) barycentric(found, p, b);
    return found;
  }

  // The field at p (sign applied), starting the walk at `tet`; false outside the domain. A
  // tensor's direction takes the sign that agrees with `reference` when one is given.
  bool evaluate(const Vec3& p, uint32_t& tet, double sign, Vec3& v, const Vec3* reference = nullptr) const {
    double b[4];
    const uint32_t found = walk(p, tet, b);
    if (found == kNoTet) return false;
    tet = found;
    v = interpolate(found, b) * sign;
    if (tensor && reference && dot(v, *reference) < 0) v = v * -1.0;
    return true;
  }

  // From p in tet t, the straight line along d to the boundary face it reaches within a few tets;
  // false if none is reached (the line then ends at p).
  bool clip_to_boundary(Vec3 p, uint32_t t, const Vec3& d, double reach, Vec3& hit, uint32_t& hit_tet) const {
    double travelled = 0;
    for (int step = 0; step < kMaxClipTets; ++step) {
      double b0[4], b1[4];
      barycentric(t, p, b0);
      barycentric(t, p + d, b1);
      double exit_s = std::numeric_limits<double>::max();
      int exit_face = -1;
      for (int f = 0; f < 4; ++f) {
        const double rate = b1[f] - b0[f];
        if (rate >= 0) continue;
        const double s = std::max(0.0, -b0[f] / rate);
        if (s < exit_s) exit_s = s, exit_face = f;
      }
      if (exit_face < 0) return false;
      p = p + d * exit_s;
      travelled += exit_s * length(d);
      if (travelled > reach) return false;
      const uint32_t next = opposite[4 * size_t{t} + exit_face];
      if (next == kNoOppositeFace) {
        hit = p;
        hit_tet = t;
        return true;
      }
      t = next / 4;
    }
    return false;
  }

  StopReason trace_direction(const Vec3& seed, uint32_t seed_tet, double sign, const StreamlineOptions& o, double max_length, double zero_speed, std::atomic<int64_t>& points_left, Trace& out) const {
    Vec3 p = seed;
    uint32_t t = seed_tet;
    Vec3 k[7];
    if (!evaluate(p, t, sign, k[0])) return StopReason::lost;
    double travelled = 0, h = -1;
    for (uint32_t steps = 0;; ++steps) {
      if (steps >= o.max_steps) return StopReason::max_steps;
      const double speed = length(k[0]);
      if (!(speed > zero_speed)) return StopReason::zero_velocity;
      const double cell = cell_size(t);
      const double h_max = o.max_step_cells * cell / speed, h_min = o.min_step_cells * cell / speed;
      if (h < 0) h = 0.5 * h_max;
      h = std::clamp(h, h_min, h_max);
      // the last step reaches the maximal length (near enough: a step is short and nearly straight)
      bool last = false;
      if (travelled + h * speed >= max_length) h = (max_length - travelled) / speed, last = true;
      for (;;) {
        uint32_t stage_tet = t;
        bool outside = false;
        Vec3 stage_point = p;
        for (int s = 1; s < 7 && !outside; ++s) {
          Vec3 q = p;
          for (int j = 0; j < s; ++j) q = q + k[j] * (h * kA[s][j]);
          stage_point = q;
          outside = !evaluate(q, stage_tet, sign, k[s], &k[0]);
        }
        if (outside) {
          if (h <= h_min * (1 + 1e-9)) {
            Vec3 hit;
            uint32_t hit_tet;
            if (clip_to_boundary(p, t, k[0] * (1 / speed), 4 * cell, hit, hit_tet) && length(hit - p) > 0) {
              out.points.push_back(hit);
              out.tets.push_back(hit_tet);
            }
            return StopReason::boundary;
          }
          h = std::max(h * 0.25, h_min);
          last = false;
          continue;
        }
        Vec3 error{0, 0, 0};
        for (int s = 0; s < 7; ++s) error = error + k[s] * (h * kE[s]);
        // the error is measured against the cell and, for short steps, the step itself: near a
        // sink an absolute bound alone accepts unstable steps that hover instead of converging
        const double ratio = length(error) / (o.tolerance * std::min(cell, length(stage_point - p)));
        if (!std::isfinite(ratio)) return StopReason::lost;  // a non-finite field value
        if (ratio > 1 && h > h_min * (1 + 1e-9)) {
          h = std::max(h * std::max(kShrinkLimit, kSafety * std::pow(ratio, -0.2)), h_min);
          last = false;
          continue;
        }
        if (ratio > 1) {
          // the smallest step is too inaccurate; if the field turns over within it, the line is
          // closer to a critical point than the smallest step: it has come to rest there
          double change = 0;
          for (int s = 1; s < 7; ++s) change = std::max(change, length(k[s] - k[0]));
          if (change > speed) return StopReason::zero_velocity;
        }
        if (points_left.fetch_sub(1, std::memory_order_relaxed) <= 0) return StopReason::point_budget;
        travelled += length(stage_point - p);
        p = stage_point;  // stage 7 sits at the 5th-order solution (FSAL)
        t = stage_tet;
        k[0] = k[6];
        out.points.push_back(p);
        out.tets.push_back(t);
        h = h * (ratio > 0 ? std::min(kGrowthLimit, kSafety * std::pow(ratio, -0.2)) : kGrowthLimit);
        break;
      }
      if (last || travelled >= max_length * (1 - 1e-12)) return StopReason::max_length;
    }
  }

  struct Line {
    std::vector<float> xyz, v, values;  // values: per point, value_count values
    StopReason stops[2] = {StopReason::kCount, StopReason::kCount};
    bool traced = false;
  };

  size_t value_count() const { return 1 + scalars.size(); }

  void trace_seed(const Vec3& seed, const StreamlineOptions& o, double max_length, double zero_speed, std::atomic<int64_t>& points_left, Trace scratch[2],
                  Line& line) const {
    const uint32_t seed_tet = locate(seed);
    if (seed_tet == kNoTet) return;
    line.traced = true;
    scratch[0].clear();
    scratch[1].clear();
    if (o.direction != StreamDirection::forward) line.stops[1] = trace_direction(seed, seed_tet, -1, o, max_length, zero_speed, points_left, scratch[1]);
    if (o.direction != StreamDirection::backward) line.stops[0] = trace_direction(seed, seed_tet, 1, o, max_length, zero_speed, points_left, scratch[0]);
    Vec3 previous{0, 0, 0};
    auto emit = [&](const Vec3& p, uint32_t t) {
      double b[4];
      barycentric(t, p, b);
      Vec3 v = interpolate(t, b);
      if (tensor && dot(v, previous) < 0) v = v * -1.0;  // a tensor line's directions run one way
      previous = v;
      for (int k = 0; k < 3; ++k) line.xyz.push_back(float(p[k])), line.v.push_back(float(v[k]));
      line.values.push_back(float(length(v)));
      for (const auto* a : scalars) {
        double s = 0;
        for (int i = 0; i < 4; ++i) s += b[i] * a->values[mesh.tets[4 * size_t{t} + i]];
        line.values.push_back(float(s));
      }
    };
    // backward points run towards the seed, so the joined line passes through it once
    for (size_t i = scratch[1].points.size(); i-- > 0;) emit(scratch[1].points[i], scratch[1].tets[i]);
    emit(seed, seed_tet);
    for (size_t i = 0; i < scratch[0].points.size(); ++i) emit(scratch[0].points[i], scratch[0].tets[i]);
  }

  unsigned workers(const StreamlineOptions& o) const { return o.threads ? o.threads : std::max(1u, std::thread::hardware_concurrency()); }
  double max_length_of(const StreamlineOptions& o) const { return o.max_length > 0 ? o.max_length : 4 * diagonal; }
  double zero_speed_of(const StreamlineOptions& o) const { return o.zero_speed > 0 ? o.zero_speed : 1e-6 * max_speed; }

  void trace_all(std::span<const Vec3> seeds, const StreamlineOptions& o, std::atomic<int64_t>& points_left, std::vector<Line>& lines) const {
    lines.assign(seeds.size(), Line{});
    const unsigned w = workers(o);
    std::vector<std::array<Trace, 2>> scratch(w);
    const double max_length = max_length_of(o), zero_speed = zero_speed_of(o);
    parallel_for(seeds.size(), w, [&](size_t i, unsigned worker) { trace_seed(seeds[i], o, max_length, zero_speed, points_left, scratch[worker].data(), lines[i]); });
  }

  void append(Streamlines& out, Line& line, uint32_t seed) const {
    if (!line.traced) {
      ++out.seeds_outside;
      return;
    }
    for (StopReason r : line.stops)
      if (r != StopReason::kCount) ++out.stops[size_t(r)];
    const size_t points = line.xyz.size() / 3, count = value_count();
    for (size_t i = 0; i < points; ++i) {
      out.x.push_back(line.xyz[3 * i]), out.y.push_back(line.xyz[3 * i + 1]), out.z.push_back(line.xyz[3 * i + 2]);
      out.vx.push_back(line.v[3 * i]), out.vy.push_back(line.v[3 * i + 1]), out.vz.push_back(line.v[3 * i + 2]);
      for (size_t k = 0; k < count; ++k) out.values[k].push_back(line.values[count * i + k]);
    }
    out.line_first.push_back(static_cast<uint32_t>(out.x.size()));
    out.line_seed.push_back(seed);
  }

  Streamlines empty_result() const {
    Streamlines out;
    out.value_names.push_back(field_name + "_magnitude");
    for (const auto* a : scalars) out.value_names.push_back(a->info.name);
    out.values.resize(out.value_names.size());
    return out;
  }
};

StreamlineTracer::StreamlineTracer(const storage::TetMesh& mesh, std::span<const uint32_t> opposite, const std::string& field) : impl_(nullptr) {
  const storage::Attribute* a = mesh.find_attribute(field);
  if (!a) {
    std::string names;
    for (const auto& at : mesh.attributes)
      if (at.info.components == 3) names += (names.empty() ? "" : ", ") + at.info.name;
    throw std::invalid_argument("no attribute '" + field + "'" + (names.empty() ? std::string(" (the mesh has no vector field)") : " (vector fields: " + names + ")"));
  }
  const bool tensor = a->info.kind == storage::AttributeKind::kTensor && a->info.components == 6;
  if (a->info.components != 3 && !tensor)
    throw std::invalid_argument("attribute '" + field + "' has " + std::to_string(a->info.components) + " component(s); stream lines need a 3-component vector field or a tensor");
  if (opposite.size() != mesh.tets.size()) throw std::invalid_argument("face adjacency does not match the tets");
  impl_ = new Impl(mesh, opposite);
  Impl& m = *impl_;
  m.field = a->values.data();
  m.tensor = tensor;
  m.field_name = field;
  for (const auto& at : mesh.attributes)
    if (at.info.components == 1) m.scalars.push_back(&at);
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const float* f = m.field + (tensor ? 6 : 3) * v;
    const double s = tensor ? storage::tensor_quantities(storage::tensor_from_symmetric(f))[size_t(storage::TensorQuantity::kLinear)]
                            : std::sqrt(double(f[0]) * f[0] + double(f[1]) * f[1] + double(f[2]) * f[2]);
    if (std::isfinite(s)) m.max_speed = std::max(m.max_speed, s);
  }
  if (mesh.tet_count() > 0) {
    m.lo = m.locator.lo();
    m.hi = m.locator.hi();
    m.diagonal = m.locator.diagonal();
  }
}

StreamlineTracer::~StreamlineTracer() { delete impl_; }

uint32_t StreamlineTracer::locate(const Vec3& p) const { return impl_->locate(p); }

Streamlines StreamlineTracer::trace(std::span<const Vec3> seeds, const StreamlineOptions& options) const {
  if (!(options.tolerance > 0) || !(options.max_step_cells > 0) || !(options.min_step_cells > 0) || options.min_step_cells > options.max_step_cells)
    throw std::invalid_argument("tolerance and step limits must be positive, the smallest step below the largest");
  std::vector<Impl::Line> lines;
  std::atomic<int64_t> points_left{static_cast<int64_t>(std::min<uint64_t>(options.max_points, INT64_MAX))};
  impl_->trace_all(seeds, options, points_left, lines);
  Streamlines out = impl_->empty_result();
  out.seeds = seeds.size();
  for (size_t i = 0; i < lines.size(); ++i) impl_->append(out, lines[i], static_cast<uint32_t>(i));
  return out;
}

Streamlines StreamlineTracer::trace_dense(uint32_t resolution, const StreamlineOptions& options) const {
  const Impl& m = *impl_;
  Streamlines out = m.empty_result();
  if (m.mesh.tet_count() == 0 || resolution == 0) return out;
  const Vec3 extent = m.hi - m.lo;
  const double cell = std::max({extent[0], extent[1], extent[2]}) / resolution;
  int dims[3];
  for (int k = 0; k < 3; ++k) dims[k] = std::max(1, static_cast<int>(std::ceil(extent[k] / cell)));
  const size_t cells = size_t(dims[0]) * dims[1] * dims[2];
  std::vector<uint8_t> covered(cells, 0);
  auto cell_of = [&](const Vec3& p) {
    int c[3];
    for (int k = 0; k < 3; ++k) c[k] = std::clamp(static_cast<int>((p[k] - m.lo[k]) / cell), 0, dims[k] - 1);
    return (size_t(c[2]) * dims[1] + c[1]) * dims[0] + c[0];
  };
  auto centre_of = [&](size_t c) {
    const size_t i = c % dims[0], j = c / dims[0] % dims[1], k = c / (size_t(dims[0]) * dims[1]);
    return Vec3{m.lo[0] + (i + 0.5) * cell, m.lo[1] + (j + 0.5) * cell, m.lo[2] + (k + 0.5) * cell};
  };
  // Lines are traced in batches in parallel; a line whose seed cell an earlier line of its
  // batch crossed is dropped, so the result is that of the one-after-another order of §7.3.1.
  const size_t batch = 8 * size_t{m.workers(options)};
  std::vector<Vec3> seeds;
  std::vector<size_t> seed_cells;
  std::vector<Impl::Line> lines;
  size_t next = 0;
  uint32_t seed_index = 0;
  std::atomic<int64_t> points_left{static_cast<int64_t>(std::min<uint64_t>(options.max_points, INT64_MAX))};
  while (next < cells) {
    seeds.clear();
    seed_cells.clear();
    for (; next < cells && seeds.size() < batch; ++next) {
      if (covered[next]) continue;
      const Vec3 c = centre_of(next);
      if (m.locate(c) == kNoTet) continue;
      seeds.push_back(c);
      seed_cells.push_back(next);
    }
    if (points_left.load() <= 0) break;
    m.trace_all(seeds, options, points_left, lines);
    for (size_t i = 0; i < seeds.size(); ++i) {
      if (covered[seed_cells[i]]) continue;
      Impl::Line& line = lines[i];
      const size_t points = line.xyz.size() / 3;
      for (size_t p = 0; p < points; ++p) {
        const Vec3 a{line.xyz[3 * p], line.xyz[3 * p + 1], line.xyz[3 * p + 2]};
        covered[cell_of(a)] = 1;
        if (p + 1 == points) break;
        const Vec3 b{line.xyz[3 * p + 3], line.xyz[3 * p + 4], line.xyz[3 * p + 5]};
        const int samples = static_cast<int>(std::ceil(2 * length(b - a) / cell));
        for (int s = 1; s < samples; ++s) covered[cell_of(a + (b - a) * (double(s) / samples))] = 1;
      }
      covered[seed_cells[i]] = 1;
      ++out.seeds;
      m.append(out, line, seed_index++);
    }
  }
  return out;
}

std::vector<Vec3> sphere_points(uint32_t k) {
  std::vector<Vec3> out;
  if (k == 0) return out;
  const Vec3 corner[4] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  const int faces[4][3] = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  std::vector<std::array<int64_t, 3>> seen;  // points on shared edges once
  for (const auto& f : faces) {
    const Vec3 a = corner[f[0]], b = corner[f[1]], c = corner[f[2]];
    for (uint32_t i = 0; i <= k; ++i)
      for (uint32_t j = 0; i + j <= k; ++j) {
        const Vec3 p = a + (b - a) * (double(i) / k) + (c - a) * (double(j) / k);
        const std::array<int64_t, 3> key{std::llround(p[0] * 1e9), std::llround(p[1] * 1e9), std::llround(p[2] * 1e9)};
        if (std::find(seen.begin(), seen.end(), key) != seen.end()) continue;
        seen.push_back(key);
        out.push_back(p * (1 / length(p)));
      }
  }
  return out;
}

std::vector<StreamlineTracer::CriticalPoint> StreamlineTracer::critical_points() const {
  const Impl& m = *impl_;
  if (m.tensor) throw std::invalid_argument("critical points need a vector field; '" + m.field_name + "' is a tensor");
  std::vector<CriticalPoint> out;
  if (!(m.max_speed > 0)) return out;  // a zero field: nothing isolated
  const double merge = 1e-9 * m.diagonal;
  std::vector<uint8_t> on_boundary(m.mesh.vertex_count(), 0);
  for (size_t t = 0; t < m.mesh.tet_count(); ++t)
    for (int f = 0; f < 4; ++f)
      if (m.opposite[4 * t + f] == kNoOppositeFace)
        for (int i = 0; i < 4; ++i)
          if (i != f) on_boundary[m.mesh.tets[4 * t + i]] = 1;
  for (uint32_t t = 0; t < m.mesh.tet_count(); ++t) {
    // sum_i l_i v_i = 0, sum_i l_i = 1, the field scaled by its largest |v|: Gaussian
    // elimination with partial pivoting on the 4 x 5 system
    double a[4][5];
    for (int i = 0; i < 4; ++i) {
      const float* f = m.field + 3 * size_t{m.mesh.tets[4 * size_t{t} + i]};
      for (int k = 0; k < 3; ++k) a[k][i] = f[k] / m.max_speed;
      a[3][i] = 1;
    }
    a[0][4] = a[1][4] = a[2][4] = 0;
    a[3][4] = 1;
    bool singular = false;
    for (int col = 0; col < 4 && !singular; ++col) {
      int pivot = col;
      for (int r = col + 1; r < 4; ++r)
        if (std::abs(a[r][col]) > std::abs(a[pivot][col])) pivot = r;
      if (!(std::abs(a[pivot][col]) > 1e-9)) singular = true;
      else {
        std::swap(a[col], a[pivot]);
        for (int r = 0; r < 4; ++r) {
          if (r == col) continue;
          const double factor = a[r][col] / a[col][col];
          for (int c = col; c < 5; ++c) a[r][c] -= factor * a[col][c];
        }
      }
    }
    if (singular) continue;
    double l[4];
    bool inside = true;
    for (int i = 0; i < 4; ++i) {
      l[i] = a[i][4] / a[i][i];
      inside = inside && std::isfinite(l[i]) && l[i] >= -kInsideEpsilon;
    }
    if (!inside) continue;
    Vec3 p{0, 0, 0};
    for (int i = 0; i < 4; ++i) p = p + m.position(m.mesh.tets[4 * size_t{t} + i]) * l[i];
    // spanned by boundary vertices only (a wall vertex, edge or face): a no-slip wall's zero,
    // not a critical point of the flow inside
    bool wall = true;
    for (int i = 0; i < 4; ++i) wall = wall && (l[i] <= kInsideEpsilon || on_boundary[m.mesh.tets[4 * size_t{t} + i]]);
    out.push_back({p, m.cell_size(t), wall});
  }
  // a zero on a shared face, edge or vertex is found by every tet there: once, by a sweep in x
  std::sort(out.begin(), out.end(), [](const CriticalPoint& a, const CriticalPoint& b) { return a.position < b.position; });
  std::vector<CriticalPoint> kept;
  for (const CriticalPoint& c : out) {
    bool known = false;
    for (size_t i = kept.size(); i-- > 0 && c.position[0] - kept[i].position[0] <= merge;)
      if (length(c.position - kept[i].position) <= merge) {
        known = true;
        kept[i].on_boundary = kept[i].on_boundary || c.on_boundary;
      }
    if (!known) kept.push_back(c);
  }
  std::erase_if(kept, [](const CriticalPoint& c) { return c.on_boundary; });
  return kept;
}

std::vector<Vec3> StreamlineTracer::critical_seeds(uint32_t subdivision, double radius_cells) const {
  const std::vector<Vec3> sphere = sphere_points(subdivision);
  const std::vector<CriticalPoint> points = critical_points();
  if (uint64_t{points.size()} * sphere.size() > kMaxSeeds)
    throw std::invalid_argument(std::to_string(points.size()) + (points.size() > kMaxSeeds ? "+" : "") + " critical points x " + std::to_string(sphere.size()) + " seeds each is over " +
                                std::to_string(kMaxSeeds) + " seeds; use a smaller subdivision");
  std::vector<Vec3> seeds;
  seeds.reserve(points.size() * sphere.size());
  for (const CriticalPoint& c : points)
    for (const Vec3& s : sphere) seeds.push_back(c.position + s * (radius_cells * c.cell_size));
  return seeds;
}

Streamlines StreamlineTracer::trace(const SeedSpec& seeds, const StreamlineOptions& options) const {
  if (seeds.dense_resolution) return trace_dense(seeds.dense_resolution, options);
  if (seeds.critical_subdivision) {
    const std::vector<Vec3> around = critical_seeds(seeds.critical_subdivision, seeds.critical_radius_cells);
    return trace(std::span<const Vec3>(around), options);
  }
  return trace(std::span<const Vec3>(seeds.points), options);
}

using detail::put_big_endian;
using detail::vtk_name;

void write_streamlines_vtk(const std::filesystem::path& path, const Streamlines& lines, const std::string& field, const std::string& title) {
  std::ofstream file = detail::start_polydata(path, title, lines.x, lines.y, lines.z);
  const size_t points = lines.point_count(), count = lines.line_count();
  file << "\nLINES " << count << " " << (count + points) << "\n";
  std::vector<int32_t> cells;
  cells.reserve(count + points);
  for (size_t l = 0; l < count; ++l) {
    cells.push_back(int32_t(lines.line_first[l + 1] - lines.line_first[l]));
    for (uint32_t p = lines.line_first[l]; p < lines.line_first[l + 1]; ++p) cells.push_back(int32_t(p));
  }
  put_big_endian(file, cells.data(), cells.size());
  file << "\nCELL_DATA " << count << "\nSCALARS seed_id int 1\nLOOKUP_TABLE default\n";
  std::vector<int32_t> seeds(lines.line_seed.begin(), lines.line_seed.end());
  put_big_endian(file, seeds.data(), seeds.size());
  file << "\nPOINT_DATA " << points << "\nVECTORS " << vtk_name(field) << " float\n";
  detail::put_triples(file, lines.vx, lines.vy, lines.vz);
  for (size_t k = 0; k < lines.value_names.size(); ++k) {
    file << "\nSCALARS " << vtk_name(lines.value_names[k]) << " float 1\nLOOKUP_TABLE default\n";
    put_big_endian(file, lines.values[k].data(), lines.values[k].size());
  }
  file << "\n";
  if (!file) throw std::runtime_error("writing " + path.string() + " failed");
}

}  // namespace tetrascope::lod
