// Sharing a preprocess among ranks (lod/ranks.h, mt_share.cpp) without MPI: ranks
// played by threads of this process, exchanging through memory. Two and three ranks write the
// bytes one rank writes (segments.bin, dag.bin, manifest.json), the cost traces of the common
// error targets and the simplified ceilings both crossing between ranks; ceilings go to ranks
// by their work, the same on every rank. The exchange over real MPI is
// tests/mpi/preprocess_mpi_test.sh.
#include <gtest/gtest.h>

#include <condition_variable>
#include <fstream>
#include <iterator>
#include <mutex>
#include <numeric>
#include <thread>

#include "mt_stages.h"
#include "test_paths.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/lod/mt/ranks.h"
#include "tetrascope/storage/store_verify.h"

namespace tetrascope::testing {
namespace {

// What the ranks of one launch share: a generation barrier and one slot a rank.
struct Launch {
  explicit Launch(int ranks) : size(ranks), slots(ranks) {}
  const int size;
  std::mutex mutex;
  std::condition_variable changed;
  int arrived = 0;
  uint64_t generation = 0;
  std::vector<std::vector<uint8_t>> slots;
};

class ThreadRanks final : public lod::Ranks {
 public:
  ThreadRanks(Launch& launch, int rank) : launch_(launch), rank_(rank) {}
  int rank() const override { return rank_; }
  int size() const override { return launch_.size; }
  int node_size() const override { return launch_.size; }
  std::vector<std::vector<uint8_t>> all_gather(std::span<const uint8_t> mine) override {
    launch_.slots[rank_].assign(mine.begin(), mine.end());
    barrier();  // every slot written
    std::vector<std::vector<uint8_t>> out = launch_.slots;
    barrier();  // every slot read before the next exchange writes
    count_received(out);
    return out;
  }
  std::vector<std::vector<uint8_t>> gather(std::span<const uint8_t> mine, int root) override {
    launch_.slots[rank_].assign(mine.begin(), mine.end());
    barrier();
    std::vector<std::vector<uint8_t>> out(launch_.size);
    if (rank_ == root) out = launch_.slots;
    barrier();
    count_received(out);
    return out;
  }
  uint64_t received = 0;  // bytes from the other ranks
  void barrier() override {
    std::unique_lock lock(launch_.mutex);
    const uint64_t generation = launch_.generation;
    if (++launch_.arrived == launch_.size) {
      launch_.arrived = 0;
      ++launch_.generation;
      launch_.changed.notify_all();
    } else {
      launch_.changed.wait(lock, [&] { return launch_.generation != generation; });
    }
  }
  [[noreturn]] void abort(const std::string& message, int) override {
    std::fprintf(stderr, "%s\n", message.c_str());
    std::abort();  // the other ranks would wait forever
  }

 private:
  void count_received(const std::vector<std::vector<uint8_t>>& out) {
    for (int r = 0; r < static_cast<int>(out.size()); ++r)
      if (r != rank_) received += out[r].size();
  }
  Launch& launch_;
  const int rank_;
};

std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

lod::PreprocessOptions small_segments() {
  lod::PreprocessOptions options;
  options.segment_tets = 1024;  // disk_out_ref: dozens of segments at level 0, several above
  options.base_tets = 3000;
  options.threads = 1;
  options.replace = true;
  return options;
}

// Builds the sample on `ranks` threads playing ranks (and alone, for the bytes to compare);
// returns the bytes each rank received from the others.
std::vector<uint64_t> expect_same_store_on(int ranks, uint32_t variants = 0) {
  const auto dir = scratch_dir("mt-share-" + std::to_string(ranks) + "-" + std::to_string(variants));
  lod::PreprocessOptions base = small_segments();
  base.variants = variants;
  const lod::PreprocessReport alone = lod::preprocess(sample_mesh(), dir / "alone", base);
  if (alone.levels.size() < 3 || alone.levels[1].segments < 2u * ranks) {
    ADD_FAILURE() << "the sample needs 3 levels and several segments a rank at level 1";
    return std::vector<uint64_t>(ranks);
  }

  Launch launch(ranks);
  std::vector<lod::PreprocessReport> reports(ranks);
  std::vector<uint64_t> received(ranks);
  std::vector<std::thread> threads;
  for (int r = 0; r < ranks; ++r)
    threads.emplace_back([&, r] {
      ThreadRanks mine(launch, r);
      lod::PreprocessOptions options = base;
      options.threads = 2;  // a rank's own threads change nothing either
      options.ranks = &mine;
      reports[r] = lod::preprocess(sample_mesh(), dir / "shared", options);
      received[r] = mine.received;
    });
  for (auto& t : threads) t.join();

  EXPECT_EQ(reports[0].segments, alone.segments);
  for (int r = 1; r < ranks; ++r) EXPECT_TRUE(reports[r].levels.empty()) << "rank " << r << " wrote";
  std::vector<const char*> files = {"segments.bin", "dag.bin", "manifest.json"};
  if (variants) files.push_back("variants.bin");
  for (const char* file : files)
    EXPECT_TRUE(file_bytes(dir / "alone" / file) == file_bytes(dir / "shared" / file)) << file << " differs on " << ranks << " ranks";
  const auto verified = storage::verify_store(dir / "shared");
  EXPECT_TRUE(verified.ok) << (verified.problems.empty() ? "" : verified.problems[0]);
  return received;
}

TEST(MtShare, TwoRanksWriteTheBytesOfOne) { expect_same_store_on(2); }

TEST(MtShare, ThreeRanksWriteTheBytesOfOne) {
  if (kSanitized) GTEST_SKIP() << "two ranks cover the exchange under the sanitizers";
  expect_same_store_on(3);
}

// Variants go to rank 0 alone: the others receive the same bytes as without them, rank 0
// more, and the store is the one rank's, variants.bin included.
TEST(MtShare, VariantsReachRankZeroAloneAndTheStoreIsTheBytesOfOne) {
  const std::vector<uint64_t> without = expect_same_store_on(2, 0);
  const std::vector<uint64_t> with = expect_same_store_on(2, 2);
  EXPECT_GT(with[0], without[0]) << "rank 0 received the variants of rank 1's segments";
  EXPECT_EQ(with[1], without[1]) << "rank 1 received variants";
}

TEST(MtShare, CeilingsGoToTheLeastLoadedRankLargestFirst) {
  const std::vector<uint64_t> work = {5, 9, 1, 7, 3, 3};
  EXPECT_EQ(lod::mt::ceiling_owners(work, 1), std::vector<uint32_t>(work.size(), 0));
  // 9 -> 0, 7 -> 1, 5 -> 1 (7 < 9), 3 -> 0 (9 < 12), 3 -> 0 (12 = 12: the lower rank), 1 -> 1
  const std::vector<uint32_t> two = lod::mt::ceiling_owners(work, 2);
  EXPECT_EQ(two, (std::vector<uint32_t>{1, 0, 1, 1, 0, 0}));
  std::vector<uint64_t> load(2, 0);
  for (size_t k = 0; k < work.size(); ++k) load[two[k]] += work[k];
  EXPECT_EQ(load, (std::vector<uint64_t>{15, 13}));
  // more ranks than ceilings: each ceiling its own rank, the rest idle
  EXPECT_EQ(lod::mt::ceiling_owners(std::vector<uint64_t>{4, 8}, 4), (std::vector<uint32_t>{1, 0}));
}

}  // namespace
}  // namespace tetrascope::testing
