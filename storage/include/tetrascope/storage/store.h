// Reading a store: the manifest, segments.bin's header and directory, and segments mapped
// on demand. Store files are untrusted: every block is checked (magic, version, sizes, CRC)
// and every index of a segment is range-checked when it is mapped; problems raise
// StoreError naming the file, the segment and the field. A validated segment is then used
// in place, without parsing.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <span>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/store_format.h"

namespace tetrascope::storage {

class StoreError : public std::runtime_error {
 public:
  explicit StoreError(const std::string& message) : std::runtime_error(message) {}
};
// A store file that could not be opened or mapped (permissions, out of descriptors or memory):
// the store may be sound; the server does not mark it damaged.
class StoreIoError : public StoreError {
 public:
  using StoreError::StoreError;
};

struct StoreAttribute {
  std::string name;
  uint32_t components = 1;
  double min = 0, max = 0;  // of the value (scalars) or the magnitude (vectors), original units
  // of each component of a vector (manifest "component_ranges"); empty for scalars and in
  // stores written before it was recorded
  std::vector<std::array<double, 2>> component_ranges{};
  // As in AttributeInfo: a symmetric tensor (6 components) or a scalar derived from one.
  AttributeKind kind = AttributeKind::kValue;
  bool positive_semidefinite = false;
  std::string derived_from{};
};

// The range of component `component` (0..components-1) of a vector attribute over the whole
// dataset: as recorded, else [-max, max] (no component exceeds the magnitude).
inline std::array<double, 2> component_range(const StoreAttribute& a, uint32_t component) {
  if (component < a.component_ranges.size()) return a.component_ranges[component];
  return {-a.max, a.max};
}

struct StoreManifest {
  uint32_t version = 0;
  std::string source_file;
  uint64_t source_bytes = 0;
  std::string source_sha256;
  uint64_t vertex_count = 0, tet_count = 0;
  uint32_t segment_count = 0;
  std::vector<StoreAttribute> attributes;
  Bounds bounds;
  std::vector<int64_t> stream_tags;  // §6.1.3: s+1 loads segment s, -(s+1) releases it
  uint32_t max_workload_segments = 0;
  nlohmann::json json;               // the whole manifest, as read
};

// A validated segment, used in place. Arrays as in store_format.h.
struct SegmentView {
  uint32_t id = 0;
  uint32_t vertex_count = 0, owned_vertex_count = 0, tet_count = 0, boundary_tet_count = 0;
  std::span<const float> x, y, z;
  std::span<const float> attributes;  // attribute-major: attribute a starts at vertex_count * (sum of earlier components)
  std::span<const uint32_t> tets, opposites, global_ids;
  std::span<const store::BorderLink> links;
};

// One segment mapped from segments.bin; unmapped when the last reference goes. In a compressed
// store the view's tets (and, for kCutBorder, opposites) point into `decoded`, owned here.
class MappedSegment {
 public:
  MappedSegment(void* address, size_t length, SegmentView view, std::vector<uint32_t> decoded = {})
      : address_(address), length_(length), view_(view), decoded_(std::move(decoded)) {}
  // `base` with its attributes replaced by `values` (a time step's, owned here; laid out as
  // SegmentView::attributes); base stays mapped while this lives.
  MappedSegment(std::shared_ptr<const MappedSegment> base, std::vector<float> values);
  ~MappedSegment();
  MappedSegment(const MappedSegment&) = delete;
  MappedSegment& operator=(const MappedSegment&) = delete;
  const SegmentView& view() const { return view_; }
  // what the segment holds in memory: the mapping and the decoded arrays
  size_t mapped_bytes() const { return length_ + decoded_.size() * sizeof(uint32_t) + values_.size() * sizeof(float) + (base_ ? base_->mapped_bytes() : 0); }

 private:
  void* address_;
  size_t length_;
  SegmentView view_;
  std::vector<uint32_t> decoded_;
  std::shared_ptr<const MappedSegment> base_;  // a time step's segment: the mapping it reads
  std::vector<float> values_;                  // a time step's segment: its attributes
};

class Store {
 public:
  // Reads and checks manifest.json and segments.bin's header, directory and neighbour lists.
  static std::unique_ptr<Store> open(const std::filesystem::path& directory);
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  const std::filesystem::path& path() const { return path_; }
  const StoreManifest& manifest() const { return manifest_; }
  const store::FileHeader& header() const { return header_; }
  store::Compression compression() const { return static_cast<store::Compression>(header_.compression); }
  uint32_t segment_count() const { return header_.segment_count; }
  const store::SegmentRecord& record(uint32_t segment) const { return records_.at(segment); }
  std::span<const uint32_t> neighbours(uint32_t segment) const;
  // Maps one segment and checks its CRC and every index. Thread-safe.
  std::shared_ptr<const MappedSegment> map_segment(uint32_t segment) const;

 private:
  Store() = default;
  std::filesystem::path path_;
  int fd_ = -1;
  StoreManifest manifest_;
  store::FileHeader header_{};
  std::vector<store::SegmentRecord> records_;
  std::vector<uint32_t> neighbours_;
};

class SegmentCache;

// The byte budget and least-recently-used order that segment caches share: a server gives one
// pool to every open dataset, so all datasets' segments compete for one budget (`serve
// --cache-mb`). Thread-safe.
class SegmentPool {
 public:
  struct Stats {
    uint64_t hits = 0, misses = 0, evictions = 0, resident_bytes = 0;
  };
  explicit SegmentPool(uint64_t budget_bytes) : budget_(budget_bytes) {}
  uint64_t budget() const { return budget_; }
  Stats stats() const;  // all caches together

 private:
  friend class SegmentCache;
  using Key = uint64_t;  // cache id << 32 | segment
  struct Entry {
    std::shared_ptr<const MappedSegment> segment;
    std::list<Key>::iterator position;
  };
  uint64_t add_cache();
  void remove_cache(uint64_t id);  // unmaps (drops) the cache's entries nobody holds
  std::shared_ptr<const MappedSegment> find(uint64_t id, uint32_t segment);
  std::shared_ptr<const MappedSegment> insert(uint64_t id, uint32_t segment, std::shared_ptr<const MappedSegment> mapped);
  Stats cache_stats(uint64_t id) const;

  const uint64_t budget_;
  mutable std::mutex mutex_;
  uint64_t next_id_ = 1;
  std::list<Key> lru_;  // most recent first
  std::unordered_map<Key, Entry> entries_;
  std::unordered_map<uint64_t, Stats> per_cache_;
  Stats total_;
};

// One store's segments: mapped on demand, kept while their bytes fit the pool's budget, least
// recently used released first, across every cache of the pool (a segment in use stays
// mapped). Thread-safe.
class SegmentCache {
 public:
  using Stats = SegmentPool::Stats;
  SegmentCache(const Store& store, uint64_t budget_bytes);           // a pool of its own
  SegmentCache(const Store& store, std::shared_ptr<SegmentPool> pool);  // shares `pool`'s budget
  // A cache whose segments pass through `transform` once mapped (a time step's values:
  // with_step_values, time_steps.h).
  using Transform = std::function<std::shared_ptr<const MappedSegment>(std::shared_ptr<const MappedSegment>)>;
  SegmentCache(const Store& store, std::shared_ptr<SegmentPool> pool, Transform transform);
  ~SegmentCache();
  SegmentCache(const SegmentCache&) = delete;
  SegmentCache& operator=(const SegmentCache&) = delete;
  std::shared_ptr<const MappedSegment> get(uint32_t segment);
  Stats stats() const;  // this store's segments: hits, misses, evictions, resident bytes

 private:
  const Store& store_;
  std::shared_ptr<SegmentPool> pool_;
  uint64_t id_;
  Transform transform_;
};

// CRC-32 (zlib's polynomial) of a byte range.
uint32_t crc32_of(const void* data, size_t bytes, uint32_t seed = 0);

}  // namespace tetrascope::storage
