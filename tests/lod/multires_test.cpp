// The multi-triangulation: preprocess builds a store that verifies; the finest cut is the
// input; the coarsest fits the base budget; random cuts are conforming and fill exactly the
// volume their own boundary encloses; budgets hold; the error histograms are monotone and
// bound the measured error; damaged DAGs are refused.
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
#include "test_paths.h"
#include "tetrascope/lod/cut.h"
#include "tetrascope/lod/multires.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store_verify.h"

namespace tetrascope::testing {
namespace {

struct Built {
  std::filesystem::path store;
  lod::PreprocessReport report;
};

// One store per dataset for the whole test program.
const Built& built(const std::string& name) {
  static std::map<std::string, Built> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  const std::filesystem::path mesh = name == "sample" ? sample_mesh() : shared_data() / name;
  Built b;
  b.store = scratch_dir("multires-" + std::filesystem::path(name).stem().string()) / "store";
  lod::PreprocessOptions options;
  options.segment_tets = 2000;
  options.base_tets = 3000;
  options.replace = true;
  b.report = lod::preprocess(mesh, b.store, options);
  return cache[name] = b;
}

using Tet = std::array<uint32_t, 4>;

std::multiset<Tet> tets_by_global_id(const lod::CutMesh& m) {
  std::multiset<Tet> out;
  for (size_t t = 0; t < m.mesh.tet_count(); ++t) {
    Tet tet;
    for (int k = 0; k < 4; ++k) tet[k] = m.global_ids[m.mesh.tets[4 * t + k]];
    std::sort(tet.begin(), tet.end());
    out.insert(tet);
  }
  return out;
}

// Conformity of an assembled cut: every face used once (boundary) or twice, the boundary
// closed (each boundary edge in exactly two boundary triangles), no inverted tet, and the
// summed tet volume equal to the volume the boundary encloses (overlaps or gaps break it).
void expect_conforming(const lod::CutMesh& m, const std::string& what) {
  const MeshCheck c = check_mesh(m.mesh);
  EXPECT_EQ(c.faces_shared_by_more_than_two, 0u) << what;
  size_t inverted = 0;
  for (size_t t = 0; t < m.mesh.tet_count(); ++t) {
    const uint32_t* v = &m.mesh.tets[4 * t];
    inverted += storage::signed_volume(m.mesh, v[0], v[1], v[2], v[3]) < 0;
  }
  EXPECT_EQ(inverted, 0u) << what;
  // boundary triangles, outward (face f of a positive tet, vertices in kTetFace order)
  const int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<uint32_t, 2>, int> edge_uses;
  double enclosed = 0;
  size_t boundary_faces = 0;
  for (size_t t = 0; t < m.mesh.tet_count(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<uint32_t, 3> tri{m.mesh.tets[4 * t + kFace[f][0]], m.mesh.tets[4 * t + kFace[f][1]], m.mesh.tets[4 * t + kFace[f][2]]}, key = tri;
      std::sort(key.begin(), key.end());
      if (c.face_uses.at(key) != 1) continue;
      ++boundary_faces;
      double p[3][3];
      for (int i = 0; i < 3; ++i) {
        p[i][0] = m.mesh.x[tri[i]];
        p[i][1] = m.mesh.y[tri[i]];
        p[i][2] = m.mesh.z[tri[i]];
      }
      enclosed += (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                   p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) / 6;
      for (int i = 0; i < 3; ++i) ++edge_uses[{std::min(key[i], key[(i + 1) % 3]), std::max(key[i], key[(i + 1) % 3])}];
    }
  EXPECT_GT(boundary_faces, 0u) << what;
  size_t open_edges = 0;
  for (const auto& [edge, uses] : edge_uses) open_edges += uses != 2;
  EXPECT_EQ(open_edges, 0u) << what << ": the boundary is not a closed surface";
  EXPECT_NEAR(c.volume, enclosed, 1e-6 * std::fabs(enclosed)) << what << ": tets overlap or leave gaps";
  // the cut's own adjacency agrees
  size_t unpaired = 0;
  for (uint32_t o : m.opposites) unpaired += o == storage::store::kMeshBoundary;
  EXPECT_EQ(unpaired, boundary_faces) << what << ": cross-patch adjacency misses faces";
}

TEST(Multires, PreprocessBuildsLevelsThatVerify) {
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

TEST(Multires, FinestCutIsTheInputAndCoarsestFitsTheBase) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  storage::SegmentCache cache(*store, 1ull << 28);
  lod::Cut cut(*dag);
  auto coarse = lod::assemble_cut(*store, cache, cut);
  EXPECT_EQ(coarse.mesh.tet_count(), b.report.levels.back().tets);
  expect_conforming(coarse, "coarsest cut");
  cut.refine_all();
  auto fine = lod::assemble_cut(*store, cache, cut);
  storage::TetMesh input = storage::load_mesh(sample_mesh());
  ASSERT_EQ(fine.mesh.tet_count(), input.tet_count());
  std::multiset<Tet> expected;
  for (size_t t = 0; t < input.tet_count(); ++t) {
    Tet tet{input.tets[4 * t], input.tets[4 * t + 1], input.tets[4 * t + 2], input.tets[4 * t + 3]};
    std::sort(tet.begin(), tet.end());
    expected.insert(tet);
  }
  EXPECT_TRUE(tets_by_global_id(fine) == expected) << "the finest cut is not the input mesh";
  expect_conforming(fine, "finest cut");
  EXPECT_NEAR(check_mesh(fine.mesh).volume, check_mesh(input).volume, 1e-9 * check_mesh(input).volume);
}

TEST(Multires, RandomCutsAreConforming) {
  // (nasa_combustion_chamber is left out: its input's tets already fill 0.14% less than its
  // boundary encloses - the curvilinear hexes' 5-tet split overlaps itself)
  for (const char* name : {"sample", "fea_bracket.vtk", "freefem_leman.vtk"}) {
    if (std::string(name) != "sample" && shared_data().empty()) continue;
    const Built& b = built(name);
    auto store = storage::Store::open(b.store);
    auto dag = lod::open_dag(*store);
    storage::SegmentCache cache(*store, 1ull << 28);
    lod::Cut cut(*dag);
    std::mt19937 rng(7);
    for (int round = 0; round < 6; ++round) {
      for (int step = 0; step < 12; ++step) {
        const uint32_t node = rng() % dag->node_count();
        if (rng() % 3 == 0) cut.coarsen(node);
        else cut.refine(node);
      }
      auto m = lod::assemble_cut(*store, cache, cut);
      EXPECT_EQ(m.mesh.tet_count(), cut.tet_count()) << name;
      expect_conforming(m, std::string(name) + " round " + std::to_string(round));
    }
  }
}

TEST(Multires, UpdateHonoursTheBudgetAndReportsWhatChanged) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  lod::Cut cut(*dag);
  const uint64_t coarsest = cut.tet_count();
  std::set<uint32_t> active;
  for (uint32_t p : cut.active_patches()) active.insert(p);
  lod::TransferFunction tf;
  tf.attribute = "Temp";
  auto criteria = lod::criteria_for(*store, *dag, tf);
  for (uint64_t budget : {coarsest + 2000, uint64_t{20000}, uint64_t{8000}, uint64_t{45000}, uint64_t{1000}}) {
    auto changes = cut.update(criteria, budget);
    EXPECT_EQ(changes.tets, cut.tet_count());
    if (budget >= coarsest) {
      EXPECT_LE(cut.tet_count(), budget) << "budget " << budget;
    } else {
      EXPECT_EQ(cut.tet_count(), coarsest) << "below the coarsest cut everything coarsens";
    }
    for (uint32_t p : changes.removed) EXPECT_EQ(active.erase(p), 1u);
    for (uint32_t p : changes.added) EXPECT_TRUE(active.insert(p).second);
    std::vector<uint32_t> now = cut.active_patches();
    EXPECT_EQ(std::vector<uint32_t>(active.begin(), active.end()), now) << "changes do not add up to the new cut";
  }
  // a generous budget refines (the errors are not all zero); the segments it needs stay mapped
  cut.update(criteria, 45000);
  EXPECT_GT(cut.tet_count(), coarsest);
  storage::SegmentCache cache(*store, 1);  // a tiny budget: only pinned segments stay mapped
  lod::ResidentSegments resident;
  EXPECT_GT(resident.update(cut, cache), 0u);
  for (uint32_t p : cut.active_patches()) EXPECT_TRUE(resident.holds(dag->patch(p).floor));
  EXPECT_TRUE(cut.update(criteria, 1).over_budget) << "below the coarsest cut the budget cannot hold, and that is reported";
  resident.update(cut, cache);
  for (uint32_t p : cut.active_patches()) EXPECT_TRUE(resident.holds(dag->patch(p).floor));
  EXPECT_LT(resident.size(), dag->node_count());
  // nothing in view: nothing refines
  lod::CutCriteria away = criteria;
  lod::Camera camera = lod::parse_camera("azimuth=0,elevation=0", store->manifest().bounds);
  for (int k = 0; k < 3; ++k) camera.target[k] = 2 * camera.eye[k] - camera.target[k];  // look away from the mesh
  away.frustum = lod::view_frustum(camera, 0, 1e9);
  cut.update(away, 45000);
  EXPECT_EQ(cut.tet_count(), coarsest);
}

TEST(Multires, AnUpdateFromAnyCutReachesWhatAFreshCutReaches) {
  // A viewer's cut goes through many criteria (volume, then an isosurface); the cut a new
  // criterion settles on must not depend on where the cut was before.
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  lod::TransferFunction tf;
  tf.attribute = "Temp";
  auto volume = lod::criteria_for(*store, *dag, tf);
  auto iso = volume;
  iso.isovalues = {0.5};  // exactly on a bin edge, where no vertex value lies
  const lod::Camera camera = lod::parse_camera("azimuth=30,elevation=20", store->manifest().bounds);
  for (auto* c : {&volume, &iso}) c->frustum = lod::view_frustum(camera, 0, 1e30);
  lod::Cut fresh(*dag);
  fresh.update(iso, 500000);
  lod::Cut refined(*dag);
  refined.update(volume, 500000);
  EXPECT_EQ(refined.tet_count(), b.report.levels.front().tets);
  refined.update(iso, 500000);
  EXPECT_GT(fresh.tet_count(), lod::Cut(*dag).tet_count()) << "the isosurface's segments refine";
  EXPECT_EQ(refined.active_patches(), fresh.active_patches());
}

TEST(Multires, HistogramsAreMonotoneAndBoundTheMeasuredError) {
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
  EXPECT_GT(checked, 1000u);
  EXPECT_GT(nonzero, 100u) << "simplification changed nothing?";
  auto problems = lod::verify_dag(*store, *dag);
  EXPECT_TRUE(problems.empty()) << (problems.empty() ? "" : problems[0]);
}

TEST(Multires, EverySharedDatasetPreprocessesAndVerifies) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to this checkout";
  std::vector<std::filesystem::path> meshes;
  for (const auto& entry : std::filesystem::directory_iterator(shared_data()))
    if (entry.path().extension() == ".vtk") meshes.push_back(entry.path());
  for (const char* f : {"formats/freefem_leman_published.vtu", "formats/onera_m6_coarse.msh", "formats/disk_out_ref.node", "formats/nasa_bluntfin.off"})
    meshes.push_back(shared_data() / f);
  std::sort(meshes.begin(), meshes.end());
  ASSERT_GE(meshes.size(), 11u);
#if defined(__SANITIZE_ADDRESS__)
  constexpr bool kSanitized = true;
#elif defined(__has_feature)
  constexpr bool kSanitized = __has_feature(address_sanitizer);
#else
  constexpr bool kSanitized = false;
#endif
  if (kSanitized) {  // under ASan the larger sets take over ten minutes; the release run covers them
    std::erase_if(meshes, [](const std::filesystem::path& m) { return std::filesystem::file_size(m) > 2000000; });
    std::printf("sanitizer build: the %zu shared meshes under 2 MB only\n", meshes.size());
  }
  const auto dir = scratch_dir("multires-shared");
  for (const auto& mesh : meshes) {
    lod::PreprocessOptions options;
    options.segment_tets = 8000;
    options.base_tets = 20000;
    auto report = lod::preprocess(mesh, dir / mesh.filename(), options);
    if (report.input_tets > 2 * options.base_tets) {
      EXPECT_GE(report.levels.size(), 2u) << mesh;
    }
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

TEST(Multires, DamagedDagIsRefused) {
  const Built& b = built("sample");
  const auto copy = scratch_dir("multires-damaged") / "store";
  std::filesystem::remove_all(copy);
  std::filesystem::copy(b.store, copy, std::filesystem::copy_options::recursive);
  auto store = storage::Store::open(copy);
  std::vector<uint32_t> tets(store->segment_count());
  for (uint32_t s = 0; s < tets.size(); ++s) tets[s] = store->record(s).tet_count;
  const auto file = copy / "dag.bin";
  const auto size = std::filesystem::file_size(file);
  for (uint64_t at : {uint64_t{20}, uint64_t{200}, size / 2, size - 3}) {
    std::filesystem::copy_file(b.store / "dag.bin", file, std::filesystem::copy_options::overwrite_existing);
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(at));
    char byte = 0;
    f.seekg(static_cast<std::streamoff>(at));
    f.read(&byte, 1);
    byte = static_cast<char>(byte ^ 0x5A);
    f.seekp(static_cast<std::streamoff>(at));
    f.write(&byte, 1);
    f.close();
    EXPECT_THROW(lod::Dag::open(file, tets), lod::DagError) << "flipped byte " << at;
  }
  std::filesystem::copy_file(b.store / "dag.bin", file, std::filesystem::copy_options::overwrite_existing);
  std::filesystem::resize_file(file, size - 100);
  EXPECT_THROW(lod::Dag::open(file, tets), lod::DagError);
  tets[0] += 1;  // a dag that does not match its segments
  std::filesystem::copy_file(b.store / "dag.bin", file, std::filesystem::copy_options::overwrite_existing);
  EXPECT_THROW(lod::Dag::open(file, tets), lod::DagError);
}

}  // namespace
}  // namespace tetrascope::testing
