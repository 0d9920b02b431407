// On-disk layout of a store's segments.bin (see docs/store-format.md).
//
// A store is a directory NAME/ with manifest.json and segments.bin, written as NAME.tmp/
// and renamed when complete. segments.bin holds a file header, a directory of segment
// records, the segment neighbour lists, and then the segments, each at a page-aligned
// offset in streaming order so that it can be mapped and used in place. Every block carries
// a CRC-32; array positions inside a segment follow from its counts (segment_layout), so a
// reader never follows an offset it read from the file.
#pragma once

#include <cstddef>
#include <cstdint>

namespace tetrascope::storage::store {

constexpr uint32_t kFormatVersion = 1;
// Stores whose tets are compressed (FileHeader::compression != kNone) carry this version in
// manifest.json, the file header and every segment header, so a reader built before
// compression refuses them by version instead of misreading the tets.
constexpr uint32_t kCompressedFormatVersion = 2;

// How a store keeps its segments' tets (FileHeader::compression, manifest files.segments.bin
// .compression). kIndex16 stores uint16 local indices in segments of at most
// kMaxIndex16Vertices vertices (others stay uint32); kCutBorder replaces tets and opposites
// by a connectivity stream (segment_codec.h) after the other arrays.
enum class Compression : uint32_t { kNone = 0, kIndex16 = 1, kCutBorder = 2 };
constexpr uint32_t kMaxIndex16Vertices = 65536;
// The shortest a tet's code in a kCutBorder stream can be (a symbol byte and the gate), so a
// record's size bounds its tet count and what decoding it allocates.
constexpr uint64_t kMinStreamBytesPerTet = 2;
constexpr uint64_t kPageBytes = 4096;
constexpr char kFileMagic[8] = {'T', 'E', 'T', 'R', 'A', 'S', 'E', 'G'};
constexpr uint32_t kSegmentMagic = 0x47455354;  // "TSEG"

// Opposite of a tet face: local tet * 4 + face, or one of these.
constexpr uint32_t kMeshBoundary = 0xFFFFFFFFu;   // face on the boundary of the whole mesh
constexpr uint32_t kSegmentBorder = 0xFFFFFFFEu;  // face shared with another segment: see links
constexpr uint32_t kMaxSegmentTets = (1u << 30) - 1;
constexpr uint32_t kMaxSegments = (1u << 30);

struct FileHeader {  // at offset 0
  char magic[8];
  uint32_t version;
  uint32_t header_bytes;       // sizeof(FileHeader)
  uint64_t file_bytes;
  uint64_t vertex_count;       // of the whole mesh
  uint64_t tet_count;
  uint32_t segment_count;
  uint32_t floats_per_vertex;  // sum of attribute components
  uint64_t directory_offset;   // SegmentRecord[segment_count]
  uint64_t neighbours_offset;  // uint32_t[neighbour_total]
  uint64_t neighbour_total;
  uint32_t directory_crc;
  uint32_t neighbours_crc;
  uint32_t compression;        // Compression; 0 in version 1
  uint32_t reserved;
  uint32_t header_crc;         // of every byte above
};

struct SegmentRecord {
  uint64_t offset;             // page-aligned
  uint64_t bytes;
  uint32_t vertex_count;       // owned + shared copies
  uint32_t owned_vertex_count; // the first owned_vertex_count vertices belong to this segment
  uint32_t tet_count;
  uint32_t boundary_tet_count; // tets with a face on a segment border come first (§6.2.3)
  uint32_t link_count;         // faces on segment borders
  uint32_t neighbour_begin;    // into the neighbour list
  uint32_t neighbour_count;
  uint32_t crc;                // of the segment's bytes
  float bounds[6];             // min xyz, max xyz
};

struct SegmentHeader {  // first bytes of every segment
  uint32_t magic;
  uint32_t version;
  uint32_t segment;
  uint32_t vertex_count;
  uint32_t owned_vertex_count;
  uint32_t tet_count;
  uint32_t boundary_tet_count;
  uint32_t link_count;
  uint32_t floats_per_vertex;
  uint32_t compression;        // the file's Compression; 0 in version 1
  uint32_t stream_bytes;       // kCutBorder: bytes of the connectivity stream; else 0
  uint32_t reserved;
};

// A face on a segment border and the face it meets in the neighbouring segment.
struct BorderLink {
  uint32_t face;          // local tet * 4 + face, ascending within a segment
  uint32_t segment;       // neighbouring segment
  uint32_t remote_face;   // its local tet * 4 + face
};

// Byte positions of a segment's arrays, derived from its counts; every array 16-byte aligned.
struct SegmentLayout {
  uint64_t x, y, z;        // float[vertex_count] each
  uint64_t attributes;     // float[vertex_count * floats_per_vertex], attribute-major
  uint64_t tets;           // uint32[4 * tet_count], uint16 when tet_index_bytes is 2; kCutBorder: the stream
  uint64_t opposites;      // uint32[4 * tet_count]; kCutBorder: none (rebuilt by the decoder)
  uint64_t links;          // BorderLink[link_count]
  uint64_t global_ids;     // uint32[vertex_count]
  uint64_t bytes;          // total, not padded to a page
  uint32_t tet_index_bytes;  // 4 or 2; 0 for kCutBorder
};

inline uint64_t align16(uint64_t v) { return (v + 15) & ~uint64_t{15}; }
inline uint64_t align_page(uint64_t v) { return (v + kPageBytes - 1) & ~(kPageBytes - 1); }

// The layout of version 1 and of kNone/kIndex16: header, x, y, z, attributes, tets, opposites,
// links, global ids. kCutBorder: header, x, y, z, attributes, links, global ids, then the
// stream of `stream_bytes` (known from the record's size, checked against the header).
inline SegmentLayout segment_layout(uint64_t vertices, uint64_t tets, uint64_t links, uint64_t floats_per_vertex,
                                    Compression compression = Compression::kNone, uint64_t stream_bytes = 0) {
  SegmentLayout l{};
  uint64_t at = align16(sizeof(SegmentHeader));
  l.x = at;
  at = align16(at + 4 * vertices);
  l.y = at;
  at = align16(at + 4 * vertices);
  l.z = at;
  at = align16(at + 4 * vertices);
  l.attributes = at;
  at = align16(at + 4 * vertices * floats_per_vertex);
  if (compression == Compression::kCutBorder) {
    l.links = at;
    at = align16(at + sizeof(BorderLink) * links);
    l.global_ids = at;
    at = align16(at + 4 * vertices);
    l.tets = at;
    l.opposites = at;
    l.bytes = at + stream_bytes;
    l.tet_index_bytes = 0;
    return l;
  }
  l.tet_index_bytes = compression == Compression::kIndex16 && vertices <= kMaxIndex16Vertices ? 2 : 4;
  l.tets = at;
  at = align16(at + 4 * uint64_t{l.tet_index_bytes} * tets);
  l.opposites = at;
  at = align16(at + 16 * tets);
  l.links = at;
  at = align16(at + sizeof(BorderLink) * links);
  l.global_ids = at;
  at = align16(at + 4 * vertices);
  l.bytes = at;
  return l;
}

static_assert(sizeof(FileHeader) == 96);
static_assert(sizeof(SegmentRecord) == 72);
static_assert(sizeof(SegmentHeader) == 48);
static_assert(sizeof(BorderLink) == 12);

}  // namespace tetrascope::storage::store
