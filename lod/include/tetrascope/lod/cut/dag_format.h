// On-disk layout of a multiresolution store's dag.bin (see docs/store-format.md): the
// multi-triangulation of dissertation §6.3. Nodes are segments (one per segment of
// segments.bin, same index); patches are the DAG's arcs, from a ceiling segment (level i+1)
// to a floor segment (level i), and hold a contiguous range of the floor segment's tets.
// Every block carries a CRC-32; a reader checks every count, range and index before use.
#pragma once

#include <cstdint>

namespace tetrascope::lod::dag {

// 1: field and spatial error histograms; 2: also the error mass and its centroid per bin.
// A reader takes both.
constexpr uint32_t kFormatVersion = 2;
constexpr uint32_t kKindsV1 = 2;  // histograms per node and channel: field, spatial
constexpr uint32_t kKinds = 6;    // field, spatial, mass, centroid x, y, z
constexpr char kFileMagic[8] = {'T', 'E', 'T', 'R', 'A', 'D', 'A', 'G'};
constexpr uint32_t kRoot = 0xFFFFFFFFu;  // ceiling of the patches of the coarsest segments
constexpr uint32_t kMaxBins = 4096;
constexpr uint32_t kMaxLevels = 64;

struct Header {  // at offset 0
  char magic[8];
  uint32_t version;
  uint32_t header_bytes;  // sizeof(Header)
  uint64_t file_bytes;
  uint32_t level_count;
  uint32_t node_count;      // = the store's segment count
  uint32_t patch_count;
  uint32_t channel_count;   // one histogram pair per attribute (vectors by magnitude)
  uint32_t bins;            // histogram resolution N
  uint32_t reserved0;
  uint64_t nodes_offset;       // Node[node_count]
  uint64_t patches_offset;     // Patch[patch_count], grouped by ceiling: root patches first
  uint64_t parents_offset;     // uint32_t[patch_count]: patch ids grouped by floor node
  uint64_t histograms_offset;  // float[node_count][channel_count][kinds][bins]: field error, spatial error, and
                               // from version 2 the error mass then its centroid's x, y, z (kKinds)
  uint32_t nodes_crc, patches_crc, parents_crc, histograms_crc;
  uint32_t reserved[3];
  uint32_t header_crc;  // of every byte above
};

struct Node {
  uint32_t level;          // 0 = the input mesh
  uint32_t tet_count;      // = the segment's
  uint32_t first_child;    // patches with this node as ceiling: [first_child, first_child + child_count)
  uint32_t child_count;
  uint32_t first_parent;   // into the parents list: patches with this node as floor
  uint32_t parent_count;
  float bounds[6];         // min xyz, max xyz
};

struct Patch {
  uint32_t ceiling;    // node, or kRoot
  uint32_t floor;      // node whose tets it holds
  uint32_t tet_begin;  // range in the floor segment's tets
  uint32_t tet_count;
};

static_assert(sizeof(Header) == 112);
static_assert(sizeof(Node) == 48);
static_assert(sizeof(Patch) == 16);

}  // namespace tetrascope::lod::dag
