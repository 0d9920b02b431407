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
#include "tetrascope/lod/cut.h"
#include "tetrascope/lod/dag.h"
#include "tetrascope/lod/mt_build.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store_verify.h"

namespace tetrascope::testing {
namespace {

TEST(Dag, DamagedDagIsRefused) {
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
