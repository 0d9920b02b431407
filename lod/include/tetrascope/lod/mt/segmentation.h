// `tetrascope segment`: mesh file -> store of segments (dissertation §6.1), out of core:
// vertices in memory, tets streamed once and spilled per segment to a temporary file.
#pragma once

#include <cstdint>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/progress.h"

namespace tetrascope::lod {

struct SegmentationOptions {
  uint32_t leaf_vertices = 0;      // K: most vertices in an octree leaf; 0 = about 1/8 of a segment's vertices, at most 2000
  uint32_t segment_tets = 16384;   // target tets a segment (sets the segment count)
  uint32_t segments = 0;           // or the segment count itself (0: from segment_tets)
  int seed = 1;                    // METIS seed: same input and options, same store
  bool replace = false;            // overwrite an existing store
  storage::ReadLimits read_limits;  // what one input may cost (--max-inflate-ratio), as preprocess
};

// Limits on options, checked before any work.
constexpr uint32_t kMinLeafVertices = 8;
constexpr uint32_t kMaxLeafVertices = 1u << 20;
constexpr uint32_t kMinSegmentTets = 64;

struct SegmentationReport {
  uint64_t vertices = 0, tets = 0;
  uint32_t segments = 0, leaves = 0;
  uint32_t min_vertices = 0, max_vertices = 0, min_tets = 0, max_tets = 0;
  double avg_vertices = 0, avg_tets = 0;
  uint32_t max_workload = 0;
  bool contiguous = false;
  uint64_t store_bytes = 0;
  double seconds = 0;
  nlohmann::json to_json() const;
};

// Throws storage::MeshError for a bad mesh, std::runtime_error for other failures; on any
// failure no store directory is left behind.
SegmentationReport segment_mesh(const std::filesystem::path& mesh, const std::filesystem::path& store,
                                const SegmentationOptions& options, storage::Progress* progress = nullptr);

}  // namespace tetrascope::lod
