// The multi-triangulation build (lod/mt_build.h): preprocess builds levels that verify; level
// 0 is partitioned as `tetrascope segment` partitions; the error histograms are monotone and
// bound the measured error; every shared dataset preprocesses into a store that verifies.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include "mesh_checks.h"
#include "mt_fixture.h"
#include "test_paths.h"
#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/lod/mt/segmentation.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store_verify.h"

namespace tetrascope::testing {
namespace {

TEST(MtBuild, PreprocessBuildsLevelsThatVerify) {
  const Built& b = built("sample");
  ASSERT_GE(b.report.levels.size(), 3u) << "a 45K-tet mesh with 2000-tet segments and a 3000-tet base has several levels";
  for (size_t i = 1; i < b.report.levels.size(); ++i) EXPECT_LT(b.report.levels[i].tets, b.report.levels[i - 1].tets);
  EXPECT_TRUE(b.report.levels.back().tets <= 3000 || b.report.levels.back().segments == 1);
  auto v = storage::verify_store(b.store);
  EXPECT_TRUE(v.ok) << (v.problems.empty() ? "" : v.problems[0]);
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  ASSERT_TRUE(dag);
  auto problems = lod::verify_dag(*store, *dag);
  EXPECT_TRUE(problems.empty()) << (problems.empty() ? "" : problems[0]);
  EXPECT_EQ(dag->level_count(), b.report.levels.size());
}

TEST(MtBuild, HistogramsAreMonotoneAndBoundTheMeasuredError) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  const auto& attributes = store->manifest().attributes;
  storage::TetMesh input = storage::load_mesh(sample_mesh());
  size_t checked = 0, nonzero = 0;
  for (uint32_t n = 0; n < dag->node_count(); ++n) {
    if (dag->node(n).level != 1) continue;
    auto segment = store->map_segment(n);
    const auto& s = segment->view();
    // original vertices of its child patches (the level-0 tets it replaces)
    std::set<uint32_t> originals;
    for (const auto& p : dag->child_patches(n)) {
      auto floor = store->map_segment(p.floor);
      const auto& f = floor->view();
      for (uint32_t t = p.tet_begin; t < p.tet_begin + p.tet_count; ++t)
        for (int k = 0; k < 4; ++k) originals.insert(f.global_ids[f.tets[4 * size_t{t} + k]]);
    }
    for (uint32_t c = 0; c < attributes.size(); ++c) {
      if (attributes[c].components != 1) continue;
      const double lo = attributes[c].min, span = attributes[c].max - attributes[c].min;
      const auto h = dag->field_histogram(n, c);
      size_t offset = 0;
      for (uint32_t a = 0; a < c; ++a) offset += attributes[a].components;
      for (uint32_t v : originals) {
        // a third of them under a sanitizer: the search below is the test's own arithmetic, a
        // minute of ASan time that finds nothing the release run does not
        if (kSanitized && v % 3 != 0) continue;
        // brute force: the tet of this segment that strictly holds the vertex
        for (uint32_t t = 0; t < s.tet_count; ++t) {
          double P[4][3];
          for (int k = 0; k < 4; ++k) {
            const uint32_t l = s.tets[4 * size_t{t} + k];
            P[k][0] = s.x[l];
            P[k][1] = s.y[l];
            P[k][2] = s.z[l];
          }
          auto det = [](const double* a, const double* b2, const double* c2, const double* d) {
            double u[3], w[3], x[3];
            for (int i = 0; i < 3; ++i) {
              u[i] = b2[i] - a[i];
              w[i] = c2[i] - a[i];
              x[i] = d[i] - a[i];
            }
            return u[0] * (w[1] * x[2] - w[2] * x[1]) - u[1] * (w[0] * x[2] - w[2] * x[0]) + u[2] * (w[0] * x[1] - w[1] * x[0]);
          };
          const double q[3] = {input.x[v], input.y[v], input.z[v]};
          const double total = det(P[0], P[1], P[2], P[3]);
          if (!(total > 0)) continue;
          double w[4] = {det(q, P[1], P[2], P[3]) / total, det(P[0], q, P[2], P[3]) / total, det(P[0], P[1], q, P[3]) / total, det(P[0], P[1], P[2], q) / total};
          if (std::min({w[0], w[1], w[2], w[3]}) < 1e-6) continue;
          double approx = 0;
          for (int k = 0; k < 4; ++k) approx += w[k] * s.attributes[size_t{s.vertex_count} * offset + s.tets[4 * size_t{t} + k]];
          const double original = input.attributes[c].values[v];
          const double err = std::fabs((approx - original) / span);
          const uint32_t bin = std::min<uint32_t>(dag->bins() - 1, static_cast<uint32_t>(std::clamp((original - lo) / span, 0.0, 1.0) * dag->bins()));
          EXPECT_LE(err, h[bin] + 1e-5) << "segment " << n << " vertex " << v;
          ++checked;
          nonzero += err > 1e-6;
          break;
        }
      }
    }
  }
  EXPECT_GT(checked, kSanitized ? 300u : 1000u);
  EXPECT_GT(nonzero, kSanitized ? 30u : 100u) << "simplification changed nothing?";
  auto problems = lod::verify_dag(*store, *dag);
  EXPECT_TRUE(problems.empty()) << (problems.empty() ? "" : problems[0]);
}

TEST(MtBuild, EverySharedDatasetPreprocessesAndVerifies) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to this checkout";
  std::vector<std::filesystem::path> meshes;
  for (const auto& entry : std::filesystem::directory_iterator(shared_data()))
    if (entry.path().extension() == ".vtk") meshes.push_back(entry.path());
  for (const char* f : {"formats/freefem_leman_published.vtu", "formats/onera_m6_coarse.msh", "formats/disk_out_ref.node", "formats/nasa_bluntfin.off"})
    meshes.push_back(shared_data() / f);
  std::sort(meshes.begin(), meshes.end());
  ASSERT_GE(meshes.size(), 11u);
  if (kSanitized) {  // under ASan the larger sets take over ten minutes; the release run covers them
    std::erase_if(meshes, [](const std::filesystem::path& m) { return std::filesystem::file_size(m) > 2000000; });
    std::printf("sanitizer build: the %zu shared meshes under 2 MB only\n", meshes.size());
  }
  const auto dir = scratch_dir("multires-shared");
  for (const auto& mesh : meshes) {
    lod::PreprocessOptions options;
    options.segment_tets = 8000;  // the default base: the coarsest level must meet it
    auto report = lod::preprocess(mesh, dir / mesh.filename(), options);
    if (report.input_tets > 2 * options.base_tets) {
      EXPECT_GE(report.levels.size(), 2u) << mesh;
    }
    EXPECT_LE(report.levels.back().tets, options.base_tets) << mesh << ": the coarsest level is above the default base";
    auto verified = storage::verify_store(dir / mesh.filename());
    EXPECT_TRUE(verified.ok) << mesh << ": " << (verified.problems.empty() ? "" : verified.problems[0]);
    auto store = storage::Store::open(dir / mesh.filename());
    auto dag = lod::open_dag(*store);
    ASSERT_TRUE(dag) << mesh;
    auto problems = lod::verify_dag(*store, *dag);
    EXPECT_TRUE(problems.empty()) << mesh << ": " << (problems.empty() ? "" : problems[0]);
    std::filesystem::remove_all(dir / mesh.filename());
  }
}

// Threat: TetGen 1.5 (Debian's build keeps its assertions) aborts the process on some of
// ONERA's sampled segments (recoveredgebyflips). `preprocess --simplifier sample` took the
// whole command down with it. TetGen now runs in a child process: the crash is reported, the
// segment is simplified by quadric collapses, and the store is whole. (Should a later TetGen
// stop crashing here, this test needs another reproducer, not a weaker check.)
TEST(MtBuild, ATetgenCrashOnASampledSegmentFallsBackToQuadricCollapses) {
  if (kSanitized) GTEST_SKIP() << "ONERA's sampled build takes minutes under ASan; the release run covers it";
  if (shared_data().empty()) GTEST_SKIP() << "needs ../shared/data/onera_m6_potential.vtk (../shared/data is not beside this checkout)";
  const auto mesh = shared_data() / "onera_m6_potential.vtk";
  const auto dir = scratch_dir("tetgen-crash");
  lod::PreprocessOptions options;
  options.segment_tets = 16384;  // the segments it crashed on (auto would pick 8192 on ONERA)
  options.simplifier = lod::SimplifyMethod::kSample;
  const auto report = lod::preprocess(mesh, dir / "onera", options);
  EXPECT_GE(report.tetgen_fallbacks, 1u) << "TetGen did not fail on any of ONERA's sampled segments";
  EXPECT_GE(report.levels.size(), 3u);
  EXPECT_EQ(report.to_json().at("tetgen_fallbacks").get<uint32_t>(), report.tetgen_fallbacks);
  const auto verified = storage::verify_store(dir / "onera");
  EXPECT_TRUE(verified.ok) << (verified.problems.empty() ? "" : verified.problems[0]);
  auto store = storage::Store::open(dir / "onera");
  auto dag = lod::open_dag(*store);
  ASSERT_TRUE(dag);
  const auto problems = lod::verify_dag(*store, *dag);
  EXPECT_TRUE(problems.empty()) << (problems.empty() ? "" : problems[0]);
  std::filesystem::remove_all(dir);
}

// A level of one segment is no reason to stop: with segments as large as the whole mesh
// every level is one segment, and the build still simplifies down to the base.
TEST(MtBuild, OneSegmentLevelsKeepSimplifyingToTheBase) {
  lod::PreprocessOptions options;
  options.segment_tets = 1000000;
  options.min_segments = 1;
  options.base_tets = 3000;
  options.replace = true;
  const auto store = scratch_dir("mt-one-segment") / "store";
  auto report = lod::preprocess(sample_mesh(), store, options);
  ASSERT_GT(report.input_tets, 4 * options.base_tets);
  ASSERT_GE(report.levels.size(), 2u);
  for (const auto& level : report.levels) EXPECT_EQ(level.segments, 1u);
  EXPECT_LE(report.levels.back().tets, options.base_tets);
  auto verified = storage::verify_store(store);
  EXPECT_TRUE(verified.ok) << (verified.problems.empty() ? "" : verified.problems[0]);
  auto opened = storage::Store::open(store);
  auto dag = lod::open_dag(*opened);
  ASSERT_TRUE(dag);
  auto problems = lod::verify_dag(*opened, *dag);
  EXPECT_TRUE(problems.empty()) << (problems.empty() ? "" : problems[0]);
}

// The level-0 segments are those `tetrascope segment` makes with the same segment size: one
// partition step (partition_segments) serves both.
TEST(MtBuild, LevelZeroIsPartitionedAsSegmentDoes) {
  const Built& b = built("sample");
  const auto segmented = scratch_dir("mt-build-segment") / "store";
  lod::SegmentationOptions options;
  options.segment_tets = 2000;  // as built() preprocesses
  options.replace = true;
  lod::segment_mesh(sample_mesh(), segmented, options);
  auto mt = storage::Store::open(b.store);
  auto plain = storage::Store::open(segmented);
  ASSERT_EQ(b.report.levels.at(0).segments, plain->segment_count());
  auto tets_of = [](const storage::Store& store, uint32_t s) {
    auto mapped = store.map_segment(s);
    const auto& v = mapped->view();
    std::multiset<Tet> out;
    for (size_t t = 0; t < v.tets.size() / 4; ++t) {
      Tet tet;
      for (int k = 0; k < 4; ++k) tet[k] = v.global_ids[v.tets[4 * t + k]];
      std::sort(tet.begin(), tet.end());
      out.insert(tet);
    }
    return out;
  };
  for (uint32_t s = 0; s < plain->segment_count(); ++s) EXPECT_EQ(tets_of(*mt, s), tets_of(*plain, s)) << "segment " << s;
}

// With a tiny --memory-mb the input and every level but the coarsest live in spill
// files, read a chunk or a segment at a time; the store is the same, byte for byte, as the one
// built wholly in memory, and no spill file is left beside it. Lake Leman (136,838 tets) is
// read in several chunks.
TEST(MtBuild, ATinyMemoryBudgetBuildsTheSameStoreAsTheInMemoryBuild) {
  if (shared_data().empty()) GTEST_SKIP() << "needs ../shared/data/freefem_leman.vtk (../shared/data is not beside this checkout)";
  const auto dir = scratch_dir("mt-build-spill");
  lod::PreprocessOptions options;
  options.segment_tets = 4000;
  options.base_tets = 3000;
  options.replace = true;
  options.memory_mb = 0;  // nothing spilled
  options.vertex_hierarchy_max_tets = 0;  // built whole in memory or not at all: not what spilling changes
  const auto in_memory = lod::preprocess(shared_data() / "freefem_leman.vtk", dir / "memory", options);
  EXPECT_EQ(in_memory.spilled_bytes, 0u);
  options.memory_mb = 1;  // a level of more than 16,384 tets is spilled
  const auto spilled = lod::preprocess(shared_data() / "freefem_leman.vtk", dir / "spilled", options);
  ASSERT_GE(spilled.levels.size(), 3u);
  EXPECT_GT(spilled.levels[1].tets, 16384u) << "level 1 should spill too";
  EXPECT_GE(spilled.spilled_bytes, 16 * spilled.input_tets) << "the input's tets are spilled";
  auto bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  for (const char* file : {"segments.bin", "dag.bin", "manifest.json"}) {
    const std::string a = bytes(dir / "memory" / file), b = bytes(dir / "spilled" / file);
    EXPECT_FALSE(a.empty()) << file;
    EXPECT_TRUE(a == b) << file << " differs between the in-memory and the spilled build";
  }
  const auto v = storage::verify_store(dir / "spilled");
  EXPECT_TRUE(v.ok) << (v.problems.empty() ? "" : v.problems[0]);
  std::vector<std::string> left;
  for (const auto& e : std::filesystem::directory_iterator(dir)) left.push_back(e.path().filename().string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"memory", "spilled"})) << "nothing but the two stores, no spill file";
}

}  // namespace
}  // namespace tetrascope::testing
