// The connectivity coding of a segment's tets (Compression::kCutBorder, store_format.h): the
// tets and their in-segment face adjacency as one byte stream, decoded back to exactly the
// same uint32 tets (order, vertex order) and opposites. Inspired by the cut-border machine of
// dissertation §6.3.3; see segment_codec.cpp for the stream and how it differs.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "tetrascope/storage/store_format.h"

namespace tetrascope::storage {

// Appends the stream of `tets` (uint32[4n], local vertex ids) and `opposites` (4 per tet, the
// store's convention: 4*t'+f', kMeshBoundary or kSegmentBorder) to `out`. Trusted input from
// the store writer; throws std::invalid_argument if a face is paired with its own tet or with
// a face of different vertices.
void encode_tets(std::span<const uint32_t> tets, std::span<const uint32_t> opposites, std::vector<uint8_t>& out);

// Decodes an untrusted `stream` of `tet_count` tets over `vertex_count` local vertices into
// the caller's `tets` and `opposites` (each 4 * tet_count long). Faces paired by the stream
// get their opposite, the faces in `links` kSegmentBorder (links' faces are range-checked
// here; their order and targets are the caller's to check), the rest kMeshBoundary. Returns
// an empty string, or what is wrong ("tet 17: vertex 70000 out of range") - never reads
// outside `stream` or writes outside the two spans.
std::string decode_tets(std::span<const uint8_t> stream, uint32_t vertex_count, uint32_t tet_count,
                        std::span<const store::BorderLink> links, std::span<uint32_t> tets, std::span<uint32_t> opposites);

// "none", "index16", "cutborder"; parse_compression throws std::invalid_argument otherwise.
const char* compression_name(store::Compression compression);
store::Compression parse_compression(const std::string& name);

}  // namespace tetrascope::storage
