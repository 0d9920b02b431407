// Writing a store atomically: NAME.tmp/ is filled and renamed to NAME/ only when complete,
// so a crash or kill while writing never leaves a NAME/ behind.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <span>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/store_format.h"

namespace tetrascope::storage {

// One segment's arrays, as the store lays them out (see store_format.h).
struct SegmentData {
  uint32_t id = 0;
  uint32_t owned_vertex_count = 0;
  uint32_t boundary_tet_count = 0;
  std::vector<float> x, y, z;
  std::vector<float> attributes;  // attribute-major
  std::vector<uint32_t> tets, opposites, global_ids;
  std::vector<store::BorderLink> links;
  float bounds[6] = {0, 0, 0, 0, 0, 0};
};

class StoreWriter {
 public:
  // Fails if `directory` exists and `replace` is false. A stale NAME.tmp/ is removed.
  // `compression` other than kNone writes a version-2 store (store_format.h).
  StoreWriter(std::filesystem::path directory, bool replace, uint64_t vertex_count,
              uint32_t segment_count, uint32_t floats_per_vertex,
              store::Compression compression = store::Compression::kNone);
  ~StoreWriter();  // removes NAME.tmp/ unless finish() completed
  StoreWriter(const StoreWriter&) = delete;
  StoreWriter& operator=(const StoreWriter&) = delete;

  // Appends a segment at the next page boundary; segments come in streaming order.
  void add_segment(const SegmentData& segment);
  // Writes the directory, neighbour lists, header and manifest.json (with its checksum),
  // syncs, and renames NAME.tmp/ to NAME/. `neighbours[s]` lists segment s's neighbours.
  void finish(const std::vector<std::vector<uint32_t>>& neighbours, nlohmann::json manifest);

  uint64_t bytes_written() const { return next_offset_; }
  const std::filesystem::path& temp_directory() const { return temp_; }

 private:
  void write_at(uint64_t offset, const void* data, size_t bytes);
  std::filesystem::path directory_, temp_;
  bool replace_;
  int fd_ = -1;
  bool finished_ = false;
  store::FileHeader header_{};
  std::vector<store::SegmentRecord> records_;
  std::vector<uint8_t> added_;
  uint64_t next_offset_ = 0;
  std::vector<uint8_t> buffer_;
  std::vector<uint8_t> stream_;
  std::vector<uint16_t> narrow_;
};

// Writes `manifest` to `path` with a "checksum" field over the file's exact bytes.
void write_manifest(const std::filesystem::path& path, nlohmann::json manifest);

}  // namespace tetrascope::storage
