// Vertex partition of §6.1.1: an octree with at most K vertices a leaf, leaves joined by
// face adjacency into a graph, and the graph cut by METIS into balanced, compact,
// face-connected parts. Leaves may weigh their tets instead of their vertices (see below).
#pragma once

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

}  // namespace tetrascope::lod
