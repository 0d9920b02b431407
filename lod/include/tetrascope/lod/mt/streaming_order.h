// Streaming order of segments, dissertation §6.1.3: load and release tags chosen so that a
// segment-wise pass keeps few segments active.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace tetrascope::lod {

struct StreamOrder {
  std::vector<uint32_t> order;  // segments in load order
  std::vector<int64_t> tags;    // s+1 loads segment s, -(s+1) releases it
  uint32_t max_workload = 0;    // most segments active at once
};

// `neighbours` must be symmetric. `bounds[s]` = min xyz, max xyz of segment s; the walk starts
// at the segment nearest the minimum corner of all bounds (and again for every component).
StreamOrder streaming_order(const std::vector<std::vector<uint32_t>>& neighbours, std::span<const std::array<float, 6>> bounds);

}  // namespace tetrascope::lod
