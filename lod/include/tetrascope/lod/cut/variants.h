// Finer versions of a segment that keep its border, in the store's variants.bin.
//
// A segment of level k+1 is its region of level k simplified with the region's border locked
// (mt_levels.cpp). The same simplification stopped earlier gives versions with more tets and
// the very same border faces, so a cut can show one in place of the segment without a new
// border and without refining it: a step between the segment and its children, of the size
// the cut can still afford. `tetrascope preprocess --variants K` builds K of them a segment,
// at tets spaced evenly in log between the segment's and its region's at level k.
//
// variants.bin, little-endian: a header, an index of entries sorted by node then tets (each with
// its block's CRC-32), and one block a variant: global ids (u32 a vertex, kNoGlobal for a vertex the simplification moved
// or changed), positions (3 f32), values (`floats` f32 in manifest order), then its tets in
// the connectivity coding of segments.bin (storage/segment_codec.h), ordered depth first as
// the build orders a segment's. A store without the file has no variants.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "tetrascope/core/tet_topology.h"

namespace tetrascope::storage {
class Store;
}

namespace tetrascope::lod {

class Dag;

constexpr uint32_t kNoGlobal = 0xFFFFFFFFu;

// A damaged or mismatched variants.bin (what is wrong, and what to do).
class VariantsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
constexpr uint32_t kMaxVariants = 8;  // a segment

struct VariantMesh {
  std::vector<uint32_t> global;  // per vertex: the store's global id, or kNoGlobal
  std::vector<float> xyz;        // per vertex
  std::vector<float> values;     // per vertex: every attribute's components in manifest order
  std::vector<uint32_t> tets;    // 4 local vertex ids a tet
  uint64_t tet_count() const { return tets.size() / 4; }
  uint64_t vertex_count() const { return global.size(); }
};

// A variant: its vertices as they lie in the mapped file, its tets decoded.
struct VariantView {
  uint64_t vertex_count = 0, tet_count = 0;
  std::span<const uint32_t> global;
  std::span<const float> xyz, values;
  std::vector<uint32_t> tets;
};

// Build side: variants appended, node by node, to a file without a name in `directory` (it
// goes when the build ends, however it ends), then written out as variants.bin.
class VariantSpill {
 public:
  VariantSpill(std::filesystem::path directory, uint32_t floats);
  ~VariantSpill();
  VariantSpill(const VariantSpill&) = delete;
  VariantSpill& operator=(const VariantSpill&) = delete;
  void add(uint32_t node, const std::vector<VariantMesh>& variants);  // fewest tets first
  bool empty() const { return entries_.empty(); }
  uint64_t tets() const { return tets_; }
  // Writes variants.bin for a DAG of `node_count` nodes; returns its bytes.
  uint64_t write(const std::filesystem::path& file, uint32_t node_count) const;

 private:
  struct Entry {
    uint32_t node, rank;
    uint64_t offset, vertices, tets, stream_bytes;
    uint32_t crc;  // of the block
  };
  std::filesystem::path directory_;
  uint32_t floats_;
  int fd_ = -1;
  uint64_t end_ = 0, tets_ = 0;
  std::vector<Entry> entries_;
  FacePairingScratch pairing_;
  std::vector<uint32_t> opposite_;
  std::vector<uint8_t> stream_;
};

// Read side: variants.bin mapped; the index checked when opened, a block's tets when viewed.
class Variants {
 public:
  // The store's variants, or null when it has none; throws on a damaged file.
  static std::unique_ptr<Variants> open(const storage::Store& store, const Dag& dag);
  ~Variants();
  Variants(const Variants&) = delete;
  Variants& operator=(const Variants&) = delete;
  uint32_t count(uint32_t node) const { return node + 1 < first_.size() ? first_[node + 1] - first_[node] : 0; }
  uint64_t tets(uint32_t node, uint32_t index) const { return entries_[first_[node] + index].tets; }
  // Variant `index` (0: fewest tets) of `node`; throws VariantsError when its block fails its
  // checksum (checked the first time it is viewed) or its tets do not decode.
  VariantView view(uint32_t node, uint32_t index) const;
  uint32_t floats() const { return floats_; }
  uint64_t bytes() const { return length_; }
  uint64_t total_tets() const;

 private:
  struct Entry {
    uint64_t offset, vertices, tets, stream_bytes;
    uint32_t crc;
  };
  Variants() = default;
  void* address_ = nullptr;
  size_t length_ = 0;
  uint32_t floats_ = 0;
  std::vector<uint32_t> first_;  // per node + 1: its first entry
  std::vector<Entry> entries_;
  std::unique_ptr<std::atomic<bool>[]> checked_;  // per entry: its block's CRC has matched
};

// verify's checks of variants.bin: every variant keeps its segment's border faces (those it
// shares with other segments) and none of its tets is inverted (a flat input's flat tets are
// allowed, as in its segments). Empty when sound.
std::vector<std::string> verify_variants(const storage::Store& store, const Dag& dag);

}  // namespace tetrascope::lod
