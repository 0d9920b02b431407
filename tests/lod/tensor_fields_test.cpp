// The dissertation's artificial tensor fields (§7.4.4; tests/support/tensor_fields.h, written
// as VTK by bench/tensor_fields.py), where the exact curves of the major eigenvector and the
// exact diffusion surfaces are known: stream tubes' lines (dense seeding, as render --mode
// tensors traces them) follow the exact curve through their first point within 0.5% of the
// box diagonal on average, and the diffusion surfaces are manifold: the spiral's wind about
// its singular axis up to it (three seeds of five give a disc, two are torn), the
// sphere case's close as spheres (genus 0) about the linear core, the sinusoidal case's are flat
// discs.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "tensor_fields.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/lod/field/diffusion_surfaces.h"
#include "tetrascope/lod/field/streamlines.h"

namespace tetrascope::testing {
namespace {

constexpr double kDiagonal = 1.7320508075688772;  // of the unit cube

lod::Streamlines dense_lines(const storage::TetMesh& m, uint32_t cells, double min_cl) {
  const std::vector<uint32_t> opposite = pair_faces(m.tets).opposite;
  const lod::StreamlineTracer tracer(m, opposite, "D");
  lod::StreamlineOptions o;
  o.zero_speed = min_cl;
  o.max_steps = 2000;
  lod::SeedSpec seeds;
  seeds.dense_resolution = cells;
  return tracer.trace(seeds, o);
}

struct Deviation {
  double mean = 0, worst = 0;
  size_t points = 0, lines = 0;
};

// Each line's points against the exact curve through its first point: distance(first, p).
template <class Distance>
Deviation deviation(const lod::Streamlines& s, Distance distance) {
  Deviation d;
  double sum = 0;
  for (size_t l = 0; l < s.line_count(); ++l) {
    const uint32_t first = s.line_first[l], end = s.line_first[l + 1];
    if (end < first + 2) continue;
    ++d.lines;
    const Vec3 p0{s.x[first], s.y[first], s.z[first]};
    for (uint32_t i = first; i < end; ++i) {
      const double e = distance(p0, Vec3{s.x[i], s.y[i], s.z[i]});
      sum += e;
      d.worst = std::max(d.worst, e);
      ++d.points;
    }
  }
  d.mean = d.points ? sum / double(d.points) : 0;
  return d;
}

TEST(ArtificialTensorFields, SinusoidalTubesFollowTheSinusoidsWithinAHalfPercentOfTheDiagonal) {
  const storage::TetMesh m = artificial_tensor_box(20, sinusoidal_tensor);
  const lod::Streamlines s = dense_lines(m, 8, 0.2);
  const Deviation d = deviation(s, [](const Vec3& p0, const Vec3& p) {
    const double y = p0[1] + kSineA * (std::sin(kSineK * p[0]) - std::sin(kSineK * p0[0]));
    const double slope = kSineA * kSineK * std::cos(kSineK * p[0]);
    return std::hypot((p[1] - y) / std::sqrt(1 + slope * slope), p[2] - p0[2]);
  });
  ASSERT_GT(d.lines, 20u);
  ASSERT_GT(d.points, 1000u);
  EXPECT_LT(d.mean, 0.005 * kDiagonal) << "mean " << d.mean / kDiagonal << " of the diagonal over " << d.lines << " lines";
  RecordProperty("mean_of_diagonal", std::to_string(d.mean / kDiagonal));
  RecordProperty("worst_of_diagonal", std::to_string(d.worst / kDiagonal));
  RecordProperty("lines", std::to_string(d.lines));
}

TEST(ArtificialTensorFields, SpiralTubesRunRadiallyWithinAHalfPercentOfTheDiagonal) {
  const storage::TetMesh m = artificial_tensor_box(20, spiral_tensor);
  const lod::Streamlines s = dense_lines(m, 8, 0.2);
  const Deviation d = deviation(s, [](const Vec3& p0, const Vec3& p) {
    const double a0 = std::atan2(p0[1] - 0.5, p0[0] - 0.5), r = std::hypot(p[0] - 0.5, p[1] - 0.5);
    const double a = std::atan2(p[1] - 0.5, p[0] - 0.5);
    const double across = r * std::sin(a - a0), behind = r * std::cos(a - a0);  // the ray's own side: behind < 0 crosses the axis
    return std::hypot(behind < 0 ? std::hypot(across, behind) : across, p[2] - p0[2]);
  });
  ASSERT_GT(d.lines, 20u);
  EXPECT_LT(d.mean, 0.005 * kDiagonal) << "mean " << d.mean / kDiagonal << " of the diagonal over " << d.lines << " lines";
  RecordProperty("mean_of_diagonal", std::to_string(d.mean / kDiagonal));
  RecordProperty("worst_of_diagonal", std::to_string(d.worst / kDiagonal));
  RecordProperty("lines", std::to_string(d.lines));
}

TEST(ArtificialTensorFields, SphereCoreTubesRunAlongZWithinAHalfPercentOfTheDiagonal) {
  const storage::TetMesh m = artificial_tensor_box(20, sphere_tensor);
  const lod::Streamlines s = dense_lines(m, 10, 0.3);
  const Deviation d = deviation(s, [](const Vec3& p0, const Vec3& p) { return std::hypot(p[0] - p0[0], p[1] - p0[1]); });
  ASSERT_GT(d.lines, 3u);
  EXPECT_LT(d.mean, 0.005 * kDiagonal) << "mean " << d.mean / kDiagonal << " of the diagonal over " << d.lines << " lines";
  RecordProperty("mean_of_diagonal", std::to_string(d.mean / kDiagonal));
  RecordProperty("worst_of_diagonal", std::to_string(d.worst / kDiagonal));
  RecordProperty("lines", std::to_string(d.lines));
}

struct Topology {
  size_t vertices = 0, edges = 0, triangles = 0, border_edges = 0, edges_over_two = 0;
  long euler() const { return long(vertices) - long(edges) + long(triangles); }
};

Topology topology(const lod::DiffusionSurfaces& s, size_t surface) {
  Topology t;
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  std::set<uint32_t> used;
  for (uint32_t f = s.surface_first[surface]; f < s.surface_first[surface + 1]; ++f) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = s.triangles[3 * f + size_t(k)], b = s.triangles[3 * f + size_t(k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
      used.insert(a);
    }
    ++t.triangles;
  }
  t.vertices = used.size();
  t.edges = uses.size();
  for (const auto& [edge, n] : uses) t.border_edges += n == 1, t.edges_over_two += n > 2;
  return t;
}

// Seeds on a ray from the axis at five distances: every surface is manifold, winds through the
// box and reaches the isotropic core about the axis. Three of the five are discs (Euler
// characteristic 1); the other two are torn (characteristics 0 and -6: holes left where the
// border met itself across the axis): the surfaces do not pass the singular axis without
// tearing from every seed, and the count guards against losing more.
TEST(ArtificialTensorFields, SpiralSurfacesAreManifoldAndReachTheirSingularAxis) {
  const storage::TetMesh m = artificial_tensor_box(20, spiral_tensor);
  const lod::DiffusionSurfaceTracer tracer(m, "D");
  int discs = 0;
  for (const double x : {0.65, 0.7, 0.75, 0.85, 0.9}) {
    SCOPED_TRACE("seed x " + std::to_string(x));
    const Vec3 seed{x, 0.5, 0.5};
    lod::DiffusionSurfaceOptions o;
    o.edge = 0.03;
    const lod::DiffusionSurfaces s = tracer.trace(std::span<const Vec3>(&seed, 1), o);
    ASSERT_EQ(s.surface_count(), 1u);
    const Topology t = topology(s, 0);
    EXPECT_EQ(t.edges_over_two, 0u) << "manifold";
    discs += t.euler() == 1;
    double nearest = 1, lowest = 1, highest = 0;
    for (size_t v = 0; v < s.vertex_count(); ++v) {
      nearest = std::min(nearest, double(std::hypot(s.x[v] - 0.5, s.y[v] - 0.5)));
      lowest = std::min(lowest, double(s.z[v])), highest = std::max(highest, double(s.z[v]));
    }
    EXPECT_LT(nearest, kSpiralCore + o.edge) << "up to the isotropic core about the axis";
    EXPECT_GT(highest - lowest, 0.9) << "winding through the box";
  }
  EXPECT_GE(discs, 3) << "discs of five";
  RecordProperty("discs_of_five", std::to_string(discs));
}

TEST(ArtificialTensorFields, TheSphereCaseGivesClosedSpheresAboutTheLinearCore) {
  const storage::TetMesh m = artificial_tensor_box(20, sphere_tensor);
  const lod::DiffusionSurfaceTracer tracer(m, "D");
  int closed = 0, surfaces = 0;
  for (const double r : {0.27, 0.35}) {
    const Vec3 seed{0.5 + r, 0.5, 0.5};
    lod::DiffusionSurfaceOptions o;
    o.edge = 0.03;
    const lod::DiffusionSurfaces s = tracer.trace(std::span<const Vec3>(&seed, 1), o);
    ASSERT_EQ(s.surface_count(), 1u);
    ++surfaces;
    const Topology t = topology(s, 0);
    EXPECT_EQ(t.edges_over_two, 0u);
    closed += t.border_edges == 0 && t.euler() == 2;
    for (size_t v = 0; v < s.vertex_count(); ++v) EXPECT_NEAR(length(Vec3{s.x[v] - 0.5, s.y[v] - 0.5, s.z[v] - 0.5}), r, 0.01);
  }
  EXPECT_EQ(closed, surfaces) << "closed, genus 0";
}

TEST(ArtificialTensorFields, TheSinusoidalCasesPlanarSlabsGiveFlatDiscs) {
  const storage::TetMesh m = artificial_tensor_box(20, sinusoidal_tensor);
  const lod::DiffusionSurfaceTracer tracer(m, "D");
  const Vec3 seed{0.5, 0.5, 0.375};  // the middle of the planar slab 0.25 < z < 0.5
  const lod::DiffusionSurfaces s = tracer.trace(std::span<const Vec3>(&seed, 1), {});
  ASSERT_EQ(s.surface_count(), 1u);
  const Topology t = topology(s, 0);
  EXPECT_EQ(t.edges_over_two, 0u);
  EXPECT_EQ(t.euler(), 1) << "a disc";
  for (size_t v = 0; v < s.vertex_count(); ++v) EXPECT_NEAR(s.z[v], 0.375, 1e-4);
  EXPECT_GT(t.triangles, 500u) << "across the box";
}

}  // namespace
}  // namespace tetrascope::testing
