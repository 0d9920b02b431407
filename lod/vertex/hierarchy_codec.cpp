// The sections of vertices.bin version 2. Floats and the input's tets are split into the planes
// of their bytes (the high bytes of neighbouring values repeat, so deflate finds them); links are
// written as what remains after their prediction (a child of collapse i is below vertex V + i,
// an `after` link above i), as LEB128, and deflated. The killer of each tet, the fans and the
// `before` links are not written: derive_links finds them again from the tets and the children.
// Nor, where the file's flags say so, the value ranges, the radii and the `after` links:
// derive_star_links replays the collapses over the tets for them.
#include "hierarchy_codec.h"

#include <libdeflate.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>

namespace tetrascope::lod::vertex_codec {
namespace {

constexpr int kDeflateLevel = 6;

std::string deflate(const std::string& bytes) {
  std::unique_ptr<libdeflate_compressor, decltype(&libdeflate_free_compressor)> c(libdeflate_alloc_compressor(kDeflateLevel), &libdeflate_free_compressor);
  if (!c) throw std::runtime_error("vertices.bin: cannot allocate a compressor");
  std::string out(libdeflate_zlib_compress_bound(c.get(), bytes.size()), '\0');
  const size_t n = libdeflate_zlib_compress(c.get(), bytes.data(), bytes.size(), out.data(), out.size());
  if (n == 0) throw std::runtime_error("vertices.bin: compression failed");
  out.resize(n);
  return out;
}

}  // namespace

Coded raw(std::string bytes) {
  Coded c;
  c.raw_bytes = bytes.size();
  c.stored = std::move(bytes);
  return c;
}

Coded shuffled(const void* words, size_t count) {
  const auto* in = static_cast<const uint8_t*>(words);
  std::string planes(4 * count, '\0');
  for (size_t i = 0; i < count; ++i)
    for (size_t b = 0; b < 4; ++b) planes[b * count + i] = static_cast<char>(in[4 * i + b]);
  return {Codec::kShuffle, planes.size(), deflate(planes)};
}

Coded varints(const std::vector<uint64_t>& numbers) {
  std::string bytes;
  bytes.reserve(numbers.size() * 2);
  for (uint64_t x : numbers) {
    while (x >= 0x80) {
      bytes.push_back(static_cast<char>((x & 0x7F) | 0x80));
      x >>= 7;
    }
    bytes.push_back(static_cast<char>(x));
  }
  return {Codec::kVarint, bytes.size(), deflate(bytes)};
}

std::string inflate(const std::string& stored, uint64_t raw_bytes, uint64_t bound, const char* what) {
  if (raw_bytes > bound) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section claims " + std::to_string(raw_bytes) + " bytes, more than its counts allow");
  std::unique_ptr<libdeflate_decompressor, decltype(&libdeflate_free_decompressor)> d(libdeflate_alloc_decompressor(), &libdeflate_free_decompressor);
  if (!d) throw std::runtime_error("vertices.bin: cannot allocate a decompressor");
  std::string out(raw_bytes, '\0');
  size_t got = 0;
  const libdeflate_result rc = libdeflate_zlib_decompress(d.get(), stored.data(), stored.size(), out.data(), out.size(), &got);
  if (rc != LIBDEFLATE_SUCCESS || got != raw_bytes) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section does not inflate to its recorded size");
  return out;
}

std::vector<uint32_t> unshuffle(const std::string& planes, size_t count, const char* what) {
  if (planes.size() != 4 * count) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section has the wrong size");
  std::vector<uint32_t> words(count);
  auto* out = reinterpret_cast<uint8_t*>(words.data());
  for (size_t i = 0; i < count; ++i)
    for (size_t b = 0; b < 4; ++b) out[4 * i + b] = static_cast<uint8_t>(planes[b * count + i]);
  return words;
}

std::vector<uint64_t> read_varints(const std::string& bytes, size_t count, const char* what) {
  std::vector<uint64_t> numbers;
  numbers.reserve(count);
  size_t at = 0;
  while (numbers.size() < count) {
    uint64_t x = 0;
    for (int shift = 0;; shift += 7) {
      if (at == bytes.size() || shift > 56) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section ends inside a number, or holds an overlong one");
      const auto byte = static_cast<uint8_t>(bytes[at++]);
      x |= uint64_t{byte & 0x7Fu} << shift;
      if (!(byte & 0x80)) break;
    }
    numbers.push_back(x);
  }
  if (at != bytes.size()) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section holds more numbers than its counts");
  return numbers;
}

namespace {

uint32_t bits_of(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

float mean_of_children(const VertexHierarchy& h, const std::vector<float>& data, uint32_t width, uint32_t i, uint32_t k) {
  const auto [a, b] = h.nodes[i].child;
  return (data[size_t{a} * width + k] + data[size_t{b} * width + k]) * 0.5f;
}

// The CSR inverse of per-collapse links (offsets, items over 0..C-1): per collapse j the
// collapses i whose lists hold j, each list ascending.
void invert_links(uint32_t C, const std::vector<uint32_t>& offsets, const std::vector<uint32_t>& items, std::vector<uint32_t>& inverse_offsets,
                  std::vector<uint32_t>& inverse) {
  inverse_offsets.assign(size_t{C} + 1, 0);
  for (uint32_t j : items) ++inverse_offsets[j + 1];
  for (uint32_t i = 0; i < C; ++i) inverse_offsets[i + 1] += inverse_offsets[i];
  inverse.assign(items.size(), 0);
  std::vector<uint32_t> fill(inverse_offsets.begin(), inverse_offsets.end() - 1);
  for (uint32_t i = 0; i < C; ++i)
    for (uint32_t k = offsets[i]; k < offsets[i + 1]; ++k) inverse[fill[items[k]]++] = i;
}

uint32_t zigzag(uint32_t actual, uint32_t predicted) {
  const uint32_t rest = actual - predicted;
  return (rest << 1) ^ (0u - (rest >> 31));
}

uint32_t unzigzag(uint32_t z, uint32_t predicted) { return predicted + ((z >> 1) ^ (0u - (z & 1))); }

// The ranges' prediction, collapse by collapse: `visit(i, a, lo, hi)` gets the predicted lo
// and hi of collapse i's attribute a and returns the actual ones, which the later collapses'
// predictions use.
template <class Visit>
void walk_ranges(const VertexHierarchy& h, Visit visit) {
  const uint32_t V = h.input_vertices, C = h.collapse_count(), A = static_cast<uint32_t>(h.attributes.size());
  std::vector<float> own(size_t{A} * (size_t{V} + C));  // each vertex's value per attribute (a vector's length)
  for (uint32_t v = 0; v < V + C; ++v) {
    uint32_t offset = 0;
    for (uint32_t a = 0; a < A; ++a) {
      own[size_t{v} * A + a] = attribute_scalar(&h.values[size_t{v} * h.value_floats + offset], h.attributes[a].components);
      offset += h.attributes[a].components;
    }
  }
  std::vector<float> lo(own), hi(own);  // subtree ranges: a leaf's is its value
  for (uint32_t i = 0; i < C; ++i) {
    const auto [c0, c1] = h.nodes[i].child;
    for (uint32_t a = 0; a < A; ++a) {
      const size_t n = (size_t{V} + i) * A + a;
      const float plo = std::min({lo[size_t{c0} * A + a], lo[size_t{c1} * A + a], own[n]});
      const float phi = std::max({hi[size_t{c0} * A + a], hi[size_t{c1} * A + a], own[n]});
      const auto [l, u] = visit(i, a, plo, phi);
      lo[n] = l;
      hi[n] = u;
    }
  }
}

}  // namespace

std::vector<uint32_t> predict_ranges(const VertexHierarchy& h) {
  std::vector<uint32_t> out(h.ranges.size());
  walk_ranges(h, [&](uint32_t i, uint32_t a, float plo, float phi) {
    const float l = h.range_lo(i, a), u = h.range_hi(i, a);
    const size_t k = 2 * (size_t{i} * h.attributes.size() + a);
    out[k] = zigzag(bits_of(l), bits_of(plo));
    out[k + 1] = zigzag(bits_of(u), bits_of(phi));
    return std::pair{l, u};
  });
  return out;
}

void restore_ranges(const std::vector<uint32_t>& remainders, VertexHierarchy& h) {
  h.ranges.assign(remainders.size(), 0.0f);
  walk_ranges(h, [&](uint32_t i, uint32_t a, float plo, float phi) {
    const size_t k = 2 * (size_t{i} * h.attributes.size() + a);
    const uint32_t l = unzigzag(remainders[k], bits_of(plo)), u = unzigzag(remainders[k + 1], bits_of(phi));
    std::memcpy(&h.ranges[k], &l, 4);
    std::memcpy(&h.ranges[k + 1], &u, 4);
    return std::pair{h.ranges[k], h.ranges[k + 1]};
  });
}

std::vector<uint32_t> predict_collapses(const VertexHierarchy& h, const std::vector<float>& vertex_data, uint32_t width) {
  const uint32_t V = h.input_vertices, C = h.collapse_count();
  std::vector<uint32_t> out(size_t{C} * width);
  for (uint32_t i = 0; i < C; ++i)
    for (uint32_t k = 0; k < width; ++k) {
      out[size_t{i} * width + k] = zigzag(bits_of(vertex_data[(size_t{V} + i) * width + k]), bits_of(mean_of_children(h, vertex_data, width, i, k)));
    }
  return out;
}

void restore_collapses(const VertexHierarchy& h, const std::vector<uint32_t>& remainders, uint32_t width, std::vector<float>& vertex_data) {
  const uint32_t V = h.input_vertices, C = h.collapse_count();
  for (uint32_t i = 0; i < C; ++i)
    for (uint32_t k = 0; k < width; ++k) {
      const uint32_t value = unzigzag(remainders[size_t{i} * width + k], bits_of(mean_of_children(h, vertex_data, width, i, k)));
      std::memcpy(&vertex_data[(size_t{V} + i) * width + k], &value, 4);
    }
}

void check_children(const VertexHierarchy& h) {
  std::vector<uint8_t> consumed(h.vertex_count(), 0);
  for (uint32_t i = 0; i < h.collapse_count(); ++i)
    for (uint32_t child : h.nodes[i].child) {
      if (child >= h.input_vertices + i || consumed[child]) throw VertexHierarchyError("vertices.bin: a collapse's child is out of order or merged twice");
      consumed[child] = 1;
    }
}

void derive_links(VertexHierarchy& h) {
  const uint32_t V = h.input_vertices, C = h.collapse_count();
  std::vector<uint32_t> parent(h.vertex_count(), kNoCollapse);  // the vertex a vertex was merged into
  for (uint32_t i = 0; i < C; ++i)
    for (uint32_t child : h.nodes[i].child) parent[child] = V + i;
  // A vertex's parent has a higher id than it, so climbing from the lower of two vertices meets
  // their lowest common ancestor, the collapse at which they became one.
  auto meet = [&](uint32_t u, uint32_t v) {
    while (u != v) {
      uint32_t& low = u < v ? u : v;
      if (parent[low] == kNoCollapse) return kNoCollapse;
      low = parent[low];
    }
    return u - V;
  };
  const size_t T = h.tets.size() / 4;
  h.killer.assign(T, kNoCollapse);
  for (VertexNode& n : h.nodes) n.fan = 0;
  for (size_t t = 0; t < T; ++t) {
    const uint32_t* s = &h.tets[4 * t];
    uint32_t first = kNoCollapse;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        if (s[a] == s[b]) throw VertexHierarchyError("vertices.bin: tet " + std::to_string(t) + " names a vertex twice");
        first = std::min(first, meet(s[a], s[b]));
      }
    h.killer[t] = first;
    if (first != kNoCollapse) ++h.nodes[first].fan;
  }
  // before: the inverse of after, each list ascending as the build writes it
  invert_links(C, h.after_offsets, h.after, h.before_offsets, h.before);
}

}  // namespace tetrascope::lod::vertex_codec

namespace tetrascope::lod::vertex_codec {
namespace {

// Per vertex and attribute the least and greatest value of the leaves below it and of the
// collapses' own values there (the build's subtree ranges): lo, hi interleaved.
std::vector<float> subtree_ranges(const VertexHierarchy& h) {
  const uint32_t V = h.input_vertices, C = h.collapse_count(), A = static_cast<uint32_t>(h.attributes.size());
  std::vector<float> out(2 * size_t{A} * (size_t{V} + C));
  for (uint32_t v = 0; v < V + C; ++v) {
    uint32_t offset = 0;
    for (uint32_t a = 0; a < A; ++a) {
      float* r = &out[2 * (size_t{v} * A + a)];
      r[0] = r[1] = attribute_scalar(&h.values[size_t{v} * h.value_floats + offset], h.attributes[a].components);
      offset += h.attributes[a].components;
      if (v < V) continue;
      for (uint32_t child : h.nodes[v - V].child) {
        r[0] = std::min(r[0], out[2 * (size_t{child} * A + a)]);
        r[1] = std::max(r[1], out[2 * (size_t{child} * A + a) + 1]);
      }
    }
  }
  return out;
}

// Per collapse its `before` links from the (collapse, earlier collapse) pairs of the replay, each
// list ascending without repeats; `after` their inverse, each list ascending.
void links_from_pairs(uint32_t C, const std::vector<uint64_t>& pairs, StarLinks& out) {
  std::vector<uint32_t> start(size_t{C} + 1, 0), items(pairs.size());
  for (uint64_t p : pairs) ++start[(p >> 32) + 1];
  for (uint32_t i = 0; i < C; ++i) start[i + 1] += start[i];
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (uint64_t p : pairs) items[fill[p >> 32]++] = static_cast<uint32_t>(p);
  out.before_offsets.assign(size_t{C} + 1, 0);
  out.before.clear();
  for (uint32_t i = 0; i < C; ++i) {
    auto first = items.begin() + start[i], last = items.begin() + start[i + 1];
    std::sort(first, last);
    out.before.insert(out.before.end(), first, std::unique(first, last));
    out.before_offsets[i + 1] = static_cast<uint32_t>(out.before.size());
  }
  invert_links(C, out.before_offsets, out.before, out.after_offsets, out.after);
}

}  // namespace

StarLinks derive_star_links(const VertexHierarchy& h) {
  const uint32_t V = h.input_vertices, C = h.collapse_count(), A = static_cast<uint32_t>(h.attributes.size());
  std::vector<uint32_t> consumer(h.vertex_count(), kNoCollapse);  // the collapse that consumes a vertex
  for (uint32_t i = 0; i < C; ++i)
    for (uint32_t child : h.nodes[i].child) consumer[child] = i;
  const std::vector<float> subtree = subtree_ranges(h);
  StarLinks out;
  out.ranges.assign(subtree.begin() + 2 * size_t{A} * V, subtree.end());  // the children's and the own value
  const size_t T = h.tets.size() / 4;
  out.killer.assign(T, kNoCollapse);
  out.fans.assign(C, 0);
  std::vector<double> radius2(C, 0.0);  // as the build sums it: float differences, double squares
  std::vector<uint64_t> pairs;  // (collapse << 32) | the collapse that last changed a tet of its star
  pairs.reserve(8 * T);
  for (size_t t = 0; t < T; ++t) {
    uint32_t cur[4];
    for (int k = 0; k < 4; ++k) cur[k] = h.tets[4 * t + k];
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        if (cur[a] == cur[b]) throw VertexHierarchyError("vertices.bin: tet " + std::to_string(t) + " names a vertex twice");
    // the collapses that touch the tet come in the order they were made: each consumes the
    // current vertex of one of its corners, and the one that consumes two removes it
    for (uint32_t last = kNoCollapse;;) {
      const uint32_t i = std::min({consumer[cur[0]], consumer[cur[1]], consumer[cur[2]], consumer[cur[3]]});
      if (i == kNoCollapse) break;
      float* range = out.ranges.data() + 2 * size_t{i} * A;  // no attributes: never read
      const float* centre = &h.positions[3 * (size_t{V} + i)];
      for (int k = 0; k < 4; ++k) {
        for (uint32_t a = 0; a < A; ++a) {
          range[2 * a] = std::min(range[2 * a], subtree[2 * (size_t{cur[k]} * A + a)]);
          range[2 * a + 1] = std::max(range[2 * a + 1], subtree[2 * (size_t{cur[k]} * A + a) + 1]);
        }
        const float* p = &h.positions[3 * size_t{cur[k]}];
        radius2[i] = std::max(radius2[i], double(p[0] - centre[0]) * (p[0] - centre[0]) + double(p[1] - centre[1]) * (p[1] - centre[1]) + double(p[2] - centre[2]) * (p[2] - centre[2]));
      }
      if (last != kNoCollapse) pairs.push_back(uint64_t{i} << 32 | last);
      int consumed = 0;
      for (int k = 0; k < 4; ++k)
        if (consumer[cur[k]] == i) {
          cur[k] = V + i;
          ++consumed;
        }
      if (consumed > 1) {
        out.killer[t] = i;
        ++out.fans[i];
        break;
      }
      last = i;
    }
  }
  out.radius.resize(C);
  for (uint32_t i = 0; i < C; ++i) out.radius[i] = static_cast<float>(std::sqrt(radius2[i]));
  links_from_pairs(C, pairs, out);
  return out;
}

bool star_links_match(const VertexHierarchy& h, const StarLinks& d) {
  if (d.killer != h.killer || d.before_offsets != h.before_offsets || d.before != h.before || d.after_offsets != h.after_offsets || d.after != h.after) return false;
  if (d.ranges.size() != h.ranges.size() || d.fans.size() != h.nodes.size()) return false;
  for (size_t i = 0; i < d.fans.size(); ++i)
    if (d.fans[i] != h.nodes[i].fan || d.radius[i] != h.nodes[i].radius) return false;
  // by value: the least of 0 and -0 is whichever came first
  for (size_t k = 0; k < d.ranges.size(); ++k)
    if (!(d.ranges[k] == h.ranges[k])) return false;
  return true;
}

}  // namespace tetrascope::lod::vertex_codec
