// The coding of vertices.bin's sections (version 2) and the links a reader derives instead of
// reading them: see hierarchy_codec.cpp.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tetrascope/lod/vertex/vertex_hierarchy.h"

namespace tetrascope::lod::vertex_codec {

// How a section's bytes are kept: as they are, or deflated after a transform.
enum class Codec : uint32_t {
  kRaw = 0,
  kShuffle = 1,  // 32-bit words split into four planes of their bytes, deflated
  kVarint = 2,   // unsigned LEB128 numbers (what remains of a value after its prediction), deflated
};

// A section as written: its codec, its bytes before deflating (the header records them), the
// stored bytes.
struct Coded {
  Codec codec = Codec::kRaw;
  uint64_t raw_bytes = 0;
  std::string stored;
};

Coded raw(std::string bytes);
Coded shuffled(const void* words, size_t count);  // count 32-bit words
Coded varints(const std::vector<uint64_t>& numbers);

// The stored bytes back to the transform's bytes: exactly `raw_bytes` of them, or
// VertexHierarchyError naming `what`. `raw_bytes` is checked against the caller's bound
// before anything is allocated.
std::string inflate(const std::string& stored, uint64_t raw_bytes, uint64_t bound, const char* what);
// The transforms undone: `count` words from four byte planes; `count` numbers from LEB128
// (VertexHierarchyError when the bytes hold more, fewer or an overlong number).
std::vector<uint32_t> unshuffle(const std::string& planes, size_t count, const char* what);
std::vector<uint64_t> read_varints(const std::string& bytes, size_t count, const char* what);

// The collapses' vertices (`width` floats each: 3 positions, or the values) as what remains of
// each float's bits after the mean of its two children (zigzag of the 32-bit difference):
// QEM puts a new vertex near its children's mean, so the high bytes of the rest are mostly
// zero. `vertex_data` holds every vertex (V + C); predict writes the C remainders, restore
// fills the collapses' part of `vertex_data` from them in collapse order (a child is made
// before its parent).
std::vector<uint32_t> predict_collapses(const VertexHierarchy& h, const std::vector<float>& vertex_data, uint32_t width);
void restore_collapses(const VertexHierarchy& h, const std::vector<uint32_t>& remainders, uint32_t width, std::vector<float>& vertex_data);

// The value ranges (per collapse and attribute, lo and hi) as what remains after their
// prediction: the least and greatest of the children's subtree ranges (a leaf's: its own
// value) and the new vertex's value, which the range holds. Needs the values restored.
std::vector<uint32_t> predict_ranges(const VertexHierarchy& h);
void restore_ranges(const std::vector<uint32_t>& remainders, VertexHierarchy& h);

// What version 2 leaves out and a reader derives from the rest: per input tet the collapse that
// removes it (the first at which two of its corners meet: their lowest common ancestor), each
// collapse's fan (the tets it removes) and the `before` links (the inverse of `after`). Needs
// the children checked (check_children); throws VertexHierarchyError for a tet that names a
// vertex twice.
void check_children(const VertexHierarchy& h);
void derive_links(VertexHierarchy& h);

// What a reader of a file with the star links left out derives by replaying the collapses over
// the input's tets: per tet the collapses whose star holds it (those that consume one of its
// corners' current vertices, up to the one that removes it). From them: each tet's removing
// collapse and the fans (as derive_links), each collapse's value ranges (the subtree ranges of
// every vertex of its star, its children's and its own value), its radius (the distance from its
// vertex to the farthest vertex of its star) and its `before` links (the collapses that last
// changed a tet of its star) with `after` their inverse. Needs the children checked and the
// positions and values restored; throws VertexHierarchyError for a tet that names a vertex
// twice.
struct StarLinks {
  std::vector<uint32_t> killer;
  std::vector<uint32_t> fans;  // per collapse
  std::vector<float> ranges;
  std::vector<float> radius;  // per collapse
  std::vector<uint32_t> before_offsets, before, after_offsets, after;
};
StarLinks derive_star_links(const VertexHierarchy& h);
// The hierarchy's own killer, fans, ranges and links are those derive_star_links gives.
bool star_links_match(const VertexHierarchy& h, const StarLinks& derived);

}  // namespace tetrascope::lod::vertex_codec
