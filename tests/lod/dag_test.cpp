// The runtime DAG (lod/dag.h): damaged or mismatched dag.bin files are refused.
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
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store_verify.h"

namespace tetrascope::testing {
namespace {

// A fresh copy of the sample's store, to damage or rewrite.
std::filesystem::path copy_of_sample(const std::string& scratch) {
  const auto copy = scratch_dir(scratch) / "store";
  std::filesystem::remove_all(copy);
  std::filesystem::copy(built("sample").store, copy, std::filesystem::copy_options::recursive);
  return copy;
}

TEST(Dag, DamagedDagIsRefused) {
  const Built& b = built("sample");
  const auto copy = copy_of_sample("multires-damaged");
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

// The error masses (format 2): none at the input (level 0 is exact), some at every coarser
// level, and each mass lies where its segment is: its centroid inside the segment's box.
TEST(Dag, TheErrorMassIsZeroAtTheInputAndLiesInsideItsSegment) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  ASSERT_TRUE(dag->has_mass());
  std::vector<double> level_mass(dag->level_count(), 0.0);
  for (uint32_t n = 0; n < dag->node_count(); ++n) {
    const lod::dag::Node& node = dag->node(n);
    const float* box = node.bounds;
    const double slack = 1e-3 * std::max({box[3] - box[0], box[4] - box[1], box[5] - box[2]});
    for (uint32_t c = 0; c < dag->channel_count(); ++c) {
      const auto mass = dag->mass_histogram(n, c);
      for (uint32_t bin = 0; bin < dag->bins(); ++bin) {
        ASSERT_GE(mass[bin], 0.0f);
        level_mass[node.level] += mass[bin];
        if (mass[bin] == 0) continue;
        for (int k = 0; k < 3; ++k) {
          const float at = dag->mass_centroid(n, c, k)[bin];
          EXPECT_GE(at, box[k] - slack) << "node " << n << " bin " << bin << " axis " << k;
          EXPECT_LE(at, box[k + 3] + slack) << "node " << n << " bin " << bin << " axis " << k;
        }
      }
    }
  }
  EXPECT_EQ(level_mass[0], 0.0) << "the input has no error";
  for (uint32_t level = 1; level < dag->level_count(); ++level) EXPECT_GT(level_mass[level], 0.0) << "level " << level;
}

// A store made before the error masses (dag format 1) still opens, and its cut still
// refines by the largest error per value slot.
TEST(Dag, ADagOfFormat1StillOpensAndRefines) {
  const auto copy = copy_of_sample("multires-format1");
  auto store = storage::Store::open(copy);
  auto dag = lod::open_dag(*store);
  const uint32_t C = dag->channel_count(), N = dag->bins();
  std::vector<lod::dag::Node> nodes;
  std::vector<float> histograms;
  for (uint32_t n = 0; n < dag->node_count(); ++n) {
    nodes.push_back(dag->node(n));
    for (uint32_t c = 0; c < C; ++c) {
      for (float v : dag->field_histogram(n, c)) histograms.push_back(v);
      for (float v : dag->spatial_histogram(n, c)) histograms.push_back(v);
    }
  }
  const std::vector<lod::dag::Patch> patches(dag->patches().begin(), dag->patches().end());
  lod::write_dag(copy / "dag.bin", dag->level_count(), nodes, patches, C, N, histograms, lod::dag::kKindsV1);
  auto old = lod::open_dag(*store);
  ASSERT_TRUE(old);
  EXPECT_FALSE(old->has_mass());
  for (uint32_t n = 0; n < dag->node_count(); ++n)
    for (uint32_t c = 0; c < C; ++c) {
      ASSERT_TRUE(std::ranges::equal(old->field_histogram(n, c), dag->field_histogram(n, c)));
      ASSERT_TRUE(std::ranges::equal(old->spatial_histogram(n, c), dag->spatial_histogram(n, c)));
    }
  EXPECT_TRUE(lod::verify_dag(*store, *old).empty());
  view::TransferFunction tf;
  tf.attribute = "Temp";
  auto criteria = lod::criteria_for(*store, *old, tf);
  lod::set_view(criteria, view::parse_camera("azimuth=30,elevation=20", store->manifest().bounds));
  lod::Cut cut(*old);
  const uint64_t coarsest = cut.tet_count();
  const auto changes = cut.update(criteria, 20000);
  EXPECT_GT(cut.tet_count(), coarsest);
  EXPECT_LE(cut.tet_count(), 20000u);
  EXPECT_GT(changes.estimated_error, 0.0);
}

}  // namespace
}  // namespace tetrascope::testing
