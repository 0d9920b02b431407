// variants.bin (variants.h): written from a spill file at the end of a build, mapped to read,
// checked by verify.
#include "tetrascope/lod/cut/variants.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/storage/store_format.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::lod {

namespace {

constexpr char kMagic[8] = {'T', 'S', 'V', 'A', 'R', 'N', 'T', 'S'};
constexpr uint32_t kVersion = 2;  // 2: a CRC-32 a block

struct FileHeader {
  char magic[8];
  uint32_t version, floats, node_count, entry_count;
  uint64_t index_offset, data_offset, file_bytes;
  uint32_t index_crc, header_crc;
};
static_assert(sizeof(FileHeader) == 56);  // (FileEntry after it stays 8-aligned)

struct FileEntry {
  uint32_t node, rank;
  uint64_t offset, vertices, tets, stream_bytes;  // offset from data_offset
  uint32_t crc, reserved;                         // CRC-32 of the block's bytes (padding included); zero
};
static_assert(sizeof(FileEntry) == 48);

uint64_t vertex_bytes(uint64_t vertices, uint32_t floats) { return vertices * (4 + 12 + 4 * uint64_t{floats}); }
uint64_t block_bytes(uint64_t vertices, uint64_t stream_bytes, uint32_t floats) { return (vertex_bytes(vertices, floats) + stream_bytes + 3) & ~uint64_t{3}; }

[[noreturn]] void io_error(const std::filesystem::path& where, const char* what) {
  throw std::runtime_error(where.string() + ": " + what + ": " + std::strerror(errno));
}

// All `bytes` between `p` and the file at `at`, by ::pread or ::pwrite, however many calls that
// takes (as the build's spill of tets does, mt_node_tets.cpp).
template <class Io, class Pointer>
void whole(Io io, int fd, Pointer p, uint64_t bytes, uint64_t at, const std::filesystem::path& where, const char* failure) {
  while (bytes > 0) {
    const ssize_t done = io(fd, p, bytes, static_cast<off_t>(at));
    if (done < 0 && errno == EINTR) continue;
    if (done <= 0) io_error(where, failure);
    p += done;
    at += static_cast<uint64_t>(done);
    bytes -= static_cast<uint64_t>(done);
  }
}
void write_all(int fd, const void* data, uint64_t bytes, uint64_t at, const std::filesystem::path& where) {
  whole(::pwrite, fd, static_cast<const char*>(data), bytes, at, where, "cannot write");
}
void read_all(int fd, void* data, uint64_t bytes, uint64_t at, const std::filesystem::path& where) {
  whole(::pread, fd, static_cast<char*>(data), bytes, at, where, "cannot read");
}

[[noreturn]] void damaged(const std::string& what) { throw VariantsError("variants.bin: " + what + "; preprocess the mesh again (or delete variants.bin to use the store without them)"); }

}  // namespace

VariantSpill::VariantSpill(std::filesystem::path directory, uint32_t floats) : directory_(std::move(directory)), floats_(floats) {}

VariantSpill::~VariantSpill() {
  if (fd_ >= 0) ::close(fd_);
}

void VariantSpill::add(uint32_t node, const std::vector<VariantMesh>& variants) {
  if (variants.empty()) return;
  if (fd_ < 0) {
    const std::filesystem::path dir = directory_.empty() ? std::filesystem::path(".") : directory_;
    std::string name = (dir / ".tetrascope-variants-XXXXXX").string();
    fd_ = ::mkstemp(name.data());
    if (fd_ < 0) io_error(dir, "cannot create a spill file for the variants");
    ::unlink(name.c_str());  // no name: it goes when the build ends, however it ends
  }
  uint32_t rank = 0;
  for (const VariantMesh& v : variants) {
    const uint64_t nv = v.vertex_count(), nt = v.tet_count();
    if (v.xyz.size() != 3 * nv || v.values.size() != nv * floats_) throw std::logic_error("VariantSpill::add: a variant of the wrong shape");
    // the tets coded as segments.bin codes a segment's: with their face pairs
    pair_faces(v.tets, pairing_, opposite_);
    for (uint32_t& o : opposite_)
      if (o == kNoOppositeFace) o = storage::store::kMeshBoundary;
    stream_.clear();
    storage::encode_tets(v.tets, opposite_, stream_);
    write_all(fd_, v.global.data(), 4 * nv, end_, directory_);
    write_all(fd_, v.xyz.data(), 12 * nv, end_ + 4 * nv, directory_);
    write_all(fd_, v.values.data(), 4 * nv * floats_, end_ + 16 * nv, directory_);
    write_all(fd_, stream_.data(), stream_.size(), end_ + vertex_bytes(nv, floats_), directory_);
    const uint64_t block = block_bytes(nv, stream_.size(), floats_), padding = block - vertex_bytes(nv, floats_) - stream_.size();
    const char zero[4] = {0, 0, 0, 0};
    if (padding) write_all(fd_, zero, padding, end_ + block - padding, directory_);  // the next block starts 4-aligned
    uint32_t crc = storage::crc32_of(v.global.data(), 4 * nv);  // the block's bytes, in file order
    crc = storage::crc32_of(v.xyz.data(), 12 * nv, crc);
    crc = storage::crc32_of(v.values.data(), 4 * nv * floats_, crc);
    crc = storage::crc32_of(stream_.data(), stream_.size(), crc);
    crc = storage::crc32_of(zero, padding, crc);
    entries_.push_back({node, rank++, end_, nv, nt, stream_.size(), crc});
    end_ += block;
    tets_ += nt;
  }
}

uint64_t VariantSpill::write(const std::filesystem::path& file, uint32_t node_count) const {
  std::vector<FileEntry> index;
  index.reserve(entries_.size());
  for (const Entry& e : entries_) {
    if (e.node >= node_count) throw std::logic_error("VariantSpill::write: a variant of a node the DAG lacks");
    index.push_back({e.node, e.rank, e.offset, e.vertices, e.tets, e.stream_bytes, e.crc, 0});
  }
  std::stable_sort(index.begin(), index.end(), [](const FileEntry& a, const FileEntry& b) { return a.node < b.node || (a.node == b.node && a.rank < b.rank); });
  FileHeader h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kVersion;
  h.floats = floats_;
  h.node_count = node_count;
  h.entry_count = static_cast<uint32_t>(index.size());
  h.index_offset = sizeof(FileHeader);
  h.data_offset = (h.index_offset + index.size() * sizeof(FileEntry) + 15) & ~uint64_t{15};
  h.file_bytes = h.data_offset + end_;

  h.index_crc = storage::crc32_of(index.data(), index.size() * sizeof(FileEntry));
  h.header_crc = storage::crc32_of(&h, offsetof(FileHeader, header_crc));
  const int out = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (out < 0) io_error(file, "cannot create");
  try {
    write_all(out, &h, sizeof h, 0, file);
    write_all(out, index.data(), index.size() * sizeof(FileEntry), h.index_offset, file);
    std::vector<char> buffer(1 << 20);
    for (uint64_t at = 0; at < end_; at += buffer.size()) {
      const uint64_t n = std::min<uint64_t>(buffer.size(), end_ - at);
      read_all(fd_, buffer.data(), n, at, directory_);
      write_all(out, buffer.data(), n, h.data_offset + at, file);
    }
    if (::fsync(out) != 0) io_error(file, "cannot flush");
  } catch (...) {
    ::close(out);
    throw;
  }
  ::close(out);
  return h.file_bytes;
}

std::unique_ptr<Variants> Variants::open(const storage::Store& store, const Dag& dag) {
  const std::filesystem::path file = store.path() / "variants.bin";
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) return nullptr;
    io_error(file, "cannot open");
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    io_error(file, "cannot stat");
  }
  const uint64_t length = static_cast<uint64_t>(st.st_size);
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    damaged("not a regular file");
  }
  if (length < sizeof(FileHeader)) {
    ::close(fd);
    damaged("shorter than its header");
  }
  void* address = ::mmap(nullptr, length, PROT_READ, MAP_SHARED, fd, 0);
  ::close(fd);
  if (address == MAP_FAILED) io_error(file, "cannot map");
  std::unique_ptr<Variants> out(new Variants());
  out->address_ = address;
  out->length_ = length;
  const char* base = static_cast<const char*>(address);
  FileHeader h;
  std::memcpy(&h, base, sizeof h);
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) damaged("not a variants file");
  if (h.header_crc != storage::crc32_of(&h, offsetof(FileHeader, header_crc))) damaged("its header is damaged (checksum)");
  if (h.version != kVersion) damaged("version " + std::to_string(h.version) + ", this build reads " + std::to_string(kVersion));
  if (h.file_bytes != length) damaged("its header says " + std::to_string(h.file_bytes) + " bytes, the file has " + std::to_string(length) + " (truncated?)");
  const uint32_t attribute_floats = store.header().floats_per_vertex;
  if (h.floats != attribute_floats) damaged("its vertices carry " + std::to_string(h.floats) + " values, the store's " + std::to_string(attribute_floats));
  if (h.node_count != dag.node_count()) damaged("made for " + std::to_string(h.node_count) + " segments, the DAG has " + std::to_string(dag.node_count()));
  if (h.index_offset != sizeof(FileHeader) || h.data_offset < h.index_offset + uint64_t{h.entry_count} * sizeof(FileEntry) || h.data_offset > length ||
      h.data_offset % 16 != 0)  // (blocks 4-aligned from there: the views read u32 and float)
    damaged("its index lies outside the file");
  const auto* index = reinterpret_cast<const FileEntry*>(base + h.index_offset);
  if (h.index_crc != storage::crc32_of(index, uint64_t{h.entry_count} * sizeof(FileEntry))) damaged("its index is damaged (checksum)");
  out->floats_ = h.floats;
  out->first_.assign(size_t{h.node_count} + 1, 0);
  const uint64_t data = length - h.data_offset;
  for (uint32_t i = 0; i < h.entry_count; ++i) {
    FileEntry e;
    std::memcpy(&e, &index[i], sizeof e);
    if (e.node >= h.node_count) damaged("an entry names segment " + std::to_string(e.node) + " of " + std::to_string(h.node_count));
    if (i > 0 && (e.node < index[i - 1].node)) damaged("its index is out of order");
    const bool same_node = i > 0 && index[i - 1].node == e.node;
    // (the vertices' bytes bound their count below, and every tet takes a byte of the
    // stream at least, so what a view allocates stays within a few times the file)
    if (e.tets == 0 || e.vertices == 0 || e.vertices >= (uint64_t{1} << 32) || e.tets >= (uint64_t{1} << 32) || e.tets > e.stream_bytes)
      damaged("a variant of implausible size");
    if (e.tets <= (same_node ? index[i - 1].tets : uint64_t{dag.node(e.node).tet_count}))
      damaged("the variants of segment " + std::to_string(e.node) + " do not grow from the segment's tets");
    if (e.offset % 4 != 0 || e.offset > data || e.stream_bytes > data || block_bytes(e.vertices, e.stream_bytes, h.floats) > data - e.offset)
      damaged("a variant's block lies outside the file");
    out->entries_.push_back({h.data_offset + e.offset, e.vertices, e.tets, e.stream_bytes, e.crc});
    ++out->first_[e.node + 1];
  }
  out->checked_ = std::make_unique<std::atomic<bool>[]>(out->entries_.size());
  for (size_t n = 1; n < out->first_.size(); ++n) {
    if (out->first_[n] > kMaxVariants) damaged("segment " + std::to_string(n - 1) + " has " + std::to_string(out->first_[n]) + " variants, at most " + std::to_string(kMaxVariants));
    out->first_[n] += out->first_[n - 1];
  }
  return out;
}

Variants::~Variants() {
  if (address_) ::munmap(address_, length_);
}

uint64_t Variants::total_tets() const {
  uint64_t sum = 0;
  for (const Entry& e : entries_) sum += e.tets;
  return sum;
}

VariantView Variants::view(uint32_t node, uint32_t index) const {
  if (index >= count(node)) throw std::out_of_range("Variants::view: segment " + std::to_string(node) + " has no variant " + std::to_string(index));
  const Entry& e = entries_[first_[node] + index];
  const char* p = static_cast<const char*>(address_) + e.offset;
  std::atomic<bool>& checked = checked_[first_[node] + index];
  if (!checked.load(std::memory_order_acquire)) {  // the block's checksum, the first time it is shown
    if (storage::crc32_of(p, block_bytes(e.vertices, e.stream_bytes, floats_)) != e.crc)
      damaged("variant " + std::to_string(index + 1) + " of segment " + std::to_string(node) + ": checksum mismatch");
    checked.store(true, std::memory_order_release);
  }
  VariantView v;
  v.vertex_count = e.vertices;
  v.tet_count = e.tets;
  v.global = {reinterpret_cast<const uint32_t*>(p), e.vertices};
  v.xyz = {reinterpret_cast<const float*>(p + 4 * e.vertices), 3 * e.vertices};
  v.values = {reinterpret_cast<const float*>(p + 16 * e.vertices), e.vertices * floats_};
  const std::span<const uint8_t> stream(reinterpret_cast<const uint8_t*>(p + vertex_bytes(e.vertices, floats_)), e.stream_bytes);
  v.tets.resize(4 * e.tets);
  std::vector<uint32_t> opposites(4 * e.tets);
  const std::string problem = storage::decode_tets(stream, static_cast<uint32_t>(e.vertices), static_cast<uint32_t>(e.tets), {}, v.tets, opposites);
  if (!problem.empty()) damaged("variant " + std::to_string(index + 1) + " of segment " + std::to_string(node) + ": " + problem);
  return v;
}

std::vector<std::string> verify_variants(const storage::Store& store, const Dag& dag) {
  std::vector<std::string> problems;
  std::unique_ptr<Variants> variants;
  try {
    variants = Variants::open(store, dag);
  } catch (const std::exception& e) {
    return {e.what()};
  }
  if (!variants) return problems;
  using Face = FaceVertices;  // by global ids, face_key order
  struct FaceHash {
    size_t operator()(const Face& f) const { return (size_t{f[0]} * 0x9E3779B97F4A7C15ull) ^ (size_t{f[1]} * 0xC2B2AE3D27D4EB4Full) ^ f[2]; }
  };
  for (uint32_t node = 0; node < dag.node_count() && problems.size() < 20; ++node) {
    if (variants->count(node) == 0) continue;
    auto mapped = store.map_segment(node);
    const storage::SegmentView& s = mapped->view();
    // the faces the segment shares with other segments, by global ids, and where its vertices are
    std::vector<Face> border;
    std::unordered_map<uint32_t, std::array<float, 3>> position;
    for (uint32_t t = 0; t < s.tet_count; ++t)
      for (int f = 0; f < 4; ++f) {
        if (s.opposites[4 * size_t{t} + f] != storage::store::kSegmentBorder) continue;
        Face face = tet_face(s.tets, t, f);
        for (uint32_t& id : face) id = s.global_ids[id];
        border.push_back(face_key(face));
      }
    for (uint32_t l = 0; l < s.vertex_count; ++l) position[s.global_ids[l]] = {s.x[l], s.y[l], s.z[l]};
    for (uint32_t j = 0; j < variants->count(node) && problems.size() < 20; ++j) {
      const std::string name = "variant " + std::to_string(j + 1) + " of segment " + std::to_string(node);
      VariantView v;
      try {
        v = variants->view(node, j);
      } catch (const std::exception& e) {
        problems.push_back(e.what());
        continue;
      }
      for (uint64_t l = 0; l < v.vertex_count; ++l) {
        auto it = v.global[l] == kNoGlobal ? position.end() : position.find(v.global[l]);
        if (it != position.end() && (it->second[0] != v.xyz[3 * l] || it->second[1] != v.xyz[3 * l + 1] || it->second[2] != v.xyz[3 * l + 2])) {
          problems.push_back(name + ": vertex " + std::to_string(v.global[l]) + " is not where the segment has it");
          break;
        }
      }
      // faces used once are its boundary; the segment's border faces must be among them
      std::unordered_map<Face, uint32_t, FaceHash> uses;
      uint64_t inverted = 0;
      for (uint64_t t = 0; t < v.tet_count; ++t) {
        auto p = [&](int k) {
          const float* x = &v.xyz[3 * size_t{v.tets[4 * t + k]}];
          return Vec3{x[0], x[1], x[2]};
        };
        // inverted: negative volume (flat tets of a flat or coincident input stay flat, as in it)
        if (!(dot(cross(p(1) - p(0), p(2) - p(0)), p(3) - p(0)) >= 0)) ++inverted;  // (NaN counts)
        for (int f = 0; f < 4; ++f) {
          Face face = tet_face(v.tets, t, f);
          bool named = true;
          for (uint32_t& id : face) named &= (id = v.global[id]) != kNoGlobal;
          if (named) ++uses[face_key(face)];
        }
      }
      if (inverted) problems.push_back(name + ": " + std::to_string(inverted) + " tets are inverted");
      uint64_t missing = 0;
      for (const Face& f : border) {
        auto it = uses.find(f);
        if (it == uses.end() || it->second != 1) ++missing;
      }
      if (missing) problems.push_back(name + ": " + std::to_string(missing) + " of the segment's " + std::to_string(border.size()) + " border faces are not on its boundary");
    }
  }
  return problems;
}

}  // namespace tetrascope::lod
