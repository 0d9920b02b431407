// Variants of a segment that keep its border (variants.h): the store's variants
// verify, a cut spends on them what its budget has left and stays conforming, that never makes
// the picture worse (exact integrator), and a damaged variants.bin is refused with a message.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <algorithm>

#include "mt_fixture.h"
#include "test_paths.h"
#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/mt/store_check.h"
#include "tetrascope/lod/cut/variants.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::testing {
namespace {

constexpr uint32_t kVariants = 3;

view::TransferFunction stress_tf() {
  view::TransferFunction tf;
  tf.attribute = "von_mises_stress_psi";
  tf.opacity = {{0, 0}, {4, 0}, {21, 0.6}};
  return tf;
}

// A built store opened as a viewer opens it: segments, DAG and variants (null when none).
struct Opened {
  std::unique_ptr<storage::Store> store;
  std::unique_ptr<lod::Dag> dag;
  std::unique_ptr<lod::Variants> variants;
};
Opened open_with_variants(const Built& b) {
  Opened o;
  o.store = storage::Store::open(b.store);
  o.dag = lod::open_dag(*o.store);
  o.variants = lod::Variants::open(*o.store, *o.dag);
  return o;
}

TEST(Variants, EverySimplifiedSegmentGetsVariantsBetweenItAndItsRegionAndTheyVerify) {
  if (shared_data().empty()) GTEST_SKIP() << "no shared data (../shared/data)";
  const Built& b = built("fea_bracket.vtk", kVariants);
  EXPECT_GT(b.report.variant_tets, 0u);
  EXPECT_GT(b.report.variants_bytes, 0u);
  EXPECT_EQ(lod::check_store(b.store), std::vector<std::string>{}) << "verify's checks, the variants' border faces among them";
  const Opened o = open_with_variants(b);
  const auto& dag = o.dag;
  const auto& variants = o.variants;
  ASSERT_TRUE(variants);
  uint32_t with = 0, simplified = 0;
  for (uint32_t v = 0; v < dag->node_count(); ++v) {
    const lod::dag::Node& node = dag->node(v);
    if (node.level == 0) {
      EXPECT_EQ(variants->count(v), 0u) << "level 0 is the input: segment " << v;
      continue;
    }
    ++simplified;
    if (variants->count(v) == 0) continue;
    ++with;
    EXPECT_LE(variants->count(v), kVariants);
    // more tets than the segment, fewer than the region it was simplified from
    uint64_t region = 0;
    for (const auto& p : dag->child_patches(v)) region += p.tet_count;
    uint64_t last = node.tet_count;
    for (uint32_t j = 0; j < variants->count(v); ++j) {
      EXPECT_GT(variants->tets(v, j), last) << "segment " << v << " variant " << j;
      EXPECT_LT(variants->tets(v, j), region) << "segment " << v << " variant " << j;
      last = variants->tets(v, j);
      EXPECT_EQ(variants->view(v, j).tets.size(), 4 * variants->tets(v, j));
    }
  }
  EXPECT_GE(with * 10, simplified * 8) << with << " of " << simplified << " simplified segments have variants";
}

// The budget a refinement cannot use goes to variants: never past the budget, never fewer
// tets than the cut without them, the assembled mesh conforming and as large as the cut says.
TEST(Variants, ACutSpendsWhatItsBudgetLeavesOnVariantsAndStaysConforming) {
  if (shared_data().empty()) GTEST_SKIP() << "no shared data (../shared/data)";
  const Built& b = built("fea_bracket.vtk", kVariants);
  const Opened o = open_with_variants(b);
  const auto& store = o.store;  // (not a structured binding: lambdas below capture it)
  const auto& dag = o.dag;
  const auto& variants = o.variants;
  ASSERT_TRUE(variants);
  storage::SegmentCache cache(*store, 1ull << 28);
  const uint64_t input = store->manifest().json["multiresolution"]["input"]["tetrahedra"].get<uint64_t>();
  lod::CutCriteria criteria = lod::criteria_for(*store, *dag, stress_tf(), {});
  lod::set_view(criteria, view::parse_camera("azimuth=30,elevation=20", store->manifest().bounds));
  lod::Cut plain(*dag), filled(*dag);
  filled.attach_variants(variants.get());
  uint32_t used = 0;
  for (double share : {0.1, 0.2, 0.3, 0.45, 0.6, 0.8}) {
    const uint64_t budget = static_cast<uint64_t>(share * double(input));
    const lod::CutChanges without = plain.update(criteria, budget);
    const lod::CutChanges with = filled.update(criteria, budget);
    EXPECT_LE(with.tets, budget) << share;
    EXPECT_GE(with.tets, without.tets) << share;
    EXPECT_EQ(with.tets, filled.tet_count());
    if (filled.variant_extra_tets() > 0) ++used;
    const lod::CutMesh m = lod::assemble_cut(*store, cache, filled);  // with adjacency, which expect_conforming checks too
    EXPECT_EQ(m.mesh.tet_count(), filled.tet_count()) << share;
    expect_conforming(m, "the cut with variants at " + std::to_string(share));
  }
  EXPECT_GE(used, 2u) << "variants filled the budget at so few budgets";
}

// Variants only add tets where the cut could not refine: the picture with them is never worse
// than without, from outside and from inside (exact integrator).
TEST(Variants, FillingTheBudgetWithVariantsNeverLowersThePsnr) {
  if (shared_data().empty()) GTEST_SKIP() << "no shared data (../shared/data)";
  if (kSanitized) GTEST_SKIP() << "about 30 s under a sanitizer: the release run covers it";
  const Built& b = built("fea_bracket.vtk", kVariants);
  const Opened o = open_with_variants(b);
  const auto& store = o.store;  // (not a structured binding: lambdas below capture it)
  const auto& dag = o.dag;
  const auto& variants = o.variants;
  ASSERT_TRUE(variants);
  storage::SegmentCache cache(*store, 1ull << 28);
  const storage::TetMesh input = storage::load_mesh(shared_data() / "fea_bracket.vtk");
  double gained = 0;
  for (const char* camera_text : {"azimuth=30,elevation=20", "eye=0,-1.2,1.6,target=0,2,1.6,up=0,0,1,fov=70"}) {
    renderer::RenderSettings s;
    s.width = 128;
    s.height = 96;
    s.camera = view::parse_camera(camera_text, store->manifest().bounds);
    s.camera.aspect = double(s.width) / s.height;
    s.tf = stress_tf();
    const renderer::Image full = renderer::reference_render(renderer::SceneMesh::from(input, s.tf.attribute), s);
    lod::CutCriteria criteria = lod::criteria_for(*store, *dag, s.tf, {});
    lod::set_view(criteria, s.camera);
    for (double share : {0.25, 0.5}) {
      const uint64_t budget = static_cast<uint64_t>(share * double(input.tet_count()));
      lod::Cut plain(*dag), filled(*dag);
      filled.attach_variants(variants.get());
      plain.update(criteria, budget);
      filled.update(criteria, budget);
      auto db = [&](const lod::Cut& cut) {
        const lod::CutMesh m = lod::assemble_cut(*store, cache, cut, false);
        return renderer::psnr(full, renderer::reference_render(renderer::SceneMesh::from(m.mesh, s.tf.attribute), s));
      };
      const double without = db(plain), with = db(filled);
      std::printf("%s at %.0f%%: %llu tets %.2f dB, with variants %llu tets %.2f dB\n", camera_text, 100 * share, static_cast<unsigned long long>(plain.tet_count()),
                  without, static_cast<unsigned long long>(filled.tet_count()), with);
      EXPECT_GE(with, without - 0.01) << camera_text << " at " << share << ": the variants made the picture worse";
      gained = std::max(gained, with - without);
    }
  }
  EXPECT_GT(gained, 0.5) << "the variants never made a visible difference";
}

// A copy of the store with variants whose variants.bin `damage` changes.
std::filesystem::path damaged_copy(const std::string& name, const std::function<void(std::vector<char>&)>& damage) {
  const Built& b = built("fea_bracket.vtk", kVariants);
  const std::filesystem::path copy = run_scratch_dir("variants-" + name) / "store";
  std::filesystem::remove_all(copy);
  std::filesystem::copy(b.store, copy);
  const std::filesystem::path file = copy / "variants.bin";
  std::ifstream in(file, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  damage(bytes);
  std::ofstream(file, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return copy;
}

// Opening the store's variants fails with a message naming variants.bin and what to do.
void expect_refused(const std::filesystem::path& store_dir, const std::string& what) {
  auto store = storage::Store::open(store_dir);
  auto dag = lod::open_dag(*store);
  try {
    auto variants = lod::Variants::open(*store, *dag);
    ADD_FAILURE() << "a variants.bin with " << what << " was opened";
  } catch (const lod::VariantsError& e) {
    EXPECT_NE(std::string(e.what()).find("variants.bin"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("preprocess"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(lod::check_store(store_dir).empty()) << "verify passed a variants.bin with " << what;
}

TEST(Variants, ATruncatedVariantsFileIsRefused) {
  if (shared_data().empty()) GTEST_SKIP() << "no shared data (../shared/data)";
  expect_refused(damaged_copy("truncated", [](std::vector<char>& b) { b.resize(b.size() / 2); }), "half its bytes");
  expect_refused(damaged_copy("header-only", [](std::vector<char>& b) { b.resize(20); }), "part of a header");
}

TEST(Variants, AVariantsFileWithADamagedIndexIsRefused) {
  if (shared_data().empty()) GTEST_SKIP() << "no shared data (../shared/data)";
  // a byte of the first index entry (after the 56-byte header): the index checksum fails
  expect_refused(damaged_copy("index", [](std::vector<char>& b) { b[56 + 17] ^= 0x40; }), "a damaged index");
}

// An index that checks out (its CRCs recomputed) but claims 2^31 tets for the first variant:
// refused when opened, before anything is allocated for them.
TEST(Variants, AVariantsFileClaimingHugeCountsIsRefusedBeforeAllocating) {
  if (shared_data().empty()) GTEST_SKIP() << "no shared data (../shared/data)";
  expect_refused(damaged_copy("huge", [](std::vector<char>& b) {
                   uint32_t entries = 0;
                   std::memcpy(&entries, &b[20], 4);
                   const uint64_t tets = uint64_t{1} << 31;
                   std::memcpy(&b[56 + 24], &tets, 8);  // entry 0's tets
                   const uint32_t index_crc = storage::crc32_of(&b[56], size_t{entries} * 48);
                   std::memcpy(&b[48], &index_crc, 4);
                   const uint32_t header_crc = storage::crc32_of(b.data(), 52);
                   std::memcpy(&b[52], &header_crc, 4);
                 }),
                 "a variant of 2^31 tets");
}

// The tets' stream of the last variant damaged: the index still checks out, the block does
// not decode; viewing it throws and verify reports it, the cut's other variants still open.
TEST(Variants, AVariantWhoseTetsDoNotDecodeIsReported) {
  if (shared_data().empty()) GTEST_SKIP() << "no shared data (../shared/data)";
  const std::filesystem::path copy = damaged_copy("stream", [](std::vector<char>& b) {
    for (size_t i = b.size() - 64; i < b.size(); ++i) b[i] = static_cast<char>(0xFF);
  });
  const std::vector<std::string> problems = lod::check_store(copy);
  ASSERT_FALSE(problems.empty()) << "verify passed a variant whose tets do not decode";
  EXPECT_NE(problems.front().find("variants.bin"), std::string::npos) << problems.front();
}

// One flipped bit inside a variant's vertex data: the index still checks out and the tets still
// decode, but the block's CRC-32 does not match, so verify reports it and viewing it throws
// (before, verify passed it and `cut` exported the changed value).
TEST(Variants, AFlippedBitInAVariantsDataFailsItsChecksum) {
  if (shared_data().empty()) GTEST_SKIP() << "needs ../shared/data/fea_bracket.vtk (../shared/data is not beside this checkout)";
  const std::filesystem::path copy = damaged_copy("flipped", [](std::vector<char>& b) {
    uint64_t data_offset = 0;
    std::memcpy(&data_offset, &b[32], 8);
    b.at(data_offset + 4 * 3 + 1) ^= 0x01;  // a byte of the first block's fourth global id (a variant has 4 vertices or more)
  });
  const std::vector<std::string> problems = lod::check_store(copy);
  ASSERT_FALSE(problems.empty()) << "verify passed a flipped bit in a variant";
  EXPECT_NE(problems.front().find("checksum"), std::string::npos) << problems.front();
  auto store = storage::Store::open(copy);
  auto dag = lod::open_dag(*store);
  auto variants = lod::Variants::open(*store, *dag);
  ASSERT_TRUE(variants);
  uint32_t node = 0;
  while (node < dag->node_count() && variants->count(node) == 0) ++node;
  ASSERT_LT(node, dag->node_count());
  EXPECT_THROW(variants->view(node, 0), lod::VariantsError);
}

}  // namespace
}  // namespace tetrascope::testing
