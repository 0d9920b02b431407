// The binary segment hierarchy (preprocess --model binary, §6.2) and the 0-segment (§6.2.3):
// the matching pairs face-adjacent segments; the store passes verify with every segment hung
// whole from one parent; random fronts are conforming, closed and keep the input's volume; the
// 0-segment's adjacency after any swap is the adjacency a full rebuild of the cut mesh finds,
// and a front that over-shares a face is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <random>
#include <set>

#include "mesh_checks.h"
#include "mt_fixture.h"
#include "mt_stages.h"
#include "test_paths.h"
#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/cut/zero_segment.h"
#include "tetrascope/lod/mt/store_check.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

TEST(BinaryPairs, HeavyEdgesPairFirstAndASingleJoinsItsHeaviestNeighbour) {
  // a path 0-1-2-3-4 (shared faces 5, 9, 2, 7) and node 5 alone
  const std::vector<lod::mt::NodeEdge> edges = {{0, 1, 5}, {1, 2, 9}, {2, 3, 2}, {3, 4, 7}};
  std::vector<double> weight;
  for (const auto& e : edges) weight.push_back(double(e.faces));
  const std::vector<uint64_t> size(6, 100);
  uint32_t groups = 0;
  const std::vector<uint32_t> g = lod::mt::match_pairs(6, edges, weight, size, 1, true, &groups);
  EXPECT_EQ(g[1], g[2]) << "the heaviest edge pairs first";
  EXPECT_EQ(g[3], g[4]);
  EXPECT_EQ(g[0], g[1]) << "0, left single, joins the pair it shares faces with";
  EXPECT_NE(g[1], g[3]);
  EXPECT_NE(g[5], g[0]);
  EXPECT_NE(g[5], g[3]);
  EXPECT_EQ(groups, 3u);
  // without attaching, and with edges under the threshold left out
  const std::vector<uint32_t> h = lod::mt::match_pairs(6, edges, weight, size, 6, false, &groups);
  EXPECT_EQ(h[1], h[2]);
  EXPECT_EQ(h[3], h[4]);
  EXPECT_NE(h[0], h[1]);
  EXPECT_EQ(groups, 4u);
}

TEST(BinaryHierarchy, StorePassesVerifyAndHangsEverySegmentWholeFromOneParent) {
  const Built& b = built_binary("sample");
  EXPECT_TRUE(lod::check_store(b.store).empty());
  auto store = storage::Store::open(b.store);
  EXPECT_EQ(store->manifest().json["multiresolution"]["model"], "binary");
  auto dag = lod::open_dag(*store);
  ASSERT_TRUE(dag);
  ASSERT_GE(dag->level_count(), 4u);
  std::vector<uint32_t> per_level(dag->level_count(), 0);
  for (uint32_t n = 0; n < dag->node_count(); ++n) ++per_level[dag->node(n).level];
  for (uint32_t n = 0; n < dag->node_count(); ++n) {
    const lod::dag::Node& node = dag->node(n);
    ASSERT_EQ(node.parent_count, 1u) << "segment " << n;
    const lod::dag::Patch& up = dag->patch(dag->parent_patches(n)[0]);
    EXPECT_EQ(up.tet_begin, 0u);
    EXPECT_EQ(up.tet_count, node.tet_count) << "segment " << n << " goes up whole";
    if (node.level == 1) {
      EXPECT_EQ(node.child_count, 1u) << "level 1 copies one segment";
    } else if (node.level > 1 && per_level[node.level - 1] > 1) {
      EXPECT_GE(node.child_count, 2u) << "a merge of at least two";  // once one segment is left, it is simplified again alone
    }
  }
  for (uint32_t level = 2; level < dag->level_count(); ++level)
    if (per_level[level - 1] > 1) {
      EXPECT_LE(2 * per_level[level], per_level[level - 1] + 1) << "level " << level << " halves the segments";
    }
  EXPECT_EQ(per_level[0], per_level[1]);
}

// Random fronts of the binary store, the 0-segment following each: conforming, closed, the
// volume of the input, and every border face's neighbour as the cut mesh's full rebuild finds it.
void check_front(const lod::CutMesh& m, const lod::ZeroSegment& zero, const lod::Dag& dag, double input_volume, const std::string& what) {
  expect_conforming(m, what);
  // the simplifier moves the domain's boundary a little (the coarsest cut of the sample holds
  // 2.3% less than the input): within 5%
  EXPECT_NEAR(check_mesh(m.mesh).volume, input_volume, 0.05 * input_volume) << what << ": the front's volume";
  std::vector<uint32_t> first(dag.patch_count(), 0xFFFFFFFFu);
  for (size_t i = 0; i < m.patches.size(); ++i) first[m.patches[i]] = m.patch_first_tet[i];
  size_t borders = 0, mismatches = 0;
  for (uint32_t p : m.patches) {
    ASSERT_TRUE(zero.docked(p)) << what;
    const uint32_t begin = dag.patch(p).tet_begin;
    for (const auto& b : zero.borders(p)) {
      const uint32_t t = b.tet_face / 4, f = b.tet_face % 4;
      const lod::ZeroSegment::Dock d = zero.across(p, t, f);
      const uint32_t here = 4 * (first[p] + t - begin) + f;
      const uint32_t expected = d.empty() ? storage::store::kMeshBoundary : 4 * (first[d.patch] + d.tet - dag.patch(d.patch).tet_begin) + d.face;
      ++borders;
      mismatches += m.opposites[here] != expected;
    }
  }
  if (m.patches.size() > 1) {
    EXPECT_GT(borders, 0u) << what;
  }
  EXPECT_EQ(mismatches, 0u) << what << ": the 0-segment's neighbours differ from the rebuilt adjacency";
}

TEST(ZeroSegment, RandomFrontsAreConformingAndTheZeroSegmentMatchesARebuild) {
  // the binary hierarchy without and with dependencies, and the multi-triangulation (ratio -1)
  for (double ratio : {1.0, 0.0, -1.0}) {
    const Built& b = ratio < 0 ? built("sample") : built_binary("sample", ratio);
    auto store = storage::Store::open(b.store);
    auto dag = lod::open_dag(*store);
    storage::SegmentCache cache(*store, 1ull << 28);
    lod::ZeroSegment zero(cache, *dag);
    EXPECT_GT(zero.triangle_count(), 0u);
    const double input_volume = check_mesh(storage::load_mesh(sample_mesh())).volume;
    lod::Cut cut(*dag);
    zero.follow(cut);
    std::mt19937 rng(20261150);
    for (int round = 0; round < 8; ++round) {
      for (int step = 0; step < 10; ++step) {
        const uint32_t node = rng() % dag->node_count();
        if (rng() % 3 == 0) cut.coarsen(node);
        else cut.refine(node);
      }
      zero.follow(cut);
      const std::string what = "R " + std::to_string(ratio) + " round " + std::to_string(round);
      check_front(lod::assemble_cut(*store, cache, cut), zero, *dag, input_volume, what);
    }
    // the swaps of cut updates, as a viewer makes them, from the coarsest front
    lod::Cut viewer(*dag);
    zero.clear();
    zero.follow(viewer);
    auto criteria = lod::criteria_for(*store, *dag, [] {
      view::TransferFunction tf;
      tf.attribute = "Temp";
      return tf;
    }());
    for (uint64_t budget : {uint64_t{9000}, uint64_t{30000}, uint64_t{14000}, uint64_t{45000}}) {
      const lod::CutChanges changes = viewer.update(criteria, budget);
      zero.swap(changes.removed, changes.added);
      check_front(lod::assemble_cut(*store, cache, viewer), zero, *dag, input_volume, "budget " + std::to_string(budget));
    }
    if (ratio == 0.0) {
      EXPECT_GT(b.report.dependencies, 0u) << "with R >= 0 every matched pair of new segments simplifies its boundary";
    }
  }
}

TEST(ZeroSegment, OverSharedFaceIsRefused) {
  const Built& b = built_binary("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  storage::SegmentCache cache(*store, 1ull << 28);
  lod::ZeroSegment zero(cache, *dag);
  lod::Cut cut(*dag);
  cut.refine_all();
  zero.follow(cut);  // the input's segments
  // the copy of segment 0 (level 1) has segment 0's locked border: docking it beside its
  // neighbours puts a third patch on their shared triangles
  uint32_t copy_patch = 0xFFFFFFFFu;
  for (uint32_t p = 0; p < dag->patch_count(); ++p)
    if (dag->patch(p).ceiling != lod::dag::kRoot && dag->node(dag->patch(p).ceiling).level == 2 && dag->node(dag->patch(p).floor).level == 1) {
      const lod::dag::Node& copy = dag->node(dag->patch(p).floor);
      if (dag->child_patches(dag->patch(p).floor)[0].floor == 0 && copy.level == 1) copy_patch = p;
    }
  ASSERT_NE(copy_patch, 0xFFFFFFFFu);
  EXPECT_THROW(zero.dock(copy_patch), lod::ZeroSegmentError);
  EXPECT_FALSE(zero.docked(copy_patch));
  // nothing changed: the front's adjacency is still the rebuild's
  check_front(lod::assemble_cut(*store, cache, cut), zero, *dag, check_mesh(storage::load_mesh(sample_mesh())).volume, "after the refused dock");
}

// Under --memory-mb the levels' tets go to a spill file (read a segment at a time, the
// adjacency graph too): the store is the same bytes as the build in memory.
TEST(BinaryHierarchy, SpilledBuildWritesTheSameStore) {
  std::vector<std::string> bytes;
  for (uint64_t memory_mb : {uint64_t{0}, uint64_t{1}}) {
    const std::filesystem::path store = run_scratch_dir("binary-spill-" + std::to_string(memory_mb)) / "store";
    lod::PreprocessOptions options;
    options.model = lod::MultiresModel::kBinary;
    options.segment_tets = 2000;
    options.base_tets = 3000;
    options.memory_mb = memory_mb;
    options.vertex_hierarchy_max_tets = 0;
    options.replace = true;
    const lod::PreprocessReport report = lod::preprocess(sample_mesh(), store, options);
    if (memory_mb) {
      EXPECT_GT(report.spilled_bytes, 0u) << "a 1 MB budget spills the levels";
    }
    std::string both;
    for (const char* file : {"segments.bin", "dag.bin"}) {
      std::ifstream in(store / file, std::ios::binary);
      both += std::string(std::istreambuf_iterator<char>(in), {});
    }
    bytes.push_back(both);
  }
  ASSERT_FALSE(bytes[0].empty());
  EXPECT_TRUE(bytes[0] == bytes[1]) << "the spilled build wrote other bytes";
}

TEST(BinaryHierarchy, DamagedHierarchyFileIsRefused) {
  const Built& b = built_binary("sample");
  const std::filesystem::path copy = run_scratch_dir("binary-damaged") / "store";
  std::filesystem::remove_all(copy);
  std::filesystem::copy(b.store, copy, std::filesystem::copy_options::recursive);
  {
    std::fstream f(copy / "dag.bin", std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(200);
    char c = 0;
    f.read(&c, 1);
    c = static_cast<char>(c ^ 0x5A);
    f.seekp(200);
    f.write(&c, 1);
  }
  const std::vector<std::string> problems = lod::check_store(copy);
  ASSERT_FALSE(problems.empty());
  auto store = storage::Store::open(copy);
  EXPECT_THROW(lod::open_dag(*store), lod::DagError);
}

}  // namespace
}  // namespace tetrascope::testing
