// Diffusion surfaces of tensor fields whose surfaces are known: a constant planar tensor (the
// surfaces are planes), a tensor whose minor eigenvector is radial (spheres: the surface must
// close) and a helicoid's normal field (a spiral about a singular axis); the anisotropy
// segmentation's classes and shares; the cut-border's surfaces are manifold and consistently
// oriented.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <set>

#include "mesh_checks.h"
#include "tetrascope/lod/field/diffusion_surfaces.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::testing {
namespace {

using storage::SymmetricTensor;

// n n^T scaled: the tensor λ_t (I - n n^T) + λ_n n n^T for a unit normal n.
SymmetricTensor with_normal(const Vec3& n, double tangential, double normal) {
  const double d = normal - tangential;
  return {tangential + d * n[0] * n[0], tangential + d * n[1] * n[1], tangential + d * n[2] * n[2], d * n[0] * n[1], d * n[1] * n[2], d * n[0] * n[2]};
}

storage::TetMesh tensor_box(int n, const std::function<SymmetricTensor(const Vec3&)>& tensor) {
  storage::TetMesh m = kuhn_box(n, 0.0, [](float, float, float) { return 0.0; });
  storage::Attribute t{{"D", 6, storage::AttributeKind::kTensor, true}, {}};
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float six[6];
    storage::store_tensor(tensor({m.x[v], m.y[v], m.z[v]}), six);
    t.values.insert(t.values.end(), six, six + 6);
  }
  m.attributes.push_back(t);
  return m;
}

struct Topology {
  size_t vertices = 0, edges = 0, triangles = 0, border_edges = 0, edges_over_two = 0, directed_twice = 0;
  long euler() const { return long(vertices) - long(edges) + long(triangles); }
};

// Of surface s: its vertices (those its triangles use), edges, and how they are shared.
Topology topology(const lod::DiffusionSurfaces& s, size_t surface) {
  Topology t;
  std::map<std::pair<uint32_t, uint32_t>, int> undirected, directed;
  std::set<uint32_t> used;
  for (uint32_t f = s.surface_first[surface]; f < s.surface_first[surface + 1]; ++f) {
    const uint32_t* v = &s.triangles[3 * f];
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      ++undirected[{std::min(a, b), std::max(a, b)}];
      ++directed[{a, b}];
      used.insert(a);
    }
    ++t.triangles;
  }
  t.vertices = used.size();
  t.edges = undirected.size();
  for (const auto& [e, uses] : undirected) t.border_edges += uses == 1, t.edges_over_two += uses > 2;
  for (const auto& [e, uses] : directed) t.directed_twice += uses > 1;
  return t;
}

Vec3 vertex(const lod::DiffusionSurfaces& s, uint32_t v) { return {s.x[v], s.y[v], s.z[v]}; }

double area(const lod::DiffusionSurfaces& s, size_t surface) {
  double a = 0;
  for (uint32_t f = s.surface_first[surface]; f < s.surface_first[surface + 1]; ++f) {
    const Vec3 p = vertex(s, s.triangles[3 * f]), q = vertex(s, s.triangles[3 * f + 1]), r = vertex(s, s.triangles[3 * f + 2]);
    a += length(cross(q - p, r - p)) / 2;
  }
  return a;
}

TEST(DiffusionSurfaces, AConstantPlanarTensorGivesAFlatDiscAcrossTheBox) {
  const storage::TetMesh mesh = tensor_box(8, [](const Vec3&) { return SymmetricTensor{1.0, 0.8, 0.05, 0, 0, 0}; });
  lod::DiffusionSurfaceTracer tracer(mesh, "D");
  const Vec3 seed{0.5, 0.47, 0.43};
  const lod::DiffusionSurfaces s = tracer.trace(std::span<const Vec3>(&seed, 1), {});
  ASSERT_EQ(s.surface_count(), 1u);
  double worst = 0;
  for (size_t v = 0; v < s.vertex_count(); ++v) worst = std::max(worst, std::fabs(s.z[v] - 0.43));
  EXPECT_LT(worst, 1e-5) << "the plane z = 0.43";
  EXPECT_GT(area(s, 0), 0.8) << "the surface reaches the box's sides (within an edge)";
  EXPECT_LE(area(s, 0), 1.0 + 1e-6);
  const Topology t = topology(s, 0);
  EXPECT_EQ(t.edges_over_two, 0u);
  EXPECT_EQ(t.directed_twice, 0u) << "consistently oriented";
  EXPECT_EQ(t.euler(), 1) << "a disc: V " << t.vertices << " E " << t.edges << " F " << t.triangles;
  EXPECT_GT(s.operations[size_t(lod::SurfaceOperation::border)], 0u);
  for (size_t v = 0; v < s.vertex_count(); ++v) EXPECT_NEAR(std::fabs(s.nz[v]), 1.0, 1e-6);
}

// Spheres of three radii about the centre, seeded in three directions each, at four edge
// lengths: every surface manifold, consistently oriented, on its sphere and of its area; all
// but a few (a hole of a few edges where no triangle fitted) closed, of genus 0.
TEST(DiffusionSurfaces, ARadialMinorEigenvectorGivesClosedSpheres) {
  const Vec3 centre{0.5, 0.5, 0.5};
  const storage::TetMesh mesh = tensor_box(20, [&](const Vec3& p) { return with_normal(normalise(p - centre, {1, 0, 0}), 1.0, 0.05); });
  lod::DiffusionSurfaceTracer tracer(mesh, "D");
  int surfaces = 0, closed = 0;
  for (const double edge : {0.02, 0.03, 0.045, 0.06})
    for (const double r : {0.15, 0.25, 0.35})
      for (const Vec3& direction : {Vec3{1, 0, 0}, normalise(Vec3{1, 2, -1}), normalise(Vec3{-0.3, 0.4, 0.8})}) {
        SCOPED_TRACE("edge " + std::to_string(edge) + " radius " + std::to_string(r));
        const Vec3 seed = centre + direction * r;
        lod::DiffusionSurfaceOptions o;
        o.edge = edge;
        const lod::DiffusionSurfaces s = tracer.trace(std::span<const Vec3>(&seed, 1), o);
        ASSERT_EQ(s.surface_count(), 1u);
        ++surfaces;
        const Topology t = topology(s, 0);
        EXPECT_EQ(t.edges_over_two, 0u);
        EXPECT_EQ(t.directed_twice, 0u) << "consistently oriented";
        EXPECT_LE(t.border_edges, 3u) << "at most one small hole";
        closed += t.border_edges == 0 && t.euler() == 2;
        double worst = 0;
        for (size_t v = 0; v < s.vertex_count(); ++v) worst = std::max(worst, std::fabs(length(vertex(s, uint32_t(v)) - centre) - r));
        EXPECT_LT(worst, 0.01) << "on the sphere";
        const double sphere = 4 * std::numbers::pi * r * r;
        EXPECT_NEAR(area(s, 0), sphere, 0.04 * sphere);
        EXPECT_FALSE(s.truncated);
      }
  EXPECT_GE(closed, surfaces * 9 / 10) << closed << " of " << surfaces << " closed";
}

// A helicoid's normal field (the dissertation's Spiral): z = 0.5 + c θ about the axis x = y = 0.5,
// where the field is singular (the tensor isotropic on the axis). The surface grown from one
// seed is one manifold disc, consistently oriented, on the helicoid, winding up the box; it
// ends at a border along the singular axis, close to it, without folding or jumping sheets.
TEST(DiffusionSurfaces, AHelicoidGrowsUpToItsSingularAxisWithoutFolding) {
  const double c = 0.25;
  const storage::TetMesh mesh = tensor_box(20, [&](const Vec3& p) {
    const double x = p[0] - 0.5, y = p[1] - 0.5, r2 = x * x + y * y;
    if (r2 < 1e-12) return SymmetricTensor{1, 1, 1, 0, 0, 0};
    return with_normal(normalise(Vec3{c * y / r2, -c * x / r2, 1.0}), 1.0, 0.05);
  });
  lod::DiffusionSurfaceTracer tracer(mesh, "D");
  const Vec3 seed{0.75, 0.5, 0.5};
  lod::DiffusionSurfaceOptions o;
  o.edge = 0.03;
  const lod::DiffusionSurfaces s = tracer.trace(std::span<const Vec3>(&seed, 1), o);
  ASSERT_EQ(s.surface_count(), 1u);
  const Topology t = topology(s, 0);
  EXPECT_EQ(t.edges_over_two, 0u);
  EXPECT_EQ(t.directed_twice, 0u);
  EXPECT_EQ(t.euler(), 1) << "a disc: V " << t.vertices << " E " << t.edges << " F " << t.triangles;
  const double spacing = c * std::numbers::pi;  // between the sheets over a point of the plane
  double worst = 0, nearest = 1, lowest = 1, highest = 0;
  for (size_t v = 0; v < s.vertex_count(); ++v) {
    double dz = std::fmod(s.z[v] - 0.5 - c * std::atan2(s.y[v] - 0.5, s.x[v] - 0.5), spacing);
    dz = dz < 0 ? dz + spacing : dz;
    worst = std::max(worst, std::min(dz, spacing - dz));
    nearest = std::min(nearest, double(std::hypot(s.x[v] - 0.5, s.y[v] - 0.5)));
    lowest = std::min(lowest, double(s.z[v])), highest = std::max(highest, double(s.z[v]));
  }
  EXPECT_LT(worst, 0.15 * spacing) << "on the helicoid";
  EXPECT_LT(nearest, o.edge) << "up to the axis";
  EXPECT_GT(highest - lowest, 0.9) << "winding through the box";
}

TEST(DiffusionSurfaces, SegmentationFindsLinearPlanarAndIsotropicThirds) {
  const storage::TetMesh mesh = tensor_box(6, [](const Vec3& p) {
    if (p[0] < 0.33) return SymmetricTensor{1.0, 0.1, 0.1, 0, 0, 0};  // a cigar
    if (p[0] < 0.67) return SymmetricTensor{1.0, 1.0, 0.1, 0, 0, 0};  // a pancake
    return SymmetricTensor{1.0, 1.0, 1.0, 0, 0, 0};
  });
  const lod::AnisotropySegmentation s = lod::segment_anisotropy(mesh, "D", 0.3, 0.3);
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const lod::Anisotropy expected = mesh.x[v] < 0.33 ? lod::Anisotropy::linear : mesh.x[v] < 0.67 ? lod::Anisotropy::planar : lod::Anisotropy::isotropic;
    EXPECT_EQ(s.vertex_class[v], expected) << "vertex " << v;
  }
  EXPECT_NEAR(s.volume_share[0] + s.volume_share[1] + s.volume_share[2], 1.0, 1e-9);
  EXPECT_GT(s.volume_share[size_t(lod::Anisotropy::planar)], 0.2);
  EXPECT_THROW(lod::segment_anisotropy(kuhn_box(2, 0, [](float, float, float) { return 0.0; }), "f", 0.3, 0.3), std::invalid_argument);
}

TEST(DiffusionSurfaces, SeedsOutsideTheDomainOrOffPlanarRegionsAreRefused) {
  const storage::TetMesh mesh = tensor_box(6, [](const Vec3& p) { return p[2] < 0.5 ? SymmetricTensor{1, 1, 1, 0, 0, 0} : SymmetricTensor{1, 0.9, 0.05, 0, 0, 0}; });
  lod::DiffusionSurfaceTracer tracer(mesh, "D");
  const std::vector<Vec3> seeds = {{2, 2, 2}, {0.5, 0.5, 0.2}, {0.5, 0.5, 0.8}};
  const lod::DiffusionSurfaces s = tracer.trace(seeds, {});
  EXPECT_EQ(s.seeds, 3u);
  EXPECT_EQ(s.seeds_refused, 2u);
  ASSERT_EQ(s.surface_count(), 1u);
  EXPECT_EQ(s.surface_seed[0], 2u);
  for (size_t v = 0; v < s.vertex_count(); ++v) EXPECT_GT(s.z[v], 0.45) << "the surface stays in the planar region";
}

}  // namespace
}  // namespace tetrascope::testing
