// Segment caches and the pool whose budget they share (store.h).
#include "tetrascope/storage/store.h"

namespace tetrascope::storage {

SegmentPool::Stats SegmentPool::stats() const {
  std::lock_guard lock(mutex_);
  return total_;
}

uint64_t SegmentPool::add_cache() {
  std::lock_guard lock(mutex_);
  const uint64_t id = next_id_++;
  per_cache_[id] = {};
  return id;
}

void SegmentPool::remove_cache(uint64_t id) {
  std::lock_guard lock(mutex_);
  for (auto it = lru_.begin(); it != lru_.end();) {
    if ((*it >> 32) != id) {
      ++it;
      continue;
    }
    auto entry = entries_.find(*it);
    total_.resident_bytes -= entry->second.segment->mapped_bytes();
    entries_.erase(entry);  // a reader still holding the segment keeps it mapped until it lets go
    it = lru_.erase(it);
  }
  per_cache_.erase(id);
}

std::shared_ptr<const MappedSegment> SegmentPool::find(uint64_t id, uint32_t segment) {
  std::lock_guard lock(mutex_);
  auto it = entries_.find(id << 32 | segment);
  Stats& mine = per_cache_[id];
  if (it == entries_.end()) {
    ++mine.misses;
    ++total_.misses;
    return nullptr;
  }
  ++mine.hits;
  ++total_.hits;
  lru_.splice(lru_.begin(), lru_, it->second.position);
  return it->second.segment;
}

std::shared_ptr<const MappedSegment> SegmentPool::insert(uint64_t id, uint32_t segment, std::shared_ptr<const MappedSegment> mapped) {
  std::lock_guard lock(mutex_);
  const Key key = id << 32 | segment;
  auto it = entries_.find(key);
  if (it != entries_.end()) return it->second.segment;  // another thread mapped it first
  lru_.push_front(key);
  entries_[key] = {mapped, lru_.begin()};
  per_cache_[id].resident_bytes += mapped->mapped_bytes();
  total_.resident_bytes += mapped->mapped_bytes();
  // evict the least recently used segments nobody holds, of any cache, until the budget fits
  for (auto victim = std::prev(lru_.end()); total_.resident_bytes > budget_ && victim != lru_.begin();) {
    auto entry = entries_.find(*victim);
    auto previous = std::prev(victim);
    if (entry->second.segment.use_count() == 1) {
      const uint64_t bytes = entry->second.segment->mapped_bytes();
      Stats& owner = per_cache_[*victim >> 32];
      owner.resident_bytes -= bytes;
      ++owner.evictions;
      total_.resident_bytes -= bytes;
      ++total_.evictions;
      entries_.erase(entry);
      lru_.erase(victim);
    }
    victim = previous;
  }
  return mapped;
}

SegmentPool::Stats SegmentPool::cache_stats(uint64_t id) const {
  std::lock_guard lock(mutex_);
  auto it = per_cache_.find(id);
  return it == per_cache_.end() ? Stats{} : it->second;
}

SegmentCache::SegmentCache(const Store& store, uint64_t budget_bytes) : SegmentCache(store, std::make_shared<SegmentPool>(budget_bytes)) {}

SegmentCache::SegmentCache(const Store& store, std::shared_ptr<SegmentPool> pool) : store_(store), pool_(std::move(pool)), id_(pool_->add_cache()) {}

SegmentCache::SegmentCache(const Store& store, std::shared_ptr<SegmentPool> pool, Transform transform)
    : store_(store), pool_(std::move(pool)), id_(pool_->add_cache()), transform_(std::move(transform)) {}

SegmentCache::~SegmentCache() { pool_->remove_cache(id_); }

std::shared_ptr<const MappedSegment> SegmentCache::get(uint32_t segment) {
  if (auto hit = pool_->find(id_, segment)) return hit;
  // map and validate outside the pool's lock; two threads may race to map the same segment,
  // and the first to insert wins
  auto mapped = store_.map_segment(segment);
  if (transform_) mapped = transform_(std::move(mapped));
  return pool_->insert(id_, segment, std::move(mapped));
}

SegmentCache::Stats SegmentCache::stats() const { return pool_->cache_stats(id_); }

}  // namespace tetrascope::storage
