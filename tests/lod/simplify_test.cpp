// The quadric simplifier: exact cases (a linear field simplifies with ~zero field error,
// locked vertices stay bit-identical, a collapse that would flip a tet is refused), output
// always conforming with positive volumes, planar boundary keeps its volume, hostile options
// rejected. The error tool is checked against known answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>

#include "fixture_writers.h"
#include "mesh_checks.h"
#include "test_paths.h"
#include "tetrascope/lod/field/error_measure.h"
#include "tetrascope/lod/simplify/quadric.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

// The unit box with f = 2x - y + 0.5z.
storage::TetMesh linear_cube(int n, double jitter = 0) {
  return kuhn_box(n, jitter, [](float x, float y, float z) { return 2 * x - y + 0.5f * z; });
}

struct Check {
  size_t nonmanifold_faces = 0, nonpositive = 0;
  double volume = 0;
};

Check check(const storage::TetMesh& m) {
  const MeshCheck c = check_mesh(m);
  return {c.faces_shared_by_more_than_two, c.nonpositive, c.volume};
}

TEST(Simplify, LinearFieldSimplifiesWithAlmostNoFieldError) {
  storage::TetMesh original = linear_cube(6);
  storage::TetMesh mesh = original;
  lod::SimplifyOptions options;
  options.target_tets = original.tet_count() / 4;
  auto report = lod::simplify(mesh, options);
  EXPECT_LE(mesh.tet_count(), options.target_tets + 6);
  EXPECT_GT(report.collapses, 50u);
  Check c = check(mesh);
  EXPECT_EQ(c.nonmanifold_faces, 0u);
  EXPECT_EQ(c.nonpositive, 0u);
  EXPECT_NEAR(c.volume, 1.0, 1e-4) << "a box has a planar boundary: its volume stays";
  auto error = lod::measure_error(original, mesh, 2000);
  ASSERT_EQ(error.fields.size(), 1u);
  EXPECT_LT(error.fields[0].mean, 1e-4);
  EXPECT_LT(error.fields[0].max, 1e-3);
  EXPECT_LT(error.hausdorff, 1e-4);
}

TEST(Simplify, LockedVerticesStayBitIdentical) {
  storage::TetMesh mesh = linear_cube(5, 0.3);
  // lock the plane x = 0 and one interior vertex
  std::vector<uint8_t> locked(mesh.vertex_count(), 0);
  std::vector<std::array<float, 4>> expected;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.x[v] == 0.0f || v == 100) {
      locked[v] = 1;
      expected.push_back({mesh.x[v], mesh.y[v], mesh.z[v], mesh.attributes[0].values[v]});
    }
  }
  lod::SimplifyOptions options;
  options.target_tets = mesh.tet_count() / 5;
  lod::simplify(mesh, options, locked);
  std::vector<std::array<float, 4>> after;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) after.push_back({mesh.x[v], mesh.y[v], mesh.z[v], mesh.attributes[0].values[v]});
  for (const auto& e : expected) EXPECT_NE(std::find(after.begin(), after.end(), e), after.end()) << "a locked vertex moved or vanished";
  Check c = check(mesh);
  EXPECT_EQ(c.nonpositive, 0u);
  EXPECT_EQ(c.nonmanifold_faces, 0u);
}

TEST(Simplify, CollapsesThatWouldFlipOrCrushTetsAreRefused) {
  // A strongly jittered box: many candidate collapses would flip or crush a tet. They are
  // refused (and counted), and no output tet has a non-positive volume.
  storage::TetMesh mesh = linear_cube(6, 0.5);
  Check before = check(mesh);
  ASSERT_EQ(before.nonpositive, 0u);
  ASSERT_NEAR(before.volume, 1.0, 1e-5) << "the jittered input must not be tangled";
  lod::SimplifyOptions options;
  options.target_tets = mesh.tet_count() / 20;
  options.min_quality = 0.3;
  auto report = lod::simplify(mesh, options);
  EXPECT_GT(report.refused_geometry, 0u);
  Check c = check(mesh);
  EXPECT_EQ(c.nonpositive, 0u);
  EXPECT_EQ(c.nonmanifold_faces, 0u);
}

TEST(Simplify, TwoRegionsAtOnceAreConformingDeterministicAndAsGood) {
  // Both cores on one mesh: two regions collapse at once, then one queue finishes across the
  // cut. The result is conforming, keeps locked vertices, does not depend on thread timing,
  // and its field error stays close to the one-thread run.
  const storage::TetMesh input = linear_cube(12, 0.3);
  std::vector<uint8_t> locked(input.vertex_count(), 0);
  locked[700] = 1;
  const std::array<float, 3> kept{input.x[700], input.y[700], input.z[700]};
  auto run = [&](uint32_t threads) {
    storage::TetMesh mesh = input;
    lod::SimplifyOptions options;
    options.target_tets = input.tet_count() / 10;
    options.threads = threads;
    options.min_tets_per_thread = 1000;
    auto report = lod::simplify(mesh, options, locked);
    EXPECT_EQ(report.threads, static_cast<int>(threads));
    EXPECT_LE(mesh.tet_count(), options.target_tets + 2);
    return mesh;
  };
  storage::TetMesh one = run(1), two = run(2), again = run(2);
  EXPECT_EQ(two.tets, again.tets);
  EXPECT_EQ(two.x, again.x);
  Check c = check(two);
  EXPECT_EQ(c.nonpositive, 0u);
  EXPECT_EQ(c.nonmanifold_faces, 0u);
  EXPECT_NEAR(c.volume, 1.0, 1e-4) << "the planar box keeps its volume";
  bool found = false;
  for (size_t v = 0; v < two.vertex_count(); ++v) found |= two.x[v] == kept[0] && two.y[v] == kept[1] && two.z[v] == kept[2];
  EXPECT_TRUE(found) << "the locked vertex moved";
  const double e1 = lod::measure_error(input, one, 2000).fields[0].mean, e2 = lod::measure_error(input, two, 2000).fields[0].mean;
  EXPECT_LT(e2, 2 * e1 + 1e-6);
}

// Snapshots (what segment variants are built from): the mesh kept at a count is exactly the
// mesh a run with that target leaves, with the same source vertices; with a cap that ends
// the run first, and with a count the run never reaches (the final mesh). Threads are
// asked for and not used: snapshots need the one queue.
TEST(Simplify, ASnapshotIsTheMeshARunToItsCountLeaves) {
  const storage::TetMesh input = linear_cube(9, 0.3);
  std::vector<uint8_t> locked(input.vertex_count(), 0);
  for (size_t v = 0; v < input.vertex_count(); ++v) locked[v] = input.x[v] == 0.0f;
  const uint64_t tets = input.tet_count();
  // a cap that ends the run between tets/4 and tets/8: the cost of the collapse that passes tets/6
  lod::SimplifyOptions traced;
  traced.target_tets = tets / 8;
  traced.trace_costs = true;
  storage::TetMesh scratch = input;
  const auto trace = lod::simplify(scratch, traced, locked).cost_trace;
  const auto passing = std::find_if(trace.begin(), trace.end(), [&](const auto& step) { return step.first <= tets / 6; });
  ASSERT_NE(passing, trace.end());
  for (const double cap : {0.0, passing->second}) {
    auto options = [&](uint64_t target) {
      lod::SimplifyOptions o;
      o.target_tets = target;
      o.max_error = cap;
      return o;
    };
    const std::vector<uint64_t> counts{tets, tets / 2, tets / 4, tets / 8};  // the first: no collapse at all
    storage::TetMesh mesh = input;
    lod::SimplifyOptions with = options(tets / 8);
    with.snapshot_tets = counts;
    with.threads = 2;
    with.min_tets_per_thread = 100;
    const lod::SimplifyReport report = lod::simplify(mesh, with, locked);
    EXPECT_EQ(report.threads, 1);
    ASSERT_EQ(report.snapshots.size(), counts.size());
    std::vector<uint64_t> kept;
    for (size_t k = 0; k < counts.size(); ++k) {
      storage::TetMesh alone = input;
      const lod::SimplifyReport r = lod::simplify(alone, options(counts[k]), locked);
      const lod::SimplifySnapshot& s = report.snapshots[k];
      EXPECT_EQ(s.target, counts[k]);
      EXPECT_EQ(s.mesh.tets, alone.tets) << "count " << counts[k] << ", cap " << cap;
      EXPECT_EQ(s.mesh.x, alone.x);
      EXPECT_EQ(s.mesh.z, alone.z);
      EXPECT_EQ(s.mesh.attributes[0].values, alone.attributes[0].values);
      EXPECT_EQ(s.source_vertex, r.source_vertex);
      kept.push_back(s.mesh.tet_count());
    }
    EXPECT_EQ(report.snapshots.back().mesh.tets, mesh.tets) << "the last count is the run's own";
    EXPECT_EQ(kept[0], tets);
    if (cap == 0) {
      EXPECT_GT(kept[1], kept[2]) << "three different meshes";
      EXPECT_GT(kept[2], kept[3]);
    } else {
      EXPECT_GT(kept.back(), tets / 8) << "the cap ends the run before its target: the last snapshot is the run's end";
    }
  }
  storage::TetMesh mesh = input;
  lod::SimplifyOptions independent;
  independent.target_tets = tets / 2;
  independent.independent = true;
  independent.snapshot_tets = {tets / 2};
  EXPECT_THROW(lod::simplify(mesh, independent), std::invalid_argument);
}

TEST(Simplify, EverySharedDatasetStaysConforming) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to this checkout";
  for (const char* name : {"disk_out_ref.vtk", "fea_bracket.vtk"}) {
    storage::TetMesh mesh = storage::load_mesh(shared_data() / name);
    const size_t before = mesh.tet_count();
    lod::SimplifyOptions options;
    options.target_tets = before / 10;
    lod::simplify(mesh, options);
    EXPECT_LE(mesh.tet_count(), before / 10 + 10) << name;
    Check c = check(mesh);
    EXPECT_EQ(c.nonmanifold_faces, 0u) << name;
    EXPECT_EQ(c.nonpositive, 0u) << name;
  }
}

TEST(Simplify, HostileOptionsAreRejected) {
  storage::TetMesh mesh = linear_cube(2);
  lod::SimplifyOptions none;
  EXPECT_THROW(lod::simplify(mesh, none), std::invalid_argument);
  lod::SimplifyOptions unknown;
  unknown.target_tets = 5;
  unknown.attributes = {"nope"};
  EXPECT_THROW(lod::simplify(mesh, unknown), std::invalid_argument);
  lod::SimplifyOptions negative;
  negative.target_tets = 5;
  negative.boundary_weight = -1;
  EXPECT_THROW(lod::simplify(mesh, negative), std::invalid_argument);
  lod::SimplifyOptions wrong_locks;
  wrong_locks.target_tets = 5;
  EXPECT_THROW(lod::simplify(mesh, wrong_locks, std::vector<uint8_t>(3, 0)), std::invalid_argument);
}

TEST(MeshError, IdenticalMeshesHaveNoErrorAndAShiftedFieldHasTheShift) {
  storage::TetMesh a = linear_cube(3);
  auto same = lod::measure_error(a, a, 500);
  EXPECT_EQ(same.outside, 0u);
  EXPECT_NEAR(same.mean_all, 0, 1e-12);
  EXPECT_NEAR(same.hausdorff, 0, 1e-9);
  storage::TetMesh b = a;
  const auto& f = a.attributes[0].values;
  const double range = *std::max_element(f.begin(), f.end()) - *std::min_element(f.begin(), f.end());
  for (float& v : b.attributes[0].values) v += static_cast<float>(0.1 * range);
  auto shifted = lod::measure_error(a, b, 500);
  EXPECT_NEAR(shifted.fields[0].mean, 0.1, 1e-5);
  EXPECT_NEAR(shifted.fields[0].max, 0.1, 1e-5);
  // moving the whole mesh by 0.05 in x: the boundary surfaces are 0.05 apart at most
  storage::TetMesh c = a;
  for (float& x : c.x) x += 0.05f;
  auto moved = lod::measure_error(a, c, 2000);
  EXPECT_NEAR(moved.hausdorff, 0.05, 1e-5);
  EXPECT_GT(moved.outside, 0u);
}

}  // namespace
}  // namespace tetrascope::testing
