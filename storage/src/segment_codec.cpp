// Connectivity coding of a segment's tets, after the cut-border machine of dissertation
// §6.3.3 (itself after [GGS99]): a tet is coded by the face it shares with an already decoded
// tet (the gate) and its one free vertex, and the decoder rebuilds the face adjacency from
// the same symbols instead of storing it.
//
// Where it differs from §6.3.3: the store fixes the order of a segment's tets (grouped by
// patch, dag.bin addresses them by range, opposites and links by index) and the vertex order
// inside each tet (VTK order, positive orientation), so the coder does not choose a traversal;
// it codes the tets in their stored order (`preprocess` stores them in a depth-first order
// inside each patch when it writes this coding, mt_tet_order.cpp). The gate of tet t is the
// most recent earlier tet it shares a face with, named by its distance back and its face; the
// other faces it shares with earlier tets are named the same way, which gives the decoder
// every opposite without a face hash map. The free vertex lies on each of those other faces,
// so when there is one it is named by its slot there (the analogue of Flip/Top/Close: already
// on the cut border); otherwise it is a vertex of one of the 7 previous tets or an explicit
// local id, coded as the difference to the previous explicit one (New Vertex). No entropy
// coding: byte-aligned symbols and LEB128 varints, decoded at tens of millions of tets/s.
//
// Per tet:
//   byte   code | mask << 5   code < 24: gate tet, gate face g = code / 6 (face g is opposite
//                             vertex g), kPermutation[code % 6] maps the gate's face vertices
//                             to face g's; code 24: a tet with no earlier neighbour, four
//                             explicit vertices follow and mask is 0. mask bit i: the i-th of
//                             the other three faces (ascending) meets an earlier tet
//   varint (back - 1) << 2 | f'   the gate: face f' of tet t - back
//   mask != 0: varint (back - 1) << 4 | f' << 2 | slot   the first other face, and the free
//                             vertex: vertex `slot` (0..2) of that face f' in kTetFace order
//              varint (back - 1) << 2 | f'   each further mask bit
//   mask == 0: byte free      0: explicit; 1..28: vertex (free-1) % 4 of tet t-1-(free-1)/4
//   varint zigzag(v - last)   each explicit vertex; `last` starts at 0
#include "tetrascope/storage/segment_codec.h"

#include <algorithm>
#include <stdexcept>

#include "tetrascope/core/tet_topology.h"

namespace tetrascope::storage {

using namespace store;

namespace {

constexpr uint8_t kPermutation[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
constexpr uint32_t kGateCodes = 24;
constexpr uint32_t kFreeTet = 24;
constexpr uint32_t kRecentTets = 7;  // how far back a free vertex is looked up
constexpr uint32_t kRecentCodes = 4 * kRecentTets;
constexpr int kMaxVarintBytes = 5;

void put_varint(std::vector<uint8_t>& out, uint64_t value) {
  while (value >= 0x80) {
    out.push_back(static_cast<uint8_t>(value | 0x80));
    value >>= 7;
  }
  out.push_back(static_cast<uint8_t>(value));
}

uint64_t zigzag(int64_t v) { return (static_cast<uint64_t>(v) << 1) ^ static_cast<uint64_t>(v >> 63); }
int64_t unzigzag(uint64_t v) { return static_cast<int64_t>(v >> 1) ^ -static_cast<int64_t>(v & 1); }

FaceVertices face_of(const uint32_t* tet, int f) { return {tet[kTetFace[f][0]], tet[kTetFace[f][1]], tet[kTetFace[f][2]]}; }

}  // namespace

const char* compression_name(Compression compression) {
  switch (compression) {
    case Compression::kNone: return "none";
    case Compression::kIndex16: return "index16";
    case Compression::kCutBorder: return "cutborder";
  }
  return "unknown";
}

Compression parse_compression(const std::string& name) {
  for (Compression c : {Compression::kNone, Compression::kIndex16, Compression::kCutBorder})
    if (name == compression_name(c)) return c;
  throw std::invalid_argument("segment compression must be 'none', 'index16' or 'cutborder', not '" + name + "'");
}

void encode_tets(std::span<const uint32_t> tets, std::span<const uint32_t> opposites, std::vector<uint8_t>& out) {
  if (tets.size() % 4 != 0 || opposites.size() != tets.size()) throw std::invalid_argument("encode_tets: 4 vertices and 4 opposites a tet");
  const uint64_t tet_count = tets.size() / 4;
  uint32_t last = 0;
  auto put_vertex = [&](uint32_t v) {
    put_varint(out, zigzag(int64_t{v} - int64_t{last}));
    last = v;
  };
  for (uint64_t t = 0; t < tet_count; ++t) {
    const uint32_t* tet = &tets[4 * t];
    // faces met by earlier tets; the gate is the most recent of them
    int gate = -1;
    uint64_t gate_back = 0;
    bool earlier[4] = {false, false, false, false};
    for (int f = 0; f < 4; ++f) {
      const uint32_t o = opposites[4 * t + f];
      if (o == kMeshBoundary || o == kSegmentBorder) continue;
      if (o / 4 == t || o >= tets.size()) throw std::invalid_argument("encode_tets: tet " + std::to_string(t) + " face " + std::to_string(f) + " is paired with its own tet or out of range");
      if (o / 4 > t) continue;
      earlier[f] = true;
      if (gate < 0 || t - o / 4 < gate_back) {
        gate = f;
        gate_back = t - o / 4;
      }
    }
    if (gate < 0) {
      out.push_back(static_cast<uint8_t>(kFreeTet));
      for (int i = 0; i < 4; ++i) put_vertex(tet[i]);
      continue;
    }
    const uint32_t gate_face = opposites[4 * t + gate];
    const FaceVertices from = face_of(&tets[4 * size_t{gate_face / 4}], int(gate_face % 4));
    const FaceVertices to = face_of(tet, gate);
    int permutation = -1;
    for (int p = 0; p < 6 && permutation < 0; ++p) {
      if (to[0] == from[kPermutation[p][0]] && to[1] == from[kPermutation[p][1]] && to[2] == from[kPermutation[p][2]]) permutation = p;
    }
    if (permutation < 0) throw std::invalid_argument("encode_tets: tet " + std::to_string(t) + " face " + std::to_string(gate) + " and its opposite have different vertices");
    uint32_t mask = 0;
    for (int f = 0, bit = 0; f < 4; ++f) {
      if (f == gate) continue;
      if (earlier[f]) mask |= 1u << bit;
      ++bit;
    }
    out.push_back(static_cast<uint8_t>((gate * 6 + permutation) | mask << 5));
    put_varint(out, (gate_back - 1) << 2 | (gate_face % 4));
    const uint32_t free = tet[gate];
    bool first = true;
    for (int f = 0; f < 4; ++f) {
      if (f == gate || !earlier[f]) continue;
      const uint32_t o = opposites[4 * t + f];
      const uint64_t ref = (t - o / 4 - 1) << 2 | (o % 4);
      if (!first) {
        put_varint(out, ref);
        continue;
      }
      // face f holds vertex `gate`, so the face it meets does too
      const FaceVertices across = face_of(&tets[4 * size_t{o / 4}], int(o % 4));
      const uint64_t slot = across[0] == free ? 0 : across[1] == free ? 1 : across[2] == free ? 2 : 3;
      if (slot == 3) throw std::invalid_argument("encode_tets: tet " + std::to_string(t) + " face " + std::to_string(f) + " and its opposite have different vertices");
      put_varint(out, ref << 2 | slot);
      first = false;
    }
    if (mask != 0) continue;
    uint32_t recent = 0;
    for (uint32_t k = 1; k <= kRecentTets && k <= t && recent == 0; ++k)
      for (uint32_t s = 0; s < 4 && recent == 0; ++s)
        if (tets[4 * (t - k) + s] == free) recent = (k - 1) * 4 + s + 1;
    out.push_back(static_cast<uint8_t>(recent));
    if (recent == 0) put_vertex(free);
  }
}

namespace {

// The three ids of a face sorted, to compare faces whatever their orientation.
inline FaceVertices sorted(FaceVertices f) {
  if (f[0] > f[1]) std::swap(f[0], f[1]);
  if (f[1] > f[2]) std::swap(f[1], f[2]);
  if (f[0] > f[1]) std::swap(f[0], f[1]);
  return f;
}

// The most bytes one tet takes (a free tet: a byte and four 5-byte varints); the last tets are
// decoded from a zero-padded copy, so that the loop reads without a bounds check a byte.
constexpr size_t kMaxTetBytes = 1 + 4 * kMaxVarintBytes;
constexpr size_t kTailPadding = 2 * kMaxTetBytes;

// Reads a varint of at most kMaxVarintBytes; the caller guarantees that many readable bytes.
inline bool read_varint(const uint8_t*& p, uint64_t& value) {
  uint8_t b = *p++;
  value = b & 0x7Fu;
  if (b < 0x80) [[likely]] return true;
  for (int i = 1; i < kMaxVarintBytes; ++i) {
    b = *p++;
    value |= uint64_t{b & 0x7Fu} << (7 * i);
    if (b < 0x80) return true;
  }
  return false;
}

}  // namespace

std::string decode_tets(std::span<const uint8_t> stream, uint32_t vertex_count, uint32_t tet_count, std::span<const BorderLink> links,
                        std::span<uint32_t> tets, std::span<uint32_t> opposites) {
  if (tets.size() != 4 * uint64_t{tet_count} || opposites.size() != tets.size()) return "decode_tets: output spans of the wrong size";
  std::fill(opposites.begin(), opposites.end(), kMeshBoundary);
  const uint8_t* p = stream.data();
  const uint8_t* end = p + stream.size();
  uint8_t tail[kMaxTetBytes + kTailPadding] = {};
  bool in_tail = false;
  uint32_t last = 0;
  uint32_t t = 0;
  // a tet that ran into the zero padding is a truncated stream, whatever the zeros then said
  auto fail = [&](const std::string& what) { return "tet " + std::to_string(t) + ": " + (in_tail && p > end ? std::string("stream ends early") : what); };
  uint32_t* const out = tets.data();
  uint32_t* const opposite = opposites.data();
  for (; t < tet_count; ++t) {
    if (static_cast<size_t>(end - p) < kMaxTetBytes && !in_tail) {
      // fewer bytes left than a tet may take: go on in the zero-padded copy
      const size_t left = static_cast<size_t>(end - p);
      std::copy(p, end, tail);
      p = tail;
      end = tail + left;
      in_tail = true;
    }
    if (p >= end) [[unlikely]] return fail("stream ends early");
    uint32_t* tet = out + 4 * size_t{t};
    const uint32_t code = *p & 31u, mask = *p >> 5;
    ++p;
    uint64_t ref;
    if (code == kFreeTet) [[unlikely]] {
      if (mask != 0) return fail("a tet without neighbours names earlier faces");
      for (int i = 0; i < 4; ++i) {
        if (!read_varint(p, ref)) return fail("varint longer than " + std::to_string(kMaxVarintBytes) + " bytes");
        const int64_t value = int64_t{last} + unzigzag(ref);
        if (value < 0 || value >= int64_t{vertex_count}) return fail("vertex " + std::to_string(value) + " out of range (" + std::to_string(vertex_count) + " vertices)");
        tet[i] = last = static_cast<uint32_t>(value);
      }
      if (p > end) return fail("stream ends early");
      continue;
    }
    if (code >= kGateCodes) [[unlikely]] return fail("unknown symbol " + std::to_string(code));
    const int gate = int(code / 6);
    const uint8_t* permutation = kPermutation[code % 6];
    // the gate: (back - 1) << 2 | f'
    if (!read_varint(p, ref)) [[unlikely]] return fail("varint longer than " + std::to_string(kMaxVarintBytes) + " bytes");
    if ((ref >> 2) >= t) [[unlikely]] return fail("refers to tet " + std::to_string((ref >> 2) + 1) + " back, before the first");
    const uint32_t gate_face = static_cast<uint32_t>(4 * (t - (ref >> 2) - 1) + (ref & 3));
    const uint32_t* from = out + 4 * size_t{gate_face / 4};
    const int* from_face = kTetFace[gate_face % 4];
    const uint32_t a[3] = {from[from_face[0]], from[from_face[1]], from[from_face[2]]};
    tet[kTetFace[gate][0]] = a[permutation[0]];
    tet[kTetFace[gate][1]] = a[permutation[1]];
    tet[kTetFace[gate][2]] = a[permutation[2]];
    if (opposite[gate_face] != kMeshBoundary) [[unlikely]] return fail("face " + std::to_string(gate_face) + " is paired twice");
    opposite[gate_face] = 4 * t + uint32_t(gate);
    opposite[4 * t + uint32_t(gate)] = gate_face;
    if (mask == 0) {
      if (p >= end) [[unlikely]] return fail("stream ends early");
      const uint32_t recent = *p++;
      if (recent == 0) {
        if (!read_varint(p, ref)) [[unlikely]] return fail("varint longer than " + std::to_string(kMaxVarintBytes) + " bytes");
        const int64_t value = int64_t{last} + unzigzag(ref);
        if (value < 0 || value >= int64_t{vertex_count}) [[unlikely]] return fail("vertex " + std::to_string(value) + " out of range (" + std::to_string(vertex_count) + " vertices)");
        tet[gate] = last = static_cast<uint32_t>(value);
      } else {
        const uint32_t back = (recent - 1) / 4 + 1;
        if (recent > kRecentCodes || back > t) [[unlikely]] return fail("free vertex refers to tet " + std::to_string(back) + " back, before the first");
        tet[gate] = out[4 * size_t{t - back} + (recent - 1) % 4];
      }
      if (p > end) [[unlikely]] return fail("stream ends early");
      continue;
    }
    // the other faces that meet earlier tets; the first names the free vertex
    bool first = true;
    for (int f = 0, bit = 0; f < 4; ++f) {
      if (f == gate) continue;
      if (!(mask >> bit++ & 1)) continue;
      if (!read_varint(p, ref)) [[unlikely]] return fail("varint longer than " + std::to_string(kMaxVarintBytes) + " bytes");
      uint32_t slot = 0;
      if (first) {
        slot = ref & 3;
        ref >>= 2;
        if (slot == 3) [[unlikely]] return fail("free vertex in slot 3 of a face");
      }
      if ((ref >> 2) >= t) [[unlikely]] return fail("refers to tet " + std::to_string((ref >> 2) + 1) + " back, before the first");
      const uint32_t face = static_cast<uint32_t>(4 * (t - (ref >> 2) - 1) + (ref & 3));
      const uint32_t* across = out + 4 * size_t{face / 4};
      const int* across_face = kTetFace[face % 4];
      if (first) {
        tet[gate] = across[across_face[slot]];
        first = false;
      }
      const FaceVertices here = {tet[kTetFace[f][0]], tet[kTetFace[f][1]], tet[kTetFace[f][2]]};
      const FaceVertices there = {across[across_face[0]], across[across_face[1]], across[across_face[2]]};
      if (sorted(here) != sorted(there)) [[unlikely]] return fail("face " + std::to_string(f) + " is paired with a face of other vertices");
      if (opposite[face] != kMeshBoundary) [[unlikely]] return fail("face " + std::to_string(face) + " is paired twice");
      opposite[face] = 4 * t + uint32_t(f);
      opposite[4 * t + uint32_t(f)] = face;
    }
    if (p > end) [[unlikely]] return fail("stream ends early");
  }
  if (p != end) return "stream has " + std::to_string(end - p) + " bytes after the last tet";
  for (size_t k = 0; k < links.size(); ++k) {
    const uint32_t face = links[k].face;
    if (face >= opposites.size()) return "link " + std::to_string(k) + ": face " + std::to_string(face) + " out of range";
    if (opposites[face] != kMeshBoundary) return "link " + std::to_string(k) + ": face " + std::to_string(face) + " is inside the segment";
    opposites[face] = kSegmentBorder;
  }
  return {};
}

}  // namespace tetrascope::storage
