// A tensor field as points (dissertation §7.4.2): stream tubes along the major eigenvector in
// linear regions and diffusion surfaces in planar ones, each sampled by points that the GL
// pass (tensor_pass.cpp) draws as lit splats. The lines come from lod's stream-line tracer
// (through a tensor it follows cl * e1 with the sign kept continuous and stops where cl falls
// below the threshold), the surfaces from lod's cut-border (diffusion_surfaces.h), both seeded
// densely (§7.3.1 / §7.4.2: a seed a grid cell). The tensor at every tube sample and surface
// vertex is interpolated in its tet (lod::tensors_at): its eigenvectors give the tube's
// cross-section, its class or derived quantity the colour.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "tetrascope/core/tet_topology.h"
#include "tetrascope/lod/field/diffusion_surfaces.h"
#include "tetrascope/lod/field/streamlines.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::renderer {
namespace {

constexpr double kSpacingPerDiagonal = 1.0 / 250;  // points' spacing, of the bounding-box diagonal
constexpr double kRadiusSpacings = 2;               // a tube's larger radius, in spacings
constexpr double kMinRadiusRatio = 0.25;            // the cross-section's smaller radius at least this of the larger
constexpr uint32_t kTubeSteps = 2000;               // per direction
constexpr uint64_t kMaxSurfaceTriangles = 1'000'000;
constexpr int kMaxSubdivisions = 8;

std::string resolve_field(const storage::TetMesh& mesh, const std::string& field) {
  if (!field.empty()) return field;  // lod checks it
  for (const auto& a : mesh.attributes)
    if (a.info.kind == storage::AttributeKind::kTensor) return a.info.name;
  throw std::invalid_argument("the dataset has no tensor field to draw");
}

// -1: the anisotropy class; else a storage::TensorQuantity.
int colour_quantity(const std::string& color) {
  if (color == "class") return -1;
  for (size_t q = 0; q < storage::kTensorQuantityCount; ++q)
    if (color == storage::kTensorQuantityNames[q]) return int(q);
  std::string names = "class";
  for (const char* n : storage::kTensorQuantityNames) names += std::string(", ") + n;
  throw std::invalid_argument("tensor colour '" + color + "' is none of: " + names);
}

float colour_value(const storage::SymmetricTensor& t, int quantity, const view::TensorRequest& r) {
  const auto q = storage::tensor_quantities(t);
  if (quantity >= 0) return float(q[size_t(quantity)]);
  const double cl = q[size_t(storage::TensorQuantity::kLinear)], cp = q[size_t(storage::TensorQuantity::kPlanar)];
  return float(int(lod::classify_anisotropy(cl, cp, r.min_linear, r.min_planar)));
}

bool finite(const storage::SymmetricTensor& t) { return std::isfinite(t.xx + t.yy + t.zz + t.xy + t.yz + t.xz); }

void emit(TensorPoints& out, const Vec3& p, const Vec3& n, const Vec3& t, float value) {
  for (int k = 0; k < 3; ++k) {
    out.xyz.push_back(float(p[size_t(k)]));
    out.normal.push_back(float(n[size_t(k)]));
    out.tangent.push_back(float(t[size_t(k)]));
  }
  out.value.push_back(value);
}

// Tube centres every `spacing` of arc length along each line, with the segment's direction.
void tube_centres(const lod::Streamlines& lines, double spacing, std::vector<Vec3>& centres, std::vector<Vec3>& tangents) {
  for (size_t l = 0; l < lines.line_count(); ++l) {
    double next = 0, along = 0;  // arc length of the next sample, and of the segment's start
    for (uint32_t i = lines.line_first[l]; i + 1 < lines.line_first[l + 1]; ++i) {
      const Vec3 a{lines.x[i], lines.y[i], lines.z[i]}, b{lines.x[i + 1], lines.y[i + 1], lines.z[i + 1]};
      const double len = length(b - a);
      if (!(len > 0)) continue;
      const Vec3 dir = (b - a) * (1 / len);
      for (; next <= along + len; next += spacing) {
        centres.push_back(a + dir * (next - along));
        tangents.push_back(dir);
      }
      along += len;
    }
  }
}

void sample_tubes(const storage::TetMesh& mesh, const std::string& field, const lod::Streamlines& lines, int quantity, const view::TensorRequest& r,
                  TensorPoints& out) {
  std::vector<Vec3> centres, tangents;
  tube_centres(lines, out.spacing, centres, tangents);
  const std::vector<storage::SymmetricTensor> tensors = lod::tensors_at(mesh, field, centres);
  for (size_t k = 0; k < centres.size(); ++k) {
    if (!finite(tensors[k])) continue;
    const storage::Eigensystem e = storage::eigensystem(tensors[k]);
    const Vec3& t = tangents[k];
    const Vec3 e2{e.vectors[1][0], e.vectors[1][1], e.vectors[1][2]};
    const Vec3 u = normalise(e2 - t * dot(e2, t), normalise(cross(t, std::abs(t[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0})));
    const Vec3 w = cross(t, u);
    const double m = std::max({std::abs(e.values[1]), std::abs(e.values[2]), 1e-300});
    const double au = out.radius * std::max(kMinRadiusRatio, std::abs(e.values[1]) / m);
    const double aw = out.radius * std::max(kMinRadiusRatio, std::abs(e.values[2]) / m);
    const float value = colour_value(tensors[k], quantity, r);
    for (int j = 0; j < kTubeRingPoints; ++j) {
      const double angle = 2 * std::numbers::pi * (j + 0.5 * double(k % 2)) / kTubeRingPoints;
      const double c = std::cos(angle), s = std::sin(angle);
      emit(out, centres[k] + u * (au * c) + w * (aw * s), normalise(u * (c / au) + w * (s / aw)), t, value);
    }
    ++out.tube_points;
  }
  out.tube_points *= kTubeRingPoints;
}

struct SurfaceSampler {
  const lod::DiffusionSurfaces& s;
  const std::vector<float>& corner_value;
  bool by_class;
  double area;
  uint64_t serial = 0;
  TensorPoints& out;
  Vec3 at(uint32_t v) const { return {s.x[v], s.y[v], s.z[v]}; }
  Vec3 normal_at(uint32_t v) const { return {s.nx[v], s.ny[v], s.nz[v]}; }
  // The triangle of `corners` between barycentric points b0, b1, b2 (weights of the corners).
  void triangle(const uint32_t* corners, const Vec3& b0, const Vec3& b1, const Vec3& b2, int depth) {
    auto point = [&](const Vec3& b) { return at(corners[0]) * b[0] + at(corners[1]) * b[1] + at(corners[2]) * b[2]; };
    const double t = 0.5 * length(cross(point(b1) - point(b0), point(b2) - point(b0)));
    if (t > area && depth < kMaxSubdivisions) {
      const Vec3 m01 = (b0 + b1) * 0.5, m12 = (b1 + b2) * 0.5, m20 = (b2 + b0) * 0.5;
      triangle(corners, b0, m01, m20, depth + 1);
      triangle(corners, m01, b1, m12, depth + 1);
      triangle(corners, m20, m12, b2, depth + 1);
      triangle(corners, m01, m12, m20, depth + 1);
      return;
    }
    // kept with probability t / area (§7.2), by a low-discrepancy sequence instead of dice
    const double die = std::fmod(0.5 + double(serial++) * 0.6180339887498949, 1.0);
    if (die >= t / area) return;
    const Vec3 b = (b0 + b1 + b2) * (1.0 / 3);
    const Vec3 n = normal_at(corners[0]) * b[0] + normal_at(corners[1]) * b[1] + normal_at(corners[2]) * b[2];
    float value = 0;
    if (by_class) value = corner_value[corners[size_t(std::max_element(b.begin(), b.end()) - b.begin())]];
    else for (int k = 0; k < 3; ++k) value += float(b[size_t(k)]) * corner_value[corners[k]];
    emit(out, point(b), normalise(n), {0, 0, 0}, value);
    ++out.surface_points;
  }
};

void sample_surfaces(const storage::TetMesh& mesh, const std::string& field, const lod::DiffusionSurfaces& surfaces, int quantity, const view::TensorRequest& r,
                     TensorPoints& out) {
  std::vector<Vec3> vertices(surfaces.vertex_count());
  for (size_t v = 0; v < vertices.size(); ++v) vertices[v] = {surfaces.x[v], surfaces.y[v], surfaces.z[v]};
  const std::vector<storage::SymmetricTensor> tensors = lod::tensors_at(mesh, field, vertices);
  std::vector<float> value(vertices.size(), quantity < 0 ? float(int(lod::Anisotropy::planar)) : 0.0f);
  for (size_t v = 0; v < vertices.size(); ++v)
    if (finite(tensors[v])) value[v] = colour_value(tensors[v], quantity, r);
  SurfaceSampler sampler{surfaces, value, quantity < 0, out.spacing * out.spacing, 0, out};
  for (size_t t = 0; t < surfaces.triangle_count(); ++t) sampler.triangle(&surfaces.triangles[3 * t], {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, 0);
}

double line_length(const lod::Streamlines& lines) {
  double sum = 0;
  for (size_t l = 0; l < lines.line_count(); ++l)
    for (uint32_t i = lines.line_first[l]; i + 1 < lines.line_first[l + 1]; ++i)
      sum += length(Vec3{lines.x[i + 1] - lines.x[i], lines.y[i + 1] - lines.y[i], lines.z[i + 1] - lines.z[i]});
  return sum;
}

double surface_area(const lod::DiffusionSurfaces& s) {
  double sum = 0;
  auto at = [&](uint32_t v) { return Vec3{s.x[v], s.y[v], s.z[v]}; };
  for (size_t t = 0; t < s.triangle_count(); ++t) {
    const uint32_t* c = &s.triangles[3 * t];
    sum += 0.5 * length(cross(at(c[1]) - at(c[0]), at(c[2]) - at(c[0])));
  }
  return sum;
}

}  // namespace

TensorPoints tensor_points(const storage::TetMesh& mesh, const view::TensorRequest& r) {
  const auto start = std::chrono::steady_clock::now();
  if (!(r.min_linear >= 0 && r.min_linear <= 1 && r.min_planar >= 0 && r.min_planar <= 1))
    throw std::invalid_argument("tensor thresholds min_cl and min_cp are anisotropy measures between 0 and 1");
  if (!(r.point_size >= 0 && r.point_size <= kMaxPointSize)) throw std::invalid_argument("tensor point size must be 0 (covering) to 64 pixels");
  TensorPoints out;
  out.field = resolve_field(mesh, r.field);
  out.color = r.color;
  const int quantity = colour_quantity(r.color);
  out.by_class = quantity < 0;
  lod::segment_anisotropy(mesh, out.field, 0, 0);  // throws for a field that is not a symmetric tensor
  const storage::Bounds b = storage::compute_bounds(mesh);
  const double diagonal = std::max(1e-300, length(Vec3{b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]}));
  lod::Streamlines lines;
  if (r.tube_cells > 0) {
    const std::vector<uint32_t> opposite = pair_faces(mesh.tets).opposite;
    const lod::StreamlineTracer tracer(mesh, opposite, out.field);
    lod::StreamlineOptions o;
    o.zero_speed = std::max(r.min_linear, 1e-6);
    o.max_steps = kTubeSteps;
    lod::SeedSpec seeds;
    seeds.dense_resolution = std::min(r.tube_cells, lod::kMaxDenseResolution);
    lines = tracer.trace(seeds, o);
  }
  lod::DiffusionSurfaces surfaces;
  if (r.surface_cells > 0) {
    const lod::DiffusionSurfaceTracer tracer(mesh, out.field);
    lod::DiffusionSurfaceOptions o;
    o.min_planar = r.min_planar;
    o.max_triangles = kMaxSurfaceTriangles;
    surfaces = tracer.trace_dense(std::min(r.surface_cells, lod::kMaxDenseResolution), o);
  }
  // the spacing grows until the points fit kMaxTensorPoints
  out.spacing = diagonal * kSpacingPerDiagonal;
  const double length_sum = line_length(lines), area = surface_area(surfaces);
  while (length_sum / out.spacing * kTubeRingPoints + area / (out.spacing * out.spacing) > double(kMaxTensorPoints)) out.spacing *= 1.25;
  out.radius = kRadiusSpacings * out.spacing;
  for (size_t l = 0; l < lines.line_count(); ++l) out.tubes += lines.line_first[l + 1] > lines.line_first[l] + 1;
  out.surfaces = surfaces.surface_count();
  out.surface_triangles = surfaces.triangle_count();
  sample_tubes(mesh, out.field, lines, quantity, r, out);
  sample_surfaces(mesh, out.field, surfaces, quantity, r, out);
  if (!out.by_class && out.count()) {
    const auto [lo, hi] = std::minmax_element(out.value.begin(), out.value.end());
    out.value_min = *lo;
    out.value_max = *hi > *lo ? *hi : *lo + 1;
  } else if (out.by_class) {
    out.value_max = 2;
  }
  out.trace_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace tetrascope::renderer
