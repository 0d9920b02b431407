// libFuzzer target for the cut-border connectivity decoder (segment_codec.h) on its own: the
// store loader reaches it only through a segment's CRC, which random mutations rarely get
// past. Input: vertex count (uint16), tet count (uint16, at most kMaxTets), link count
// (uint8) and that many link faces (uint16 each), then the stream. A stream that decodes must
// give tets in range and opposites that are symmetric and join equal faces; anything else is
// a bug, reported by abort() (ASan/UBSan report the rest).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/core/tet_topology.h"

namespace {
constexpr uint32_t kMaxTets = 4096;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetrascope;
  using storage::store::BorderLink;
  if (size < 5) return 0;
  const uint32_t vertex_count = data[0] | uint32_t{data[1]} << 8;
  const uint32_t tet_count = (data[2] | uint32_t{data[3]} << 8) % (kMaxTets + 1);
  const uint32_t link_count = data[4];
  size_t at = 5;
  if (size < at + 2 * size_t{link_count}) return 0;
  std::vector<BorderLink> links(link_count);
  for (uint32_t k = 0; k < link_count; ++k, at += 2) links[k] = {uint32_t{data[at]} | uint32_t{data[at + 1]} << 8, 1, 0};
  // the stream in a buffer of its exact size, so that ASan sees a read past its end
  const std::vector<uint8_t> stream(data + at, data + size);
  std::vector<uint32_t> tets(4 * size_t{tet_count}), opposites(4 * size_t{tet_count});
  if (!storage::decode_tets(stream, vertex_count, tet_count, links, tets, opposites).empty()) return 0;
  for (uint32_t v : tets)
    if (v >= vertex_count) std::abort();
  for (uint32_t f = 0; f < opposites.size(); ++f) {
    const uint32_t o = opposites[f];
    if (o == storage::store::kMeshBoundary || o == storage::store::kSegmentBorder) continue;
    if (o >= opposites.size() || opposites[o] != f || o / 4 == f / 4) std::abort();
    if (face_key(tet_face(tets, f / 4, int(f % 4))) != face_key(tet_face(tets, o / 4, int(o % 4)))) std::abort();
  }
  // and it codes back to a stream that decodes to the same
  std::vector<uint8_t> again;
  storage::encode_tets(tets, opposites, again);
  std::vector<uint32_t> tets2(tets.size()), opposites2(tets.size());
  if (!storage::decode_tets(again, vertex_count, tet_count, links, tets2, opposites2).empty() || tets2 != tets || opposites2 != opposites) std::abort();
  return 0;
}
