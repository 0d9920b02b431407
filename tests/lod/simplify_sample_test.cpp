// The sampling simplifier (lod/simplify/simplify_sample*.cpp, dissertation §4.2): its output is
// conforming, positively oriented and inside the input's domain up to the border error; locked
// border faces stay bit-identical; a border collapse that would make the border intersect
// itself is refused; Steiner points carry interpolated values; bad thresholds are refused.
// The triangle tests and the border check of `tetrascope error` against hand-built cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

#include "../../lod/simplify/simplify_sample.h"
#include <random>

#include "mesh_checks.h"
#include "mt_fixture.h"
#include "test_paths.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/storage/store_verify.h"
#include "tetrascope/lod/simplify/border_intersection.h"
#include "tetrascope/lod/field/error_measure.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

using lod::detail::Point3;

// Every boundary edge in exactly two boundary faces (a closed, conforming border).
size_t open_border_edges(const storage::TetMesh& m) {
  std::map<std::array<uint32_t, 2>, int> uses;
  for (const auto& f : lod::border_triangles(m))
    for (int e = 0; e < 3; ++e) {
      std::array<uint32_t, 2> key{f[e], f[(e + 1) % 3]};
      std::sort(key.begin(), key.end());
      ++uses[key];
    }
  size_t open = 0;
  for (const auto& [edge, count] : uses) open += count != 2;
  return open;
}

TEST(SimplifySample, OutputIsConformingPositiveAndInsideTheDomain) {
  storage::TetMesh original = kuhn_box(10, 0.3, [](float x, float y, float z) { return std::sin(3 * x) + y * z; });
  storage::TetMesh mesh = original;
  lod::SimplifyOptions options;
  options.target_tets = original.tet_count() / 5;
  options.border_error = 0.01;
  const lod::SimplifyReport report = lod::simplify_sampled(mesh, options);
  EXPECT_GT(report.samples, 20u);
  EXPECT_LT(report.border_after, report.border_before) << "the flat faces of the box simplify";
  EXPECT_LT(mesh.tet_count(), original.tet_count() / 2);
  EXPECT_GT(mesh.tet_count(), original.tet_count() / 20);
  const MeshCheck c = check_mesh(mesh);
  EXPECT_EQ(c.faces_shared_by_more_than_two, 0u);
  EXPECT_EQ(c.nonpositive, 0u);
  EXPECT_EQ(open_border_edges(mesh), 0u);
  EXPECT_NEAR(c.volume, 1.0, 1e-3) << "the box's border is planar: collapses on it keep the volume";
  const double diagonal = std::sqrt(3.0);
  for (size_t v = 0; v < mesh.vertex_count(); ++v)
    for (float coordinate : {mesh.x[v], mesh.y[v], mesh.z[v]}) {
      EXPECT_GE(coordinate, -options.border_error * diagonal);
      EXPECT_LE(coordinate, 1 + options.border_error * diagonal);
    }
  const lod::MeshErrorReport error = lod::measure_error(original, mesh, 2000);
  EXPECT_LE(error.hausdorff, options.border_error * diagonal);
  EXPECT_LT(error.mean_all, 0.05);
  EXPECT_TRUE(lod::border_self_intersections(mesh).pairs.empty());
}

TEST(SimplifySample, ThresholdsAloneSetTheSampling) {
  storage::TetMesh mesh = kuhn_box(8, 0.2, [](float x, float, float) { return x; });
  storage::TetMesh coarse = mesh, fine = mesh;
  lod::SimplifyOptions options;
  options.field_error = 0.5;
  const auto few = lod::simplify_sampled(coarse, options);
  options.space_error = 0.05;
  const auto more = lod::simplify_sampled(fine, options);
  EXPECT_GT(more.samples, few.samples) << "a space error threshold splits the large leaves across the step";
  EXPECT_EQ(check_mesh(fine).nonpositive, 0u);
}

TEST(SimplifySample, LockedBorderFacesStayBitIdentical) {
  // The half x < 0.5 of a box, its face x = 0.5 locked as a segment border is in preprocess.
  storage::TetMesh box = kuhn_box(8, 0, [](float x, float y, float z) { return x + 2 * y - z; });
  storage::TetMesh half;
  half.x = box.x;
  half.y = box.y;
  half.z = box.z;
  half.attributes = box.attributes;
  for (size_t t = 0; t < box.tet_count(); ++t) {
    double cx = 0;
    for (int k = 0; k < 4; ++k) cx += box.x[box.tets[4 * t + k]];
    if (cx / 4 < 0.5) half.tets.insert(half.tets.end(), box.tets.begin() + 4 * t, box.tets.begin() + 4 * t + 4);
  }
  storage::drop_unused_vertices(half);
  std::vector<uint8_t> locked(half.vertex_count(), 0);
  for (size_t v = 0; v < half.vertex_count(); ++v) locked[v] = half.x[v] == 0.5f;
  using Corner = std::array<float, 4>;  // x, y, z, f
  auto corner = [](const storage::TetMesh& m, uint32_t v) { return Corner{m.x[v], m.y[v], m.z[v], m.attributes[0].values[v]}; };
  std::set<std::array<Corner, 3>> locked_faces;
  for (auto f : lod::border_triangles(half))
    if (locked[f[0]] && locked[f[1]] && locked[f[2]]) {
      std::array<Corner, 3> key{corner(half, f[0]), corner(half, f[1]), corner(half, f[2])};
      std::sort(key.begin(), key.end());
      locked_faces.insert(key);
    }
  ASSERT_GT(locked_faces.size(), 50u);
  storage::TetMesh mesh = half;
  lod::SimplifyOptions options;
  options.target_tets = half.tet_count() / 4;
  const auto report = lod::simplify_sampled(mesh, options, locked);
  std::set<std::array<Corner, 3>> after;
  for (auto f : lod::border_triangles(mesh)) {
    std::array<Corner, 3> key{corner(mesh, f[0]), corner(mesh, f[1]), corner(mesh, f[2])};
    std::sort(key.begin(), key.end());
    after.insert(key);
  }
  for (const auto& face : locked_faces) EXPECT_TRUE(after.count(face)) << "a locked border face changed or vanished";
  // every kept vertex keeps its position bit for bit, a locked one its value too; a free one's
  // fitted value reproduces the linear field
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const uint32_t src = report.source_vertex[v];
    if (src == 0xFFFFFFFFu) continue;
    const Corner kept = corner(mesh, static_cast<uint32_t>(v)), source = corner(half, src);
    EXPECT_EQ((std::array<float, 3>{kept[0], kept[1], kept[2]}), (std::array<float, 3>{source[0], source[1], source[2]}));
    if (locked[src]) {
      EXPECT_EQ(kept[3], source[3]) << "locked vertex " << src;
    } else {
      EXPECT_NEAR(kept[3], source[3], 1e-5) << "free vertex " << src;
    }
  }
  EXPECT_EQ(check_mesh(mesh).nonpositive, 0u);
  EXPECT_EQ(check_mesh(mesh).faces_shared_by_more_than_two, 0u);
  EXPECT_LT(mesh.tet_count(), half.tet_count());
}

// An octahedron (apexes at z = 2 and z = -0.2 over a square) around a small tetrahedron on
// its axis: every collapse of the octahedron sweeps a triangle through the tetrahedron.
std::vector<std::array<uint32_t, 3>> octahedron_and_tet(std::vector<Point3>& positions, bool with_tet) {
  positions = {{1, 1, 0}, {-1, 1, 0}, {-1, -1, 0}, {1, -1, 0}, {0, 0, 2}, {0, 0, -0.2}};
  std::vector<std::array<uint32_t, 3>> triangles;
  for (uint32_t i = 0; i < 4; ++i) {
    triangles.push_back({i, (i + 1) % 4, 4});
    triangles.push_back({(i + 1) % 4, i, 5});
  }
  if (with_tet) {
    const uint32_t b = 6;
    positions.insert(positions.end(), {{-0.1, -0.1, -0.05}, {0.1, -0.1, -0.05}, {0, 0.1, -0.05}, {0, 0, 0.08}});
    triangles.insert(triangles.end(), {{b, b + 2, b + 1}, {b, b + 1, b + 3}, {b + 1, b + 2, b + 3}, {b + 2, b, b + 3}});
  }
  return triangles;
}

TEST(SimplifySample, BorderCollapseThatWouldSelfIntersectIsRefused) {
  std::vector<Point3> positions;
  // without the inner tetrahedron the octahedron simplifies
  auto alone = octahedron_and_tet(positions, false);
  const auto free_run = lod::detail::simplify_border(positions, alone, {}, 0, 100.0);
  EXPECT_GT(free_run.collapses, 0u);
  // with it, every collapse would cut through it: all refused as intersections
  auto both = octahedron_and_tet(positions, true);
  ASSERT_TRUE(lod::detail::self_intersections(positions, both, 10).empty()) << "the input is intersection-free";
  const auto run = lod::detail::simplify_border(positions, both, {}, 0, 100.0);
  EXPECT_EQ(run.collapses, 0u);
  EXPECT_GT(run.refused_intersection, 0u);
  EXPECT_EQ(run.triangles.size(), both.size());
  EXPECT_TRUE(lod::detail::self_intersections(positions, run.triangles, 10).empty());
}

TEST(SimplifySample, TriangleTestsSeparateTouchingFromCrossing) {
  std::vector<Point3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},                 // 0-2: a triangle in z = 0
                           {0.2, 0.2, -1}, {0.3, 0.2, 1}, {0.2, 0.3, 1},     // 3-5: pierces it
                           {0.2, 0.2, 0.5}, {0.3, 0.2, 1}, {0.2, 0.3, 1},    // 6-8: above it
                           {0.2, 0.2, 0}};                                   // 9: in its plane, inside
  using lod::detail::triangle_pair_intersects;
  EXPECT_TRUE(triangle_pair_intersects(p, {0, 1, 2}, {3, 4, 5}));
  EXPECT_FALSE(triangle_pair_intersects(p, {0, 1, 2}, {6, 7, 8}));
  EXPECT_FALSE(triangle_pair_intersects(p, {0, 1, 2}, {0, 4, 5})) << "sharing a vertex only";
  EXPECT_TRUE(triangle_pair_intersects(p, {0, 1, 2}, {0, 9, 4})) << "sharing a vertex, lying across the other in its plane";
  EXPECT_FALSE(triangle_pair_intersects(p, {0, 1, 2}, {1, 0, 4})) << "sharing an edge, bent";
  EXPECT_TRUE(triangle_pair_intersects(p, {0, 1, 2}, {1, 0, 9})) << "sharing an edge, folded flat onto it";
}

TEST(SimplifySample, BorderCheckFindsCrossingTets) {
  storage::TetMesh m = kuhn_box(2, 0, [](float x, float, float) { return x; });
  EXPECT_TRUE(lod::border_self_intersections(m).pairs.empty());
  EXPECT_EQ(lod::border_self_intersections(m).border_triangles, 6u * 2 * 4);
  // a separate tet poking through the box's face x = 1
  const uint32_t b = static_cast<uint32_t>(m.vertex_count());
  for (auto [x, y, z] : std::vector<std::array<float, 3>>{{0.9f, 0.4f, 0.4f}, {1.5f, 0.4f, 0.4f}, {1.2f, 0.7f, 0.4f}, {1.2f, 0.5f, 0.8f}}) {
    m.x.push_back(x);
    m.y.push_back(y);
    m.z.push_back(z);
    m.attributes[0].values.push_back(x);
  }
  uint32_t tet[4] = {b, b + 1, b + 2, b + 3};
  if (storage::signed_volume(m, tet[0], tet[1], tet[2], tet[3]) < 0) std::swap(tet[2], tet[3]);
  m.tets.insert(m.tets.end(), tet, tet + 4);
  EXPECT_FALSE(lod::border_self_intersections(m).pairs.empty());
}

// Schönhardt's twisted prism (no tetrahedralization without an added point), filled by the
// 8 tets from its centre, with f = x. The centre is locked (kept out of the samples), so
// TetGen must add Steiner points inside the prism.
storage::TetMesh schoenhardt_prism(double twist_degrees) {
  storage::TetMesh m;
  const double pi = std::acos(-1.0);
  for (int level = 0; level < 2; ++level)
    for (int i = 0; i < 3; ++i) {
      const double angle = 2 * pi * i / 3 + (level ? twist_degrees * pi / 180 : 0);
      m.x.push_back(static_cast<float>(std::cos(angle)));
      m.y.push_back(static_cast<float>(std::sin(angle)));
      m.z.push_back(static_cast<float>(level));
    }
  m.x.push_back(0.05f);
  m.y.push_back(-0.03f);
  m.z.push_back(0.5f);
  const uint32_t centre = 6;
  std::vector<std::array<uint32_t, 3>> faces = {{0, 2, 1}, {3, 4, 5}};
  for (uint32_t i = 0; i < 3; ++i) {
    const uint32_t a = i, a1 = (i + 1) % 3, b = 3 + i, b1 = 3 + (i + 1) % 3;
    faces.push_back({a, a1, b1});
    faces.push_back({a, b1, b});
  }
  for (const auto& f : faces) {
    uint32_t tet[4] = {f[0], f[2], f[1], centre};
    m.tets.insert(m.tets.end(), tet, tet + 4);
  }
  storage::Attribute f;  // f = x
  f.info.name = "f";
  f.values.assign(m.x.begin(), m.x.end());
  m.attributes.push_back(std::move(f));
  return m;
}

TEST(SimplifySample, SteinerPointsCarryInterpolatedValues) {
  // f = x: a kept vertex keeps its value; a Steiner point's barycentric value in the input is exact
  storage::TetMesh mesh = schoenhardt_prism(30);
  const MeshCheck input = check_mesh(mesh);
  ASSERT_EQ(input.nonpositive, 0u) << "the centre sees every face of the prism";
  std::vector<uint8_t> locked(mesh.vertex_count(), 0);
  locked[6] = 1;
  lod::SimplifyOptions options;
  options.target_tets = 8;
  options.border_error = 0;
  options.fit_values = false;  // the values as sampled and interpolated, not fitted
  const storage::TetMesh original = mesh;
  const auto report = lod::simplify_sampled(mesh, options, locked);
  ASSERT_GT(report.steiner_points, 0u) << "Schönhardt's prism needs an added point";
  EXPECT_EQ(report.border_after, 8u);
  EXPECT_EQ(check_mesh(mesh).nonpositive, 0u);
  EXPECT_NEAR(check_mesh(mesh).volume, input.volume, 1e-5);
  size_t steiner = 0;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    if (report.source_vertex[v] != 0xFFFFFFFFu) {
      EXPECT_EQ(mesh.attributes[0].values[v], original.attributes[0].values[report.source_vertex[v]]);
      continue;
    }
    ++steiner;
    EXPECT_NEAR(mesh.attributes[0].values[v], mesh.x[v], 1e-5) << "Steiner point " << v;
  }
  EXPECT_EQ(steiner, report.steiner_points);
}

TEST(SimplifySample, ABorderEnclosingACavityFallsBackToQuadrics) {
  // a box with its central cube removed: TetGen would fill the cavity, so the mesh goes to
  // the quadric simplifier and the cavity stays
  storage::TetMesh box = kuhn_box(4, 0, [](float x, float, float) { return x; });
  storage::TetMesh hollow = box;
  hollow.tets.clear();
  for (size_t t = 0; t < box.tet_count(); ++t) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 4; ++k) {
      c[0] += box.x[box.tets[4 * t + k]] / 4;
      c[1] += box.y[box.tets[4 * t + k]] / 4;
      c[2] += box.z[box.tets[4 * t + k]] / 4;
    }
    const bool inside = c[0] > 0.25 && c[0] < 0.75 && c[1] > 0.25 && c[1] < 0.75 && c[2] > 0.25 && c[2] < 0.75;
    if (!inside) hollow.tets.insert(hollow.tets.end(), box.tets.begin() + 4 * t, box.tets.begin() + 4 * t + 4);
  }
  storage::drop_unused_vertices(hollow);
  lod::SimplifyOptions options;
  options.target_tets = hollow.tet_count() / 2;
  const auto report = lod::simplify_sampled(hollow, options);
  EXPECT_TRUE(report.fell_back_to_qem);
  EXPECT_NEAR(check_mesh(hollow).volume, 1.0 - 0.125, 1e-3) << "the cavity stays empty";
  EXPECT_EQ(check_mesh(hollow).nonpositive, 0u);
}

TEST(SimplifySample, ABorderThatCrossesItselfFallsBackToQuadrics) {
  // two boxes that overlap without sharing a vertex: their faces cross, which TetGen cannot
  // mesh (and TetGen 1.5 then crashed freeing its memory, on a segment of the 5M blade); the
  // sampler sees the crossing first and leaves the mesh to the quadric simplifier
  storage::TetMesh a = kuhn_box(3, 0, [](float x, float, float) { return x; });
  storage::TetMesh both = a;
  const uint32_t offset = static_cast<uint32_t>(a.vertex_count());
  for (size_t v = 0; v < a.vertex_count(); ++v) {
    both.x.push_back(a.x[v] + 0.5f);
    both.y.push_back(a.y[v] + 0.13f);
    both.z.push_back(a.z[v] + 0.17f);
  }
  for (auto& attribute : both.attributes) attribute.values.insert(attribute.values.end(), attribute.values.begin(), attribute.values.end());
  for (uint32_t v : a.tets) both.tets.push_back(v + offset);
  lod::SimplifyOptions options;
  options.target_tets = both.tet_count() / 2;
  lod::SimplifyReport report;
  ASSERT_NO_THROW(report = lod::simplify_sampled(both, options));
  EXPECT_TRUE(report.fell_back_to_qem);
  EXPECT_GT(both.tet_count(), 0u);
  EXPECT_EQ(check_mesh(both).nonpositive, 0u);
}

TEST(SimplifySample, FittedValuesMissTheInputLessThanSampledOnes) {
  // an oscillating field at a tenth of the tets: the least-squares values are closer to the
  // input than the samples' own, a linear field stays exact, and locked vertices keep theirs
  const storage::TetMesh original = kuhn_box(12, 0.2, [](float x, float y, float z) { return std::sin(9 * x) * std::cos(7 * y) + z; });
  lod::SimplifyOptions options;
  options.target_tets = original.tet_count() / 10;
  storage::TetMesh sampled = original, fitted = original;
  options.fit_values = false;
  lod::simplify_sampled(sampled, options);
  options.fit_values = true;
  lod::simplify_sampled(fitted, options);
  ASSERT_EQ(sampled.tet_count(), fitted.tet_count()) << "the fit changes values, not tets";
  const double before = lod::measure_error(original, sampled, 500).mean_all, after = lod::measure_error(original, fitted, 500).mean_all;
  EXPECT_GT(before, 0.01);
  EXPECT_LT(after, 0.9 * before);
  EXPECT_EQ(check_mesh(fitted).nonpositive, 0u);
  EXPECT_TRUE(lod::border_self_intersections(fitted).pairs.empty());

  const storage::TetMesh ramp = kuhn_box(8, 0.2, [](float x, float y, float z) { return x - 2 * y + 0.5f * z; });
  storage::TetMesh linear = ramp;
  std::vector<uint8_t> locked(ramp.vertex_count(), 0);
  for (size_t v = 0; v < ramp.vertex_count(); v += 7) locked[v] = 1;
  options.target_tets = ramp.tet_count() / 5;
  const lod::SimplifyReport report = lod::simplify_sampled(linear, options, locked);
  ASSERT_FALSE(report.fell_back_to_qem);
  for (size_t v = 0; v < linear.vertex_count(); ++v) {
    const float value = linear.attributes[0].values[v];
    EXPECT_NEAR(value, linear.x[v] - 2 * linear.y[v] + 0.5f * linear.z[v], 2e-4) << "vertex " << v;
    const uint32_t source = report.source_vertex[v];
    if (source != 0xFFFFFFFFu && locked[source]) {
      EXPECT_EQ(value, ramp.attributes[0].values[source]) << "locked vertex " << source;
    }
  }
}

TEST(SimplifySample, SamplesGatherWhereTheFieldBends) {
  // a field linear on x < 0.5 and oscillating on x > 0.5: most samples fall where it
  // oscillates (a linear field's own leaves are split for their size only)
  const storage::TetMesh original = kuhn_box(14, 0.2, [](float x, float y, float z) {
    return x < 0.5f ? x + y + z : x + y + z + 0.5f * std::sin(30 * (x - 0.5f)) * std::sin(20 * y) * std::sin(20 * z);
  });
  storage::TetMesh mesh = original;
  lod::SimplifyOptions options;
  options.target_tets = original.tet_count() / 10;
  const lod::SimplifyReport report = lod::simplify_sampled(mesh, options);
  size_t left = 0, right = 0;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const uint32_t source = report.source_vertex[v];
    if (source == 0xFFFFFFFFu || mesh.x[v] <= 0.01f || mesh.x[v] >= 0.99f || mesh.y[v] <= 0.01f || mesh.y[v] >= 0.99f || mesh.z[v] <= 0.01f ||
        mesh.z[v] >= 0.99f)
      continue;  // the border's vertices and Steiner points: not samples
    (mesh.x[v] < 0.5f ? left : right) += 1;
  }
  EXPECT_GT(right, 2 * left) << left << " samples on the linear side, " << right << " where the field oscillates";
}

TEST(SimplifySample, AFlatBorderOfEvenValuesKeepsOnlyItsCorners) {
  // a box whose field vanishes on its faces: collapses there cost nothing, so they go on past
  // the border's share of the target and the freed tets go to interior samples
  const storage::TetMesh original = kuhn_box(10, 0.2, [](float x, float y, float z) { return std::sin(3.14159265f * x) * std::sin(3.14159265f * y) * std::sin(3.14159265f * z); });
  storage::TetMesh mesh = original;
  lod::SimplifyOptions options;
  options.target_tets = original.tet_count() / 10;
  const lod::SimplifyReport report = lod::simplify_sampled(mesh, options);
  EXPECT_LE(report.border_after, 24u) << "each face of the box needs two triangles";
  EXPECT_EQ(open_border_edges(mesh), 0u);
  EXPECT_NEAR(check_mesh(mesh).volume, 1.0, 1e-3);
  EXPECT_TRUE(lod::border_self_intersections(mesh).pairs.empty());
}

TEST(SimplifySample, BadThresholdsAreRefused) {
  const storage::TetMesh box = kuhn_box(3, 0, [](float x, float, float) { return x; });
  auto refused = [&](auto set, const std::string& expected) {
    storage::TetMesh mesh = box;
    lod::SimplifyOptions options;
    options.target_tets = 20;
    set(options);
    try {
      lod::simplify_sampled(mesh, options);
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  refused([](lod::SimplifyOptions& o) { o.field_error = -1; }, "field error");
  refused([](lod::SimplifyOptions& o) { o.space_error = std::nan(""); }, "space error");
  refused([](lod::SimplifyOptions& o) { o.border_error = 2; }, "border error");
  refused([](lod::SimplifyOptions& o) { o.target_tets = 0; }, "target tet count");
  refused([](lod::SimplifyOptions& o) { o.attributes = {"nope"}; }, "no attribute 'nope'");
}

TEST(SimplifySample, PreprocessWithTheSamplerVerifiesAndCutsConform) {
  // the store conformity checks of mt_build_test and cut_test, on a store whose segments the
  // sampler simplified with their borders locked
  lod::PreprocessOptions options;
  options.segment_tets = 2000;
  options.base_tets = 3000;
  options.replace = true;
  options.simplifier = lod::SimplifyMethod::kSample;
  const auto path = scratch_dir("multires-sampled") / "store";
  const auto report = lod::preprocess(sample_mesh(), path, options);
  ASSERT_GE(report.levels.size(), 3u);
  for (size_t i = 1; i < report.levels.size(); ++i) EXPECT_LT(report.levels[i].tets, report.levels[i - 1].tets);
  const auto verified = storage::verify_store(path);
  EXPECT_TRUE(verified.ok) << (verified.problems.empty() ? "" : verified.problems[0]);
  auto store = storage::Store::open(path);
  auto dag = lod::open_dag(*store);
  ASSERT_TRUE(dag);
  const auto problems = lod::verify_dag(*store, *dag);
  EXPECT_TRUE(problems.empty()) << (problems.empty() ? "" : problems[0]);
  storage::SegmentCache cache(*store, 1ull << 28);
  lod::Cut cut(*dag);
  expect_conforming(lod::assemble_cut(*store, cache, cut), "coarsest cut");
  std::mt19937 rng(7);
  for (int round = 0; round < 6; ++round) {
    for (int step = 0; step < 12; ++step) {
      const uint32_t node = rng() % dag->node_count();
      if (rng() % 3 == 0) cut.coarsen(node);
      else cut.refine(node);
    }
    auto m = lod::assemble_cut(*store, cache, cut);
    EXPECT_EQ(m.mesh.tet_count(), cut.tet_count());
    expect_conforming(m, "sampled store, round " + std::to_string(round));
  }
}

}  // namespace
}  // namespace tetrascope::testing
