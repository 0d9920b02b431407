// vertices.bin, the binary vertex hierarchy in a store. Little-endian:
//   header  "TSVERTH1", u32 version, u32 input vertices, u32 collapses, u32 attributes,
//           u32 value floats, u32 sections, u64 input tets, (version 2) u32 flags (1: the
//           input's vertices, 2: the input's tets are left to the store's finest segments and
//           their sections hold the collapses' vertices alone, or nothing; 4: the ranges, after
//           counts and after sections are empty and section 5 holds the errors alone, the
//           radii, ranges and after links derived from the tets and the children), then
//           per section (version 2) u64
//           offset, u64 stored bytes, u64 bytes before deflating, u32 codec, u32 CRC-32 of the
//           stored bytes (version 1: u64 offset, u64 bytes, u32 CRC-32), and last the header's
//           own CRC-32 (of every byte before it)
//   version 2 (written), sections coded as hierarchy_codec.cpp says:
//             0 attributes (per attribute: u32 components, u32 name length, the name; raw),
//             1 positions (f32 × 3 per vertex), 2 values (f32 × value floats per vertex):
//             the input's vertices, then the collapses' as the zigzag of their bits less
//             those of their children's mean; 3 tets (u32 × 4 per input tet), all three in
//             byte planes;
//             4 children (per collapse i two numbers, V + i - 1 - child),
//             5 error and radius (f32 × 2 per collapse, byte planes),
//             6 ranges (f32 lo, hi per collapse and attribute, as the rest after their
//             prediction from the children's, byte planes), 7 after counts (one number per
//             collapse), 8 after (per collapse i its ascending links j as j - previous - 1,
//             previous starting at i); the killer of each tet, the fans and the before links are derived
//   version 1 (read), sections as they are in memory: 0 attributes, 1 positions, 2 values,
//             3 tets, 4 killer (u32 per input tet), 5 nodes (u32 child × 2, f32 error,
//             f32 radius, u32 fan per collapse), 6 ranges, 7 after offsets, 8 after,
//             9 before offsets, 10 before (u32 each)
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>
#include <fstream>
#include <system_error>

#include "hierarchy_codec.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::lod {
namespace {

constexpr char kMagic[8] = {'T', 'S', 'V', 'E', 'R', 'T', 'H', '1'};
constexpr size_t kHeaderFixed = 8 + 6 * 4 + 8;  // version 2 adds a u32 of flags after it
// the flags: the input's vertices, or its tets, are read from the segments.bin beside the file
constexpr uint32_t kLeavesInStore = 1, kTetsInStore = 2;
// the value ranges and the after links are left out: a reader replays the collapses for them
constexpr uint32_t kStarLinksDerived = 4;
// per version: its sections and the bytes of a section's entry in the header
constexpr uint32_t sections_of(uint32_t version) { return version == 1 ? 11 : 9; }
constexpr size_t entry_bytes(uint32_t version) { return version == 1 ? 8 + 8 + 4 : 8 + 8 + 8 + 4 + 4; }
constexpr size_t header_bytes(uint32_t version) { return kHeaderFixed + (version == 1 ? 0 : 4) + sections_of(version) * entry_bytes(version) + 4; }
static_assert(sizeof(VertexNode) == 20);

template <class T>
std::string bytes_of(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

template <class T>
void put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

struct Reader {
  const std::string& data;
  size_t at = 0;
  template <class T>
  T get() {
    if (at + sizeof(T) > data.size()) throw VertexHierarchyError("vertices.bin: the header is truncated");
    T value;
    std::memcpy(&value, data.data() + at, sizeof(T));
    at += sizeof(T);
    return value;
  }
};

template <class T>
void take(const std::string& section, std::vector<T>& out, uint64_t count, const char* what) {
  if (section.size() != count * sizeof(T)) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section has the wrong size");
  out.resize(count);
  if (count) std::memcpy(out.data(), section.data(), section.size());
}

void check_offsets(const std::vector<uint32_t>& offsets, size_t items, const char* what) {
  for (size_t i = 0; i + 1 < offsets.size(); ++i)
    if (offsets[i] > offsets[i + 1]) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " offsets decrease");
  if (offsets.empty() || offsets.front() != 0 || offsets.back() != items) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " offsets do not cover their links");
}

// Links out of range would index past the arrays at run time: refused here.
void check_links(const VertexHierarchy& h) {
  const uint32_t C = h.collapse_count(), N = h.vertex_count();
  for (uint32_t v : h.tets)
    if (v >= h.input_vertices) throw VertexHierarchyError("vertices.bin: a tet names a vertex out of range");
  for (uint32_t k : h.killer)
    if (k != kNoCollapse && k >= C) throw VertexHierarchyError("vertices.bin: a tet's collapse is out of range");
  std::vector<uint8_t> consumed(N, 0);
  for (uint32_t i = 0; i < C; ++i)
    for (uint32_t child : h.nodes[i].child) {
      if (child >= h.input_vertices + i || consumed[child]) throw VertexHierarchyError("vertices.bin: a collapse's child is out of order or merged twice");
      consumed[child] = 1;
    }
  check_offsets(h.after_offsets, h.after.size(), "after");
  check_offsets(h.before_offsets, h.before.size(), "before");
  for (uint32_t i = 0; i < C; ++i) {
    for (uint32_t k = h.after_offsets[i]; k < h.after_offsets[i + 1]; ++k)
      if (h.after[k] <= i || h.after[k] >= C) throw VertexHierarchyError("vertices.bin: an after link is out of order");
    for (uint32_t k = h.before_offsets[i]; k < h.before_offsets[i + 1]; ++k)
      if (h.before[k] >= i) throw VertexHierarchyError("vertices.bin: a before link is out of order");
  }
  uint64_t fans = 0;
  for (const VertexNode& n : h.nodes) fans += n.fan;
  if (fans + h.base_tets() != h.input_tets()) throw VertexHierarchyError("vertices.bin: the fans do not add up to the input's tets");
}

}  // namespace

namespace {

namespace vc = vertex_codec;

std::string attribute_names(const VertexHierarchy& h) {
  std::string names;
  for (const auto& a : h.attributes) {
    put<uint32_t>(names, a.components);
    put<uint32_t>(names, static_cast<uint32_t>(a.name.size()));
    names += a.name;
  }
  return names;
}

std::vector<vc::Coded> coded_sections(const VertexHierarchy& h, uint32_t version, uint32_t flags) {
  if (version == 1) {
    std::vector<vc::Coded> out;
    for (std::string bytes : {attribute_names(h), bytes_of(h.positions), bytes_of(h.values), bytes_of(h.tets), bytes_of(h.killer), bytes_of(h.nodes), bytes_of(h.ranges),
                              bytes_of(h.after_offsets), bytes_of(h.after), bytes_of(h.before_offsets), bytes_of(h.before)})
      out.push_back(vc::raw(std::move(bytes)));
    return out;
  }
  const uint32_t V = h.input_vertices, C = h.collapse_count();
  std::vector<uint64_t> children, counts, after;
  std::vector<float> error_radius;
  for (uint32_t i = 0; i < C; ++i) {
    for (uint32_t child : h.nodes[i].child) children.push_back(uint64_t{V} + i - 1 - child);
    error_radius.insert(error_radius.end(), {h.nodes[i].error, h.nodes[i].radius});
    counts.push_back(h.after_offsets[i + 1] - h.after_offsets[i]);
    for (uint32_t k = h.after_offsets[i], previous = i; k < h.after_offsets[i + 1]; previous = h.after[k++]) {
      if (h.after[k] <= previous) throw std::invalid_argument("vertices.bin: the after links of a collapse are not ascending");
      after.push_back(uint64_t{h.after[k]} - previous - 1);
    }
  }
  std::vector<vc::Coded> out;
  out.push_back(vc::raw(attribute_names(h)));
  // the vertices written: the input's (unless the store has them), then the collapses' as
  // what remains after their children's mean
  for (const auto& [data, width] : {std::pair{&h.positions, 3u}, std::pair{&h.values, h.value_floats}}) {
    std::vector<uint32_t> words;
    if (!(flags & kLeavesInStore)) words.assign(reinterpret_cast<const uint32_t*>(data->data()), reinterpret_cast<const uint32_t*>(data->data()) + size_t{V} * width);
    const std::vector<uint32_t> rest = vc::predict_collapses(h, *data, width);
    words.insert(words.end(), rest.begin(), rest.end());
    out.push_back(vc::shuffled(words.data(), words.size()));
  }
  out.push_back(vc::shuffled(h.tets.data(), flags & kTetsInStore ? 0 : h.tets.size()));
  out.push_back(vc::varints(children));
  if (flags & kStarLinksDerived) {  // the errors alone, the radii derived
    std::vector<float> errors(C);
    for (uint32_t i = 0; i < C; ++i) errors[i] = h.nodes[i].error;
    out.push_back(vc::shuffled(errors.data(), errors.size()));
    out.push_back(vc::shuffled(nullptr, 0));
    out.push_back(vc::varints({}));
    out.push_back(vc::varints({}));
    return out;
  }
  out.push_back(vc::shuffled(error_radius.data(), error_radius.size()));
  const std::vector<uint32_t> ranges = vc::predict_ranges(h);
  out.push_back(vc::shuffled(ranges.data(), ranges.size()));
  out.push_back(vc::varints(counts));
  out.push_back(vc::varints(after));
  return out;
}

struct Section {
  std::string stored;
  uint64_t raw_bytes = 0;
  vc::Codec codec = vc::Codec::kRaw;
};

template <class T>
std::vector<T> words_of(const Section& s, uint64_t count, const char* what) {
  std::vector<T> out;
  if (s.codec != vc::Codec::kShuffle) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section has an unexpected codec");
  const std::vector<uint32_t> words = vc::unshuffle(vc::inflate(s.stored, s.raw_bytes, 4 * count, what), count, what);
  out.resize(count);
  if (count) std::memcpy(out.data(), words.data(), 4 * count);
  return out;
}

std::vector<uint64_t> numbers_of(const Section& s, uint64_t count, const char* what) {
  if (s.codec != vc::Codec::kVarint) throw VertexHierarchyError(std::string("vertices.bin: the ") + what + " section has an unexpected codec");
  return vc::read_varints(vc::inflate(s.stored, s.raw_bytes, 10 * count, what), count, what);
}

void read_attributes(const std::string& section, uint32_t attributes, VertexHierarchy& h) {
  Reader names{section};
  uint32_t floats = 0;
  for (uint32_t a = 0; a < attributes; ++a) {
    storage::AttributeInfo info;
    info.components = names.get<uint32_t>();
    const uint32_t length = names.get<uint32_t>();
    if (info.components == 0 || info.components > 16 || length > section.size() - names.at) throw VertexHierarchyError("vertices.bin: a bad attribute entry");
    info.name = section.substr(names.at, length);
    names.at += length;
    floats += info.components;
    h.attributes.push_back(std::move(info));
  }
  if (floats != h.value_floats) throw VertexHierarchyError("vertices.bin: the attributes' components do not add up");
}

void read_version1(const std::vector<Section>& s, uint32_t collapses, uint64_t input_tets, VertexHierarchy& h) {
  const uint64_t vertices = uint64_t{h.input_vertices} + collapses, attributes = h.attributes.size();
  take(s[1].stored, h.positions, 3 * vertices, "positions");
  take(s[2].stored, h.values, uint64_t{h.value_floats} * vertices, "values");
  take(s[3].stored, h.tets, 4 * input_tets, "tets");
  take(s[4].stored, h.killer, input_tets, "killer");
  take(s[5].stored, h.nodes, collapses, "nodes");
  take(s[6].stored, h.ranges, 2ull * collapses * attributes, "ranges");
  take(s[7].stored, h.after_offsets, uint64_t{collapses} + 1, "after offsets");
  take(s[8].stored, h.after, s[8].stored.size() / 4, "after");
  take(s[9].stored, h.before_offsets, uint64_t{collapses} + 1, "before offsets");
  take(s[10].stored, h.before, s[10].stored.size() / 4, "before");
}

// What a version 2 file leaves to the store beside it, read from the segments of its finest
// level (the input, `multiresolution.levels[0]` of the manifest): the input's vertices
// (positions and values), and the input's tets in the segments' order and orientation.
void read_from_store(const std::filesystem::path& directory, uint32_t flags, uint64_t input_tets, VertexHierarchy& h) {
  const uint32_t V = h.input_vertices, F = h.value_floats;
  auto refuse = [](const std::string& why) { return VertexHierarchyError("vertices.bin: its input mesh is in the store's segments, which " + why); };
  std::unique_ptr<storage::Store> store;
  uint32_t first = 0, count = 0;
  try {
    store = storage::Store::open(directory);
    const auto& level = store->manifest().json.at("multiresolution").at("levels").at(0);
    first = level.at("first_segment").get<uint32_t>();
    count = level.at("segments").get<uint32_t>();
  } catch (const std::exception& e) {
    throw refuse(std::string("cannot be read: ") + e.what());
  }
  uint32_t floats = 0;
  for (const auto& a : store->manifest().attributes) floats += a.components;
  if (floats != F || store->manifest().vertex_count < V || first > store->segment_count() || count > store->segment_count() - first) throw refuse("hold another mesh (a file of another store?)");
  if (flags & kLeavesInStore) {
    h.positions.insert(h.positions.begin(), 3 * size_t{V}, 0.0f);
    h.values.insert(h.values.begin(), size_t{F} * V, 0.0f);
  }
  std::vector<uint8_t> seen(V, 0);
  for (uint32_t segment = first; segment < first + count; ++segment) {
    std::shared_ptr<const storage::MappedSegment> mapped;
    try {
      mapped = store->map_segment(segment);
    } catch (const std::exception& e) {
      throw refuse(std::string("cannot be read: ") + e.what());
    }
    const storage::SegmentView& v = mapped->view();
    if (flags & kTetsInStore) {
      if (h.tets.size() / 4 + v.tet_count > input_tets) throw refuse("hold more tets than the hierarchy's input");
      for (uint32_t local : v.tets) {
        if (v.global_ids[local] >= V) throw refuse("hold a tet of another mesh");
        h.tets.push_back(v.global_ids[local]);
      }
    }
    for (uint32_t l = 0; l < v.vertex_count && (flags & kLeavesInStore); ++l) {
      const uint32_t g = v.global_ids[l];
      if (g >= V || seen[g]) continue;
      seen[g] = 1;
      float* p = &h.positions[3 * size_t{g}];
      p[0] = v.x[l], p[1] = v.y[l], p[2] = v.z[l];
      uint32_t offset = 0;
      for (const auto& a : h.attributes) {
        for (uint32_t k = 0; k < a.components; ++k) h.values[size_t{g} * F + offset + k] = v.attributes[size_t{v.vertex_count} * offset + size_t{l} * a.components + k];
        offset += a.components;
      }
    }
  }
  if ((flags & kLeavesInStore) && std::count(seen.begin(), seen.end(), 0)) throw refuse("lack some of its vertices (a file of another store?)");
  if ((flags & kTetsInStore) && h.tets.size() != 4 * input_tets) throw refuse("hold fewer tets than the hierarchy's input");
}

// Version 2: the sections decoded, their links checked as far as deriving the rest needs, the
// rest derived.
void read_version2(const std::vector<Section>& s, uint32_t collapses, uint64_t input_tets, uint32_t flags, const std::filesystem::path& store, VertexHierarchy& h) {
  const uint32_t V = h.input_vertices, C = collapses;
  const uint64_t written = flags & kLeavesInStore ? C : uint64_t{V} + C;
  std::vector<uint32_t> positions = words_of<uint32_t>(s[1], 3 * written, "positions"), values = words_of<uint32_t>(s[2], uint64_t{h.value_floats} * written, "values");
  // the input's vertices as written (or from the store below), the collapses' once the children are known
  const size_t input_words = flags & kLeavesInStore ? 0 : size_t{V};
  h.positions.resize(3 * input_words);
  if (!h.positions.empty()) std::memcpy(h.positions.data(), positions.data(), h.positions.size() * 4);
  h.values.resize(h.value_floats * input_words);
  if (!h.values.empty()) std::memcpy(h.values.data(), values.data(), h.values.size() * 4);
  h.tets = words_of<uint32_t>(s[3], flags & kTetsInStore ? 0 : 4 * input_tets, "tets");
  if (flags & (kLeavesInStore | kTetsInStore)) read_from_store(store, flags, input_tets, h);
  for (uint32_t v : h.tets)
    if (v >= V) throw VertexHierarchyError("vertices.bin: a tet names a vertex out of range");
  const std::vector<uint64_t> children = numbers_of(s[4], 2ull * C, "children");
  const bool derived = flags & kStarLinksDerived;  // section 5 holds the errors alone
  const std::vector<float> error_radius = words_of<float>(s[5], (derived ? 1ull : 2ull) * C, "error and radius");
  h.nodes.resize(C);
  for (uint32_t i = 0; i < C; ++i) {
    for (int k = 0; k < 2; ++k) {
      const uint64_t below = children[2 * size_t{i} + k];
      if (below >= uint64_t{V} + i) throw VertexHierarchyError("vertices.bin: a collapse's child is out of order or merged twice");
      h.nodes[i].child[k] = static_cast<uint32_t>(uint64_t{V} + i - 1 - below);
    }
    h.nodes[i].error = error_radius[(derived ? 1 : 2) * size_t{i}];
    if (!derived) h.nodes[i].radius = error_radius[2 * size_t{i} + 1];
  }
  vc::check_children(h);
  positions.erase(positions.begin(), positions.begin() + static_cast<std::ptrdiff_t>(3 * input_words));
  values.erase(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(h.value_floats * input_words));
  h.positions.resize(3 * (size_t{V} + C));
  h.values.resize(h.value_floats * (size_t{V} + C));
  vc::restore_collapses(h, positions, 3, h.positions);
  vc::restore_collapses(h, values, h.value_floats, h.values);
  if (derived) {
    if (s[6].raw_bytes || s[7].raw_bytes || s[8].raw_bytes) throw VertexHierarchyError("vertices.bin: the ranges and after sections hold bytes its flags leave out");
    vc::StarLinks d = vc::derive_star_links(h);
    h.killer = std::move(d.killer);
    for (uint32_t i = 0; i < C; ++i) {
      h.nodes[i].fan = d.fans[i];
      h.nodes[i].radius = d.radius[i];
    }
    h.ranges = std::move(d.ranges);
    h.before_offsets = std::move(d.before_offsets);
    h.before = std::move(d.before);
    h.after_offsets = std::move(d.after_offsets);
    h.after = std::move(d.after);
    return;
  }
  vc::restore_ranges(words_of<uint32_t>(s[6], 2ull * C * h.attributes.size(), "ranges"), h);
  const std::vector<uint64_t> counts = numbers_of(s[7], C, "after counts");
  h.after_offsets.assign(size_t{C} + 1, 0);
  for (uint32_t i = 0; i < C; ++i) {
    if (counts[i] > C) throw VertexHierarchyError("vertices.bin: the after offsets do not cover their links");
    h.after_offsets[i + 1] = static_cast<uint32_t>(h.after_offsets[i] + counts[i]);
    if (h.after_offsets[i + 1] < h.after_offsets[i]) throw VertexHierarchyError("vertices.bin: the after offsets do not cover their links");
  }
  const std::vector<uint64_t> after = numbers_of(s[8], h.after_offsets[C], "after");
  h.after.resize(after.size());
  for (uint32_t i = 0; i < C; ++i) {
    uint64_t previous = i;
    for (uint32_t k = h.after_offsets[i]; k < h.after_offsets[i + 1]; ++k) {
      if (after[k] >= uint64_t{C} - previous - 1) throw VertexHierarchyError("vertices.bin: an after link is out of order");
      previous += after[k] + 1;
      h.after[k] = static_cast<uint32_t>(previous);
    }
  }
  vc::derive_links(h);
}

}  // namespace

void write_vertex_hierarchy(const std::filesystem::path& path, const VertexHierarchy& h, const VertexHierarchyWriteOptions& options) {
  const uint32_t version = options.version;
  if (version != 1 && version != kVertexHierarchyVersion) throw std::invalid_argument("vertices.bin: no version " + std::to_string(version));
  uint32_t flags = (options.leaves_in_store ? kLeavesInStore : 0) | (options.tets_in_store ? kTetsInStore : 0);
  if (version == 1 && flags) throw std::invalid_argument("vertices.bin: version 1 holds the input mesh itself");
  // left out only where replaying the collapses gives them back as they are
  if (version != 1 && options.derive_star_links && vc::star_links_match(h, vc::derive_star_links(h))) flags |= kStarLinksDerived;
  const std::vector<vc::Coded> sections = coded_sections(h, version, flags);
  std::string header(kMagic, 8);
  for (uint32_t v : {version, h.input_vertices, h.collapse_count(), static_cast<uint32_t>(h.attributes.size()), h.value_floats, sections_of(version)}) put(header, v);
  put<uint64_t>(header, h.input_tets());
  if (version != 1) put<uint32_t>(header, flags);
  uint64_t offset = header_bytes(version);
  for (const vc::Coded& s : sections) {
    put<uint64_t>(header, offset);
    put<uint64_t>(header, s.stored.size());
    if (version != 1) {
      put<uint64_t>(header, s.raw_bytes);
      put<uint32_t>(header, static_cast<uint32_t>(s.codec));
    }
    put<uint32_t>(header, storage::crc32_of(s.stored.data(), s.stored.size()));
    offset += s.stored.size();
  }
  put<uint32_t>(header, storage::crc32_of(header.data(), header.size()));
  const std::filesystem::path temporary = path.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write " + temporary.string());
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    for (const vc::Coded& s : sections) out.write(s.stored.data(), static_cast<std::streamsize>(s.stored.size()));
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + temporary.string() + " (disk full?)");
  }
  std::filesystem::rename(temporary, path);
}

VertexHierarchy read_vertex_hierarchy(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (data.size() < kHeaderFixed || std::memcmp(data.data(), kMagic, 8) != 0) throw VertexHierarchyError("vertices.bin: not a vertex hierarchy, or its header is truncated");
  Reader r{data, 8};
  const uint32_t version = r.get<uint32_t>();
  if (version != 1 && version != kVertexHierarchyVersion)
    throw VertexHierarchyError("vertices.bin: version " + std::to_string(version) + " (this build reads 1 and " + std::to_string(kVertexHierarchyVersion) + ")");
  const size_t header = header_bytes(version);
  if (data.size() < header) throw VertexHierarchyError("vertices.bin: the header is truncated");
  uint32_t stored_crc;
  std::memcpy(&stored_crc, data.data() + header - 4, 4);
  if (storage::crc32_of(data.data(), header - 4) != stored_crc) throw VertexHierarchyError("vertices.bin: the header fails its checksum");
  VertexHierarchy h;
  h.input_vertices = r.get<uint32_t>();
  const uint32_t collapses = r.get<uint32_t>(), attributes = r.get<uint32_t>();
  h.value_floats = r.get<uint32_t>();
  if (r.get<uint32_t>() != sections_of(version)) throw VertexHierarchyError("vertices.bin: unexpected section count");
  const uint64_t input_tets = r.get<uint64_t>();
  const uint32_t flags = version == 1 ? 0 : r.get<uint32_t>();
  if (flags & ~(kLeavesInStore | kTetsInStore | kStarLinksDerived)) throw VertexHierarchyError("vertices.bin: unknown flags " + std::to_string(flags));
  std::vector<Section> sections(sections_of(version));
  for (uint32_t s = 0; s < sections.size(); ++s) {
    const uint64_t offset = r.get<uint64_t>(), bytes = r.get<uint64_t>();
    if (version != 1) {
      sections[s].raw_bytes = r.get<uint64_t>();
      sections[s].codec = static_cast<vc::Codec>(r.get<uint32_t>());
    }
    const uint32_t crc = r.get<uint32_t>();
    if (offset > data.size() || bytes > data.size() - offset) throw VertexHierarchyError("vertices.bin: truncated (section " + std::to_string(s) + " runs past the end)");
    sections[s].stored = data.substr(offset, bytes);
    if (storage::crc32_of(sections[s].stored.data(), sections[s].stored.size()) != crc) throw VertexHierarchyError("vertices.bin: section " + std::to_string(s) + " fails its checksum");
  }
  const uint64_t vertices = uint64_t{h.input_vertices} + collapses;
  if (vertices > 0xFFFFFFF0ull || input_tets > (uint64_t{1} << 40) || attributes > 4096 || h.value_floats > 16 * attributes) throw VertexHierarchyError("vertices.bin: counts out of range");
  if (sections[0].codec != vc::Codec::kRaw || (version != 1 && sections[0].raw_bytes != sections[0].stored.size())) throw VertexHierarchyError("vertices.bin: the attributes section has an unexpected codec");
  read_attributes(sections[0].stored, attributes, h);
  if (version == 1)
    read_version1(sections, collapses, input_tets, h);
  else
    read_version2(sections, collapses, input_tets, flags, path.parent_path(), h);
  check_links(h);
  return h;
}

std::shared_ptr<const VertexHierarchy> open_vertex_hierarchy(const std::filesystem::path& store_directory) {
  const std::filesystem::path path = store_directory / kVertexHierarchyFile;
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return nullptr;
    throw std::runtime_error("cannot read " + path.string() + ": " + std::strerror(errno));
  }
  // keyed by the file's path, size and status change: a rebuilt store is read again
  const std::string key = path.string() + "|" + std::to_string(st.st_size) + "|" + std::to_string(st.st_ctim.tv_sec) + "." + std::to_string(st.st_ctim.tv_nsec);
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<const VertexHierarchy>> open;
  {
    std::lock_guard lock(mutex);
    std::erase_if(open, [](const auto& entry) { return entry.second.expired(); });
    if (auto it = open.find(key); it != open.end())
      if (auto held = it->second.lock()) return held;
  }
  auto read = std::make_shared<const VertexHierarchy>(read_vertex_hierarchy(path));
  std::lock_guard lock(mutex);
  open[key] = read;
  return read;
}

std::vector<std::string> verify_vertex_hierarchy(const std::filesystem::path& store) {
  const std::filesystem::path path = store / kVertexHierarchyFile;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return {};
  try {
    read_vertex_hierarchy(path);
  } catch (const std::exception& e) {
    return {e.what()};
  }
  return {};
}

}  // namespace tetrascope::lod
