#include "tetrascope/storage/store.h"

#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/storage/tensor.h"

#include <fcntl.h>
#include <libdeflate.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace tetrascope::storage {

using namespace store;

uint32_t crc32_of(const void* data, size_t bytes, uint32_t seed) { return libdeflate_crc32(seed, data, bytes); }

MappedSegment::MappedSegment(std::shared_ptr<const MappedSegment> base, std::vector<float> values)
    : address_(nullptr), length_(0), view_(base->view()), base_(std::move(base)), values_(std::move(values)) {
  view_.attributes = values_;
}

MappedSegment::~MappedSegment() {
  if (address_) ::munmap(address_, length_);
}

namespace {

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
  throw StoreError(file.string() + ": " + what);
}

std::string read_text(const std::filesystem::path& path, uint64_t limit) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StoreIoError(path.string() + ": cannot open");
  in.seekg(0, std::ios::end);
  auto size = static_cast<uint64_t>(in.tellg());
  if (size > limit) fail(path, "larger than " + std::to_string(limit) + " bytes");
  in.seekg(0);
  std::string text(size, '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  if (!in) fail(path, "read error");
  return text;
}

void pread_exact(int fd, const std::filesystem::path& path, uint64_t offset, void* dst, size_t bytes, const std::string& what) {
  size_t done = 0;
  while (done < bytes) {
    ssize_t got = ::pread(fd, static_cast<char*>(dst) + done, bytes - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) fail(path, what + ": file truncated");
    done += static_cast<size_t>(got);
  }
}

}  // namespace

// The manifest carries "checksum": CRC-32 of the file's exact bytes with the checksum's own
// eight hex digits written as zeros, so a change to any byte is noticed.
constexpr uint64_t kMaxManifestBytes = 64 << 20;

Store::~Store() {
  if (fd_ >= 0) ::close(fd_);
}

namespace {

// Reads manifest.json and checks its checksum; returns the text with the checksum's digits
// written as zeros (the bytes the checksum covers).
std::string read_manifest_text(const std::filesystem::path& manifest_path) {
  std::string text = read_text(manifest_path, kMaxManifestBytes);
  const std::string key = "\"checksum\": \"";
  size_t at = text.find(key);
  if (at == std::string::npos || text.find(key, at + 1) != std::string::npos || at + key.size() + 8 > text.size()) {
    fail(manifest_path, "no checksum field");
  }
  std::string stored = text.substr(at + key.size(), 8);
  text.replace(at + key.size(), 8, "00000000");
  char hex[9];
  std::snprintf(hex, sizeof hex, "%08x", crc32_of(text.data(), text.size()));
  if (stored != hex) fail(manifest_path, "checksum mismatch (the file was changed or damaged)");
  return text;
}

// Parses the manifest's fields into m; returns the compression it names for segments.bin.
std::string parse_manifest(const std::string& text, const std::filesystem::path& manifest_path, StoreManifest& m) {
  std::string manifest_compression = "none";
  try {
    m.json = nlohmann::json::parse(text);
    const auto& j = m.json;
    if (j.at("format") != "tetrascope-store") fail(manifest_path, "not a tetrascope store manifest");
    m.version = j.at("version").get<uint32_t>();
    if (m.version != kFormatVersion && m.version != kCompressedFormatVersion) {
      fail(manifest_path, "format version " + std::to_string(m.version) + ", this build reads " + std::to_string(kFormatVersion) + " and " + std::to_string(kCompressedFormatVersion));
    }
    if (j.contains("files") && j.at("files").contains("segments.bin") && j.at("files").at("segments.bin").contains("compression")) {
      manifest_compression = j.at("files").at("segments.bin").at("compression").get<std::string>();
    }
    m.source_file = j.at("source").at("file").get<std::string>();
    m.source_bytes = j.at("source").at("bytes").get<uint64_t>();
    m.source_sha256 = j.at("source").at("sha256").get<std::string>();
    m.vertex_count = j.at("counts").at("vertices").get<uint64_t>();
    m.tet_count = j.at("counts").at("tetrahedra").get<uint64_t>();
    m.segment_count = j.at("counts").at("segments").get<uint32_t>();
    for (const auto& a : j.at("attributes")) {
      m.attributes.push_back({a.at("name").get<std::string>(), a.at("components").get<uint32_t>(), a.at("min").get<double>(), a.at("max").get<double>()});
      read_attribute_kind_json(a, m.attributes.back().kind, m.attributes.back().positive_semidefinite, m.attributes.back().derived_from);
      if (a.contains("component_ranges")) m.attributes.back().component_ranges = a.at("component_ranges").get<std::vector<std::array<double, 2>>>();
    }
    for (int k = 0; k < 3; ++k) {
      m.bounds.min[k] = j.at("bounds").at("min").at(k).get<double>();
      m.bounds.max[k] = j.at("bounds").at("max").at(k).get<double>();
    }
    m.stream_tags = j.at("stream").at("tags").get<std::vector<int64_t>>();
    m.max_workload_segments = j.at("stream").at("max_workload_segments").get<uint32_t>();
  } catch (const nlohmann::json::exception& e) {
    fail(manifest_path, std::string("malformed: ") + e.what());
  }
  return manifest_compression;
}

// Reads segments.bin's header into h and checks it against the file and the manifest;
// returns the file's size in bytes.
uint64_t read_header(int fd, const std::filesystem::path& segments_path, const StoreManifest& m, const std::string& manifest_compression, FileHeader& h) {
  struct stat st {};
  ::fstat(fd, &st);
  const uint64_t file_bytes = static_cast<uint64_t>(st.st_size);
  pread_exact(fd, segments_path, 0, &h, sizeof h, "header");
  if (std::memcmp(h.magic, kFileMagic, sizeof kFileMagic) != 0) fail(segments_path, "header: wrong magic (not a tetrascope segments file)");
  if (h.version != kFormatVersion && h.version != kCompressedFormatVersion) {
    fail(segments_path, "header: format version " + std::to_string(h.version) + ", this build reads " + std::to_string(kFormatVersion) + " and " + std::to_string(kCompressedFormatVersion));
  }
  if (crc32_of(&h, offsetof(FileHeader, header_crc)) != h.header_crc) fail(segments_path, "header: checksum mismatch");
  // version 1 is uncompressed; version 2 names its compression, and manifest.json the same
  const bool known_compression = h.compression == uint32_t(Compression::kIndex16) || h.compression == uint32_t(Compression::kCutBorder);
  if (h.version == kFormatVersion ? h.compression != 0 : !known_compression) fail(segments_path, "header: unknown segment compression " + std::to_string(h.compression));
  if (h.version != m.version || manifest_compression != compression_name(static_cast<Compression>(h.compression))) {
    fail(segments_path, "header: version or compression disagrees with manifest.json");
  }
  if (h.header_bytes != sizeof(FileHeader)) fail(segments_path, "header: unexpected header size");
  if (h.file_bytes != file_bytes) fail(segments_path, "header: file is " + std::to_string(file_bytes) + " bytes, expected " + std::to_string(h.file_bytes) + " (truncated?)");
  if (h.segment_count != m.segment_count || h.vertex_count != m.vertex_count || h.tet_count != m.tet_count) {
    fail(segments_path, "header: counts disagree with manifest.json");
  }
  uint32_t floats = 0;
  for (const auto& a : m.attributes) floats += a.components;
  if (h.floats_per_vertex != floats) fail(segments_path, "header: attribute sizes disagree with manifest.json");
  if (h.segment_count == 0 || h.segment_count > kMaxSegments) fail(segments_path, "header: invalid segment count");
  if (h.vertex_count >= 0xFFFFFFFFull) fail(segments_path, "header: too many vertices");
  return file_bytes;
}

// Reads the directory and the neighbour lists into records and neighbours, checking that
// both lie inside the file and match their checksums.
void read_directory(int fd, const std::filesystem::path& segments_path, const FileHeader& h, uint64_t file_bytes, std::vector<SegmentRecord>& records,
                    std::vector<uint32_t>& neighbours) {
  const uint64_t directory_bytes = uint64_t{h.segment_count} * sizeof(SegmentRecord);
  if (h.directory_offset > file_bytes || directory_bytes > file_bytes - h.directory_offset) fail(segments_path, "directory: out of the file");
  if (h.neighbour_total > file_bytes / 4 || h.neighbours_offset > file_bytes || h.neighbour_total * 4 > file_bytes - h.neighbours_offset) {
    fail(segments_path, "neighbour lists: out of the file");
  }
  records.resize(h.segment_count);
  pread_exact(fd, segments_path, h.directory_offset, records.data(), directory_bytes, "directory");
  if (crc32_of(records.data(), directory_bytes) != h.directory_crc) fail(segments_path, "directory: checksum mismatch");
  neighbours.resize(h.neighbour_total);
  pread_exact(fd, segments_path, h.neighbours_offset, neighbours.data(), h.neighbour_total * 4, "neighbour lists");
  if (crc32_of(neighbours.data(), h.neighbour_total * 4) != h.neighbours_crc) fail(segments_path, "neighbour lists: checksum mismatch");
}

// Checks every directory record (place in the file, counts, size, neighbours) and that the
// records' owned vertices and tets add up to the header's counts.
void check_records(const std::filesystem::path& segments_path, const FileHeader& h, uint64_t file_bytes, const std::vector<SegmentRecord>& records,
                   const std::vector<uint32_t>& neighbours) {
  const uint32_t floats = h.floats_per_vertex;  // read_header checked it against manifest.json
  const auto compression = static_cast<Compression>(h.compression);
  uint64_t vertex_sum = 0, tet_sum = 0;
  for (uint32_t i = 0; i < h.segment_count; ++i) {
    const SegmentRecord& r = records[i];
    const std::string where = "segment " + std::to_string(i) + ": ";
    if (r.offset % kPageBytes != 0 || r.offset > file_bytes || r.bytes > file_bytes - r.offset) fail(segments_path, where + "offset/size out of the file");
    if (r.tet_count > kMaxSegmentTets || r.boundary_tet_count > r.tet_count || r.owned_vertex_count > r.vertex_count) fail(segments_path, where + "invalid counts");
    const uint64_t fixed_bytes = segment_layout(r.vertex_count, r.tet_count, r.link_count, floats, compression).bytes;
    // a connectivity stream takes what is left, at least kMinStreamBytesPerTet a tet: that
    // bounds what decoding the segment may allocate (32 bytes a tet) by 16 times its stream
    if (compression == Compression::kCutBorder ? r.bytes < fixed_bytes + kMinStreamBytesPerTet * uint64_t{r.tet_count} || r.bytes - fixed_bytes > 0xFFFFFFFFu
                                               : fixed_bytes != r.bytes) {
      fail(segments_path, where + "size does not match its counts");
    }
    if (uint64_t{r.neighbour_begin} + r.neighbour_count > h.neighbour_total) fail(segments_path, where + "neighbour list out of range");
    for (uint32_t k = 0; k < r.neighbour_count; ++k) {
      uint32_t n = neighbours[r.neighbour_begin + k];
      if (n >= h.segment_count || n == i) fail(segments_path, where + "invalid neighbour " + std::to_string(n));
    }
    vertex_sum += r.owned_vertex_count;
    tet_sum += r.tet_count;
  }
  if (vertex_sum != h.vertex_count) fail(segments_path, "directory: owned vertices add up to " + std::to_string(vertex_sum) + ", expected " + std::to_string(h.vertex_count));
  if (tet_sum != h.tet_count) fail(segments_path, "directory: tets add up to " + std::to_string(tet_sum) + ", expected " + std::to_string(h.tet_count));
}

// Checks that the manifest's stream tags name valid segments.
void check_stream_tags(const std::filesystem::path& manifest_path, const StoreManifest& m, const FileHeader& h) {
  for (int64_t tag : m.stream_tags) {
    int64_t segment = tag > 0 ? tag - 1 : -tag - 1;
    if (tag == 0 || segment >= h.segment_count) fail(manifest_path, "stream tag " + std::to_string(tag) + " names no segment");
  }
}

}  // namespace

std::unique_ptr<Store> Store::open(const std::filesystem::path& directory) {
  std::unique_ptr<Store> s(new Store());
  s->path_ = directory;
  const auto manifest_path = directory / "manifest.json";
  const auto segments_path = directory / "segments.bin";
  if (!std::filesystem::is_directory(directory)) fail(directory, "not a store directory");

  // ---- manifest ----
  const std::string manifest_compression = parse_manifest(read_manifest_text(manifest_path), manifest_path, s->manifest_);

  // ---- segments.bin header ----
  s->fd_ = ::open(segments_path.c_str(), O_RDONLY | O_CLOEXEC);
  if (s->fd_ < 0) throw StoreIoError(segments_path.string() + ": cannot open: " + std::strerror(errno));
  const uint64_t file_bytes = read_header(s->fd_, segments_path, s->manifest_, manifest_compression, s->header_);

  // ---- directory and neighbour lists ----
  read_directory(s->fd_, segments_path, s->header_, file_bytes, s->records_, s->neighbours_);
  check_records(segments_path, s->header_, file_bytes, s->records_, s->neighbours_);
  check_stream_tags(manifest_path, s->manifest_, s->header_);
  return s;
}

std::span<const uint32_t> Store::neighbours(uint32_t segment) const {
  const SegmentRecord& r = records_.at(segment);
  return std::span<const uint32_t>(neighbours_).subspan(r.neighbour_begin, r.neighbour_count);
}

std::shared_ptr<const MappedSegment> Store::map_segment(uint32_t segment) const {
  const auto file = path_ / "segments.bin";
  if (segment >= header_.segment_count) fail(file, "segment " + std::to_string(segment) + " does not exist");
  const SegmentRecord& r = records_[segment];
  const std::string where = "segment " + std::to_string(segment) + ": ";
  size_t length = static_cast<size_t>(r.bytes);
  void* address = ::mmap(nullptr, length, PROT_READ, MAP_SHARED, fd_, static_cast<off_t>(r.offset));
  if (address == MAP_FAILED) throw StoreIoError(file.string() + ": " + where + "cannot map: " + std::strerror(errno));
  struct Unmap {  // on any failure below
    void* address;
    size_t length;
    ~Unmap() {
      if (address) ::munmap(address, length);
    }
  } guard{address, length};
  const auto* bytes = static_cast<const uint8_t*>(address);
  if (crc32_of(bytes, length) != r.crc) fail(file, where + "checksum mismatch");
  SegmentHeader sh;
  std::memcpy(&sh, bytes, sizeof sh);
  const auto compression = static_cast<Compression>(header_.compression);
  const uint64_t stream_bytes = compression == Compression::kCutBorder ? r.bytes - segment_layout(r.vertex_count, r.tet_count, r.link_count, header_.floats_per_vertex, compression).bytes : 0;
  if (sh.magic != kSegmentMagic || sh.version != header_.version) fail(file, where + "wrong magic or version");
  if (sh.compression != header_.compression || sh.stream_bytes != stream_bytes) fail(file, where + "compression or stream size disagrees with the directory");
  if (sh.segment != segment || sh.vertex_count != r.vertex_count || sh.owned_vertex_count != r.owned_vertex_count || sh.tet_count != r.tet_count ||
      sh.boundary_tet_count != r.boundary_tet_count || sh.link_count != r.link_count || sh.floats_per_vertex != header_.floats_per_vertex) {
    fail(file, where + "header disagrees with the directory");
  }
  const SegmentLayout l = segment_layout(r.vertex_count, r.tet_count, r.link_count, header_.floats_per_vertex, compression, stream_bytes);
  SegmentView v;
  v.id = segment;
  v.vertex_count = r.vertex_count;
  v.owned_vertex_count = r.owned_vertex_count;
  v.tet_count = r.tet_count;
  v.boundary_tet_count = r.boundary_tet_count;
  auto floats = [&](uint64_t at, uint64_t n) { return std::span<const float>(reinterpret_cast<const float*>(bytes + at), n); };
  auto words = [&](uint64_t at, uint64_t n) { return std::span<const uint32_t>(reinterpret_cast<const uint32_t*>(bytes + at), n); };
  v.x = floats(l.x, r.vertex_count);
  v.y = floats(l.y, r.vertex_count);
  v.z = floats(l.z, r.vertex_count);
  v.attributes = floats(l.attributes, uint64_t{r.vertex_count} * header_.floats_per_vertex);
  v.links = std::span<const BorderLink>(reinterpret_cast<const BorderLink*>(bytes + l.links), r.link_count);
  const size_t tet_words = 4 * size_t{r.tet_count};
  std::vector<uint32_t> decoded;
  if (l.tet_index_bytes == 4) {
    v.tets = words(l.tets, tet_words);
    v.opposites = words(l.opposites, tet_words);
  } else if (l.tet_index_bytes == 2) {
    decoded.resize(tet_words);
    const auto* narrow = reinterpret_cast<const uint16_t*>(bytes + l.tets);
    std::copy(narrow, narrow + tet_words, decoded.begin());
    v.tets = decoded;
    v.opposites = words(l.opposites, tet_words);
  } else {
    decoded.resize(2 * tet_words);
    const std::span<uint32_t> tets(decoded.data(), tet_words), opposites(decoded.data() + tet_words, tet_words);
    const std::string error = decode_tets(std::span<const uint8_t>(bytes + l.tets, stream_bytes), r.vertex_count, r.tet_count, v.links, tets, opposites);
    if (!error.empty()) fail(file, where + "connectivity stream: " + error);
    v.tets = tets;
    v.opposites = opposites;
  }
  v.global_ids = words(l.global_ids, r.vertex_count);
  // every index, once; the cut-border decoder has checked the tets and opposites it wrote
  // (ids in range, opposites in range and symmetric, one border face a link, no face twice)
  uint32_t borders = r.link_count;
  const uint32_t faces = 4 * r.tet_count;
  if (compression != Compression::kCutBorder) {
    for (size_t i = 0; i < v.tets.size(); ++i) {
      if (v.tets[i] >= r.vertex_count) fail(file, where + "tets: vertex index " + std::to_string(v.tets[i]) + " out of range");
    }
    borders = 0;
    for (uint32_t f = 0; f < faces; ++f) {
      uint32_t o = v.opposites[f];
      if (o == kSegmentBorder) ++borders;
      else if (o != kMeshBoundary && o >= faces) fail(file, where + "opposites: face " + std::to_string(f) + " points to " + std::to_string(o) + ", out of range");
    }
  }
  if (borders != r.link_count) fail(file, where + "links: " + std::to_string(r.link_count) + " links for " + std::to_string(borders) + " border faces");
  for (uint32_t k = 0; k < r.link_count; ++k) {
    const BorderLink& link = v.links[k];
    if (link.face >= faces || v.opposites[link.face] != kSegmentBorder || (k > 0 && link.face <= v.links[k - 1].face)) {
      fail(file, where + "links: entry " + std::to_string(k) + " is not an ascending border face");
    }
    if (link.segment >= header_.segment_count || link.segment == segment || link.remote_face >= 4 * uint64_t{records_[link.segment].tet_count}) {
      fail(file, where + "links: entry " + std::to_string(k) + " points to no face of a neighbouring segment");
    }
  }
  for (uint32_t g : v.global_ids) {
    if (g >= header_.vertex_count) fail(file, where + "global ids: " + std::to_string(g) + " out of range");
  }
  for (float c : v.x) if (!std::isfinite(c)) fail(file, where + "coordinates: not finite");
  for (float c : v.y) if (!std::isfinite(c)) fail(file, where + "coordinates: not finite");
  for (float c : v.z) if (!std::isfinite(c)) fail(file, where + "coordinates: not finite");
  guard.address = nullptr;
  return std::make_shared<MappedSegment>(address, length, v, std::move(decoded));
}

}  // namespace tetrascope::storage

namespace tetrascope::storage {

}  // namespace tetrascope::storage
