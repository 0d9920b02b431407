// Vertex partition of §6.1.1: an octree with at most K vertices a leaf, leaves joined by
// face adjacency into a graph, and the graph cut by METIS into balanced, compact,
// face-connected parts. Leaves may weigh their tets instead of their vertices (see below).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

namespace tetrascope::lod {

struct OctreeLeaf {
  uint32_t lo[3], hi[3];  // box in units of the finest octree level
  uint32_t vertex_count;
};

struct VertexPartition {
  std::vector<uint32_t> part_of_vertex;  // part index per vertex, 0 .. parts-1
  uint32_t parts = 0;
  std::vector<OctreeLeaf> leaves;        // non-empty leaves
  std::vector<uint32_t> part_of_leaf;
  std::vector<uint32_t> leaf_of_vertex;
  // leaf graph in CSR form (face-adjacent non-empty leaves)
  std::vector<uint32_t> adjacency_begin, adjacency;
  bool contiguous = false;               // METIS kept every part face-connected
};

struct PartitionOptions {
  uint32_t leaf_vertices = 2000;  // K
  uint32_t parts = 1;
  int seed = 1;
};

// `xyz` interleaved. Leaves weigh their vertex count, or with `tets_per_vertex` (a vertex's
// share of the tets: incident tets / 4) their share of the tets, so that METIS balances tets.
// Deterministic for the same input and options. Throws std::runtime_error when METIS fails.
VertexPartition partition_vertices(std::span<const float> xyz, const PartitionOptions& options,
                                   std::span<const float> tets_per_vertex = {});

// Octree leaves hold about an eighth of a segment's vertices, within these bounds, unless the
// caller sets the leaf size: METIS balances whole leaves, so a segment should span several.
constexpr uint32_t kMinAutoLeafVertices = 8;
constexpr uint32_t kMaxAutoLeafVertices = 2000;

// Vertices grouped into segments, numbered by ascending vertex count (§6.1.1).
struct SegmentPartition {
  std::vector<uint32_t> segment_of_vertex;
  uint32_t segments = 0;       // parts with at least one vertex
  uint32_t leaves = 0;         // octree leaves
  uint32_t leaf_vertices = 0;  // K used
  bool contiguous = false;     // METIS kept every part face-connected
};

// The partition step shared by `tetrascope segment` and every level of `tetrascope
// preprocess`: partition_vertices into `parts` (leaf size from `leaf_vertices`, or 0 for the
// automatic size above), then segments numbered by ascending vertex count, empty parts
// dropped. A tet then goes to segment_of_tet (the lowest segment among its vertices).
SegmentPartition partition_segments(std::span<const float> xyz, uint32_t parts, uint32_t leaf_vertices, int seed,
                                    std::span<const float> tets_per_vertex = {});

inline uint32_t segment_of_tet(std::span<const uint32_t> segment_of_vertex, const uint32_t* tet) {
  return std::min(std::min(segment_of_vertex[tet[0]], segment_of_vertex[tet[1]]), std::min(segment_of_vertex[tet[2]], segment_of_vertex[tet[3]]));
}

}  // namespace tetrascope::lod
