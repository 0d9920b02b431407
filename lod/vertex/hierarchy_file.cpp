// vertices.bin, the binary vertex hierarchy in a store. Little-endian:
//   header  "TSVERTH1", u32 version (1), u32 input vertices, u32 collapses, u32 attributes,
//           u32 value floats, u32 sections (11), u64 input tets, then per section u64 offset,
//           u64 bytes, u32 CRC-32, and last the header's own CRC-32 (of every byte before it)
//   sections  0 attributes (per attribute: u32 components, u32 name length, the name),
//             1 positions (f32 × 3 per vertex), 2 values (f32 × value floats per vertex),
//             3 tets (u32 × 4 per input tet), 4 killer (u32 per input tet),
//             5 nodes (u32 child × 2, f32 error, f32 radius, u32 fan per collapse),
//             6 ranges (f32 lo, hi per collapse and attribute), 7 after offsets, 8 after,
//             9 before offsets, 10 before (u32 each)
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>
#include <fstream>
#include <system_error>

#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::lod {
namespace {

constexpr char kMagic[8] = {'T', 'S', 'V', 'E', 'R', 'T', 'H', '1'};
constexpr uint32_t kVersion = 1, kSections = 11;
constexpr size_t kHeaderFixed = 8 + 6 * 4 + 8;
constexpr size_t kSectionEntry = 8 + 8 + 4;
constexpr size_t kHeaderBytes = kHeaderFixed + kSections * kSectionEntry + 4;
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

void write_vertex_hierarchy(const std::filesystem::path& path, const VertexHierarchy& h) {
  std::string names;
  for (const auto& a : h.attributes) {
    put<uint32_t>(names, a.components);
    put<uint32_t>(names, static_cast<uint32_t>(a.name.size()));
    names += a.name;
  }
  const std::string sections[kSections] = {names, bytes_of(h.positions), bytes_of(h.values), bytes_of(h.tets), bytes_of(h.killer), bytes_of(h.nodes),
                                           bytes_of(h.ranges), bytes_of(h.after_offsets), bytes_of(h.after), bytes_of(h.before_offsets), bytes_of(h.before)};
  std::string header(kMagic, 8);
  for (uint32_t v : {kVersion, h.input_vertices, h.collapse_count(), static_cast<uint32_t>(h.attributes.size()), h.value_floats, kSections}) put(header, v);
  put<uint64_t>(header, h.input_tets());
  uint64_t offset = kHeaderBytes;
  for (const std::string& s : sections) {
    put<uint64_t>(header, offset);
    put<uint64_t>(header, s.size());
    put<uint32_t>(header, storage::crc32_of(s.data(), s.size()));
    offset += s.size();
  }
  put<uint32_t>(header, storage::crc32_of(header.data(), header.size()));
  const std::filesystem::path temporary = path.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write " + temporary.string());
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    for (const std::string& s : sections) out.write(s.data(), static_cast<std::streamsize>(s.size()));
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + temporary.string() + " (disk full?)");
  }
  std::filesystem::rename(temporary, path);
}

VertexHierarchy read_vertex_hierarchy(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (data.size() < kHeaderBytes || std::memcmp(data.data(), kMagic, 8) != 0) throw VertexHierarchyError("vertices.bin: not a vertex hierarchy, or its header is truncated");
  uint32_t stored_crc;
  std::memcpy(&stored_crc, data.data() + kHeaderBytes - 4, 4);
  if (storage::crc32_of(data.data(), kHeaderBytes - 4) != stored_crc) throw VertexHierarchyError("vertices.bin: the header fails its checksum");
  Reader r{data, 8};
  const uint32_t version = r.get<uint32_t>();
  if (version != kVersion) throw VertexHierarchyError("vertices.bin: version " + std::to_string(version) + " (this build reads " + std::to_string(kVersion) + ")");
  VertexHierarchy h;
  h.input_vertices = r.get<uint32_t>();
  const uint32_t collapses = r.get<uint32_t>(), attributes = r.get<uint32_t>();
  h.value_floats = r.get<uint32_t>();
  if (r.get<uint32_t>() != kSections) throw VertexHierarchyError("vertices.bin: unexpected section count");
  const uint64_t input_tets = r.get<uint64_t>();
  std::string sections[kSections];
  for (uint32_t s = 0; s < kSections; ++s) {
    const uint64_t offset = r.get<uint64_t>(), bytes = r.get<uint64_t>();
    const uint32_t crc = r.get<uint32_t>();
    if (offset > data.size() || bytes > data.size() - offset) throw VertexHierarchyError("vertices.bin: truncated (section " + std::to_string(s) + " runs past the end)");
    sections[s] = data.substr(offset, bytes);
    if (storage::crc32_of(sections[s].data(), sections[s].size()) != crc) throw VertexHierarchyError("vertices.bin: section " + std::to_string(s) + " fails its checksum");
  }
  const uint64_t vertices = uint64_t{h.input_vertices} + collapses;
  if (vertices > 0xFFFFFFF0ull || input_tets > (uint64_t{1} << 40) || attributes > 4096) throw VertexHierarchyError("vertices.bin: counts out of range");
  Reader names{sections[0]};
  uint32_t floats = 0;
  for (uint32_t a = 0; a < attributes; ++a) {
    storage::AttributeInfo info;
    info.components = names.get<uint32_t>();
    const uint32_t length = names.get<uint32_t>();
    if (info.components == 0 || info.components > 16 || length > sections[0].size() - names.at) throw VertexHierarchyError("vertices.bin: a bad attribute entry");
    info.name = sections[0].substr(names.at, length);
    names.at += length;
    floats += info.components;
    h.attributes.push_back(std::move(info));
  }
  if (floats != h.value_floats) throw VertexHierarchyError("vertices.bin: the attributes' components do not add up");
  take(sections[1], h.positions, 3 * vertices, "positions");
  take(sections[2], h.values, uint64_t{h.value_floats} * vertices, "values");
  take(sections[3], h.tets, 4 * input_tets, "tets");
  take(sections[4], h.killer, input_tets, "killer");
  take(sections[5], h.nodes, collapses, "nodes");
  take(sections[6], h.ranges, 2ull * collapses * attributes, "ranges");
  take(sections[7], h.after_offsets, uint64_t{collapses} + 1, "after offsets");
  take(sections[8], h.after, sections[8].size() / 4, "after");
  take(sections[9], h.before_offsets, uint64_t{collapses} + 1, "before offsets");
  take(sections[10], h.before, sections[10].size() / 4, "before");
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
