// A store is untrusted on open: a byte flipped anywhere in segments.bin or manifest.json, or
// a truncated file, is reported by verify and by the loader, naming the file. The segment
// cache keeps its byte budget and counts hits and misses.
#include <gtest/gtest.h>

#include <random>
#include <thread>

#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/lod/mt/segmentation.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_verify.h"

namespace tetrascope::testing {
namespace {

std::filesystem::path make_store(const std::string& name) {
  auto dir = scratch_dir("store_" + name);
  lod::SegmentationOptions options;
  options.segment_tets = 4000;
  lod::segment_mesh(sample_mesh(), dir / "s", options);
  return dir / "s";
}

// Opens the store and maps every segment; returns the error text or "".
std::string load_all(const std::filesystem::path& store) {
  try {
    auto s = storage::Store::open(store);
    for (uint32_t i = 0; i < s->segment_count(); ++i) s->map_segment(i);
    return "";
  } catch (const storage::StoreError& e) {
    return e.what();
  }
}

TEST(Store, IntactStoreLoadsAndVerifies) {
  auto store = make_store("intact");
  EXPECT_EQ(load_all(store), "");
  auto report = storage::verify_store(store);
  EXPECT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems[0]);
  EXPECT_EQ(report.tets, 44832u);
}

TEST(Store, AFlippedByteAnywhereInSegmentsBinIsReported) {
  auto store = make_store("flip");
  const std::string original = read_file(store / "segments.bin");
  std::mt19937 rng(7);
  std::vector<size_t> positions = {0, 9, 20, 88, 100, 4095, 4096, 4100, original.size() - 1, original.size() / 2};
  for (int i = 0; i < 40; ++i) positions.push_back(rng() % original.size());
  size_t loader_reported = 0;
  for (size_t at : positions) {
    std::string bytes = original;
    bytes[at] = static_cast<char>(bytes[at] ^ (1 + rng() % 255));
    write_file(store / "segments.bin", bytes);
    auto report = storage::verify_store(store);
    EXPECT_FALSE(report.ok) << "flip at byte " << at << " went unnoticed by verify";
    if (!report.ok) {
      EXPECT_NE(report.problems[0].find("segments.bin"), std::string::npos) << report.problems[0];
    }
    loader_reported += load_all(store) != "";
  }
  write_file(store / "segments.bin", original);
  EXPECT_TRUE(storage::verify_store(store).ok);
  // padding between blocks carries no data: the loader may skip it, verify does not
  EXPECT_GE(loader_reported, positions.size() * 8 / 10);
}

TEST(Store, AFlippedByteInTheManifestIsReported) {
  auto store = make_store("manifest");
  const std::string original = read_file(store / "manifest.json");
  std::mt19937 rng(11);
  for (int i = 0; i < 40; ++i) {
    std::string bytes = original;
    size_t at = rng() % bytes.size();
    bytes[at] = static_cast<char>(bytes[at] ^ (1 + rng() % 255));
    write_file(store / "manifest.json", bytes);
    std::string error = load_all(store);
    EXPECT_NE(error, "") << "flip at byte " << at;
    EXPECT_NE(error.find("manifest.json"), std::string::npos) << error;
    EXPECT_FALSE(storage::verify_store(store).ok);
  }
}

TEST(Store, TruncatedFilesAreReported) {
  auto store = make_store("truncate");
  const std::string original = read_file(store / "segments.bin");
  for (size_t keep : {size_t{0}, size_t{50}, size_t{4096}, original.size() / 3, original.size() - 1}) {
    write_file(store / "segments.bin", original.substr(0, keep));
    std::string error = load_all(store);
    EXPECT_NE(error, "") << "kept " << keep;
    EXPECT_FALSE(storage::verify_store(store).ok);
  }
  write_file(store / "segments.bin", original);
  write_file(store / "manifest.json", read_file(store / "manifest.json").substr(0, 100));
  EXPECT_NE(load_all(store), "");
  std::filesystem::remove(store / "manifest.json");
  EXPECT_NE(load_all(store), "");
  EXPECT_NE(load_all(store.parent_path() / "missing"), "");
}

TEST(SegmentCache, KeepsItsBudgetAndCounts) {
  auto path = make_store("cache");
  auto store = storage::Store::open(path);
  ASSERT_GE(store->segment_count(), 6u);
  const uint64_t one = store->record(0).bytes;
  storage::SegmentCache cache(*store, 3 * one);
  for (uint32_t s = 0; s < store->segment_count(); ++s) cache.get(s);
  auto stats = cache.stats();
  EXPECT_EQ(stats.misses, store->segment_count());
  EXPECT_EQ(stats.hits, 0u);
  EXPECT_GT(stats.evictions, 0u);
  EXPECT_LE(stats.resident_bytes, 3 * one + store->record(store->segment_count() - 1).bytes);
  uint32_t last = store->segment_count() - 1;
  cache.get(last);
  EXPECT_EQ(cache.stats().hits, 1u);
  // a segment in use is never unmapped under its reader
  auto held = cache.get(0);
  for (uint32_t s = 1; s < store->segment_count(); ++s) cache.get(s);
  EXPECT_EQ(held->view().id, 0u);
  EXPECT_GT(held->view().tet_count, 0u);
  // many readers at once
  std::vector<std::thread> readers;
  std::atomic<uint64_t> tets{0};
  for (int r = 0; r < 4; ++r) {
    readers.emplace_back([&, r] {
      for (int i = 0; i < 200; ++i) tets += cache.get(static_cast<uint32_t>((i * 7 + r) % store->segment_count()))->view().tet_count;
    });
  }
  for (auto& t : readers) t.join();
  EXPECT_GT(tets.load(), 0u);
  auto after = cache.stats();
  EXPECT_EQ(after.hits + after.misses, uint64_t{store->segment_count()} * 2 + 1 + 800);
}

TEST(SegmentCache, OnePoolEvictsAcrossDatasets) {
  // two datasets (two stores) sharing one budget that holds three segments
  auto a = storage::Store::open(make_store("pool-a"));
  auto b = storage::Store::open(make_store("pool-b"));
  ASSERT_GE(a->segment_count(), 4u);
  uint64_t largest = 0;
  for (uint32_t s = 0; s < a->segment_count(); ++s) largest = std::max(largest, a->record(s).bytes);
  auto pool = std::make_shared<storage::SegmentPool>(3 * largest);
  storage::SegmentCache cache_a(*a, pool), cache_b(*b, pool);
  for (uint32_t s = 0; s < 3; ++s) cache_a.get(s);
  EXPECT_EQ(cache_a.stats().evictions, 0u);
  // dataset b's reads push dataset a's least recently used segments out of the shared budget
  for (uint32_t s = 0; s < 3; ++s) cache_b.get(s);
  EXPECT_GT(cache_a.stats().evictions, 0u);
  EXPECT_EQ(cache_b.stats().evictions, 0u);
  EXPECT_LE(pool->stats().resident_bytes, pool->budget() + largest);
  EXPECT_EQ(pool->stats().resident_bytes, cache_a.stats().resident_bytes + cache_b.stats().resident_bytes);
  // same segment number, different store: never confused
  EXPECT_NE(cache_a.get(0).get(), cache_b.get(0).get());
  // a closed dataset gives its bytes back to the pool
  {
    storage::SegmentCache cache_c(*b, pool);
    cache_c.get(3);
    EXPECT_GT(cache_c.stats().resident_bytes, 0u);
  }
  EXPECT_EQ(pool->stats().resident_bytes, cache_a.stats().resident_bytes + cache_b.stats().resident_bytes);
}

}  // namespace
}  // namespace tetrascope::testing
