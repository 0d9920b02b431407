#include "tetrascope/storage/store_writer.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::storage {

using namespace store;

namespace {
[[noreturn]] void io_error(const std::filesystem::path& path, const std::string& what) {
  throw std::runtime_error(path.string() + ": " + what + ": " + std::strerror(errno));
}

void sync_directory(const std::filesystem::path& directory) {
  int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}
}  // namespace

void write_manifest(const std::filesystem::path& path, nlohmann::json manifest) {
  manifest["checksum"] = "00000000";
  std::string text = manifest.dump(2) + "\n";
  const std::string key = "\"checksum\": \"00000000\"";
  size_t at = text.find(key);
  char hex[9];
  std::snprintf(hex, sizeof hex, "%08x", crc32_of(text.data(), text.size()));
  text.replace(at + key.size() - 9, 8, hex);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.flush();
  if (!out) io_error(path, "write failed");
}

StoreWriter::StoreWriter(std::filesystem::path directory, bool replace, uint64_t vertex_count,
                         uint32_t segment_count, uint32_t floats_per_vertex, Compression compression)
    : directory_(std::move(directory)), replace_(replace) {
  if (directory_.filename().empty()) directory_ = directory_.parent_path();
  temp_ = directory_;
  temp_ += ".tmp";
  if (std::filesystem::exists(directory_) && !replace_) {
    throw std::runtime_error(directory_.string() + ": already exists (use --force to replace it)");
  }
  if (segment_count == 0 || segment_count > kMaxSegments) throw std::runtime_error("invalid segment count");
  std::filesystem::remove_all(temp_);
  std::filesystem::create_directories(temp_);
  fd_ = ::open((temp_ / "segments.bin").c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) io_error(temp_ / "segments.bin", "cannot create");
  // every byte, the struct's tail padding (92 bytes of fields, 96 written) included: a store
  // is byte for byte the same for the same input and options
  std::memset(static_cast<void*>(&header_), 0, sizeof header_);
  std::memcpy(header_.magic, kFileMagic, sizeof kFileMagic);
  header_.version = compression == Compression::kNone ? kFormatVersion : kCompressedFormatVersion;
  header_.compression = static_cast<uint32_t>(compression);
  header_.header_bytes = sizeof(FileHeader);
  header_.vertex_count = vertex_count;
  header_.segment_count = segment_count;
  header_.floats_per_vertex = floats_per_vertex;
  records_.resize(segment_count);
  added_.assign(segment_count, 0);
  // header page, then the directory, then segments
  header_.directory_offset = kPageBytes;
  next_offset_ = align_page(kPageBytes + uint64_t{segment_count} * sizeof(SegmentRecord));
}

StoreWriter::~StoreWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (!finished_) {
    std::error_code ignored;
    std::filesystem::remove_all(temp_, ignored);
  }
}

void StoreWriter::write_at(uint64_t offset, const void* data, size_t bytes) {
  const char* p = static_cast<const char*>(data);
  while (bytes > 0) {
    ssize_t n = ::pwrite(fd_, p, bytes, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) io_error(temp_ / "segments.bin", "write failed");
    p += n;
    offset += static_cast<uint64_t>(n);
    bytes -= static_cast<size_t>(n);
  }
}

void StoreWriter::add_segment(const SegmentData& s) {
  if (s.id >= records_.size() || added_[s.id]) throw std::logic_error("segment added twice or out of range");
  const uint64_t vertices = s.x.size(), tets = s.tets.size() / 4;
  if (tets > kMaxSegmentTets) throw std::runtime_error("segment " + std::to_string(s.id) + " has too many tets");
  const auto compression = static_cast<Compression>(header_.compression);
  stream_.clear();
  if (compression == Compression::kCutBorder) encode_tets(s.tets, s.opposites, stream_);
  if (stream_.size() > 0xFFFFFFFFu) throw std::runtime_error("segment " + std::to_string(s.id) + ": connectivity stream too large");
  const SegmentLayout l = segment_layout(vertices, tets, s.links.size(), header_.floats_per_vertex, compression, stream_.size());
  buffer_.assign(static_cast<size_t>(l.bytes), 0);
  SegmentHeader h{};
  h.magic = kSegmentMagic;
  h.version = header_.version;
  h.compression = header_.compression;
  h.stream_bytes = static_cast<uint32_t>(stream_.size());
  h.segment = s.id;
  h.vertex_count = static_cast<uint32_t>(vertices);
  h.owned_vertex_count = s.owned_vertex_count;
  h.tet_count = static_cast<uint32_t>(tets);
  h.boundary_tet_count = s.boundary_tet_count;
  h.link_count = static_cast<uint32_t>(s.links.size());
  h.floats_per_vertex = header_.floats_per_vertex;
  std::memcpy(buffer_.data(), &h, sizeof h);
  auto put = [&](uint64_t at, const auto& v) {
    if (!v.empty()) std::memcpy(buffer_.data() + at, v.data(), v.size() * sizeof(v[0]));
  };
  put(l.x, s.x);
  put(l.y, s.y);
  put(l.z, s.z);
  put(l.attributes, s.attributes);
  if (l.tet_index_bytes == 4) {
    put(l.tets, s.tets);
  } else if (l.tet_index_bytes == 2) {
    narrow_.resize(s.tets.size());
    for (size_t i = 0; i < s.tets.size(); ++i) narrow_[i] = static_cast<uint16_t>(s.tets[i]);  // every id < kMaxIndex16Vertices
    put(l.tets, narrow_);
  } else {
    put(l.tets, stream_);
  }
  if (l.tet_index_bytes != 0) put(l.opposites, s.opposites);
  put(l.links, s.links);
  put(l.global_ids, s.global_ids);
  SegmentRecord& r = records_[s.id];
  r.offset = next_offset_;
  r.bytes = l.bytes;
  r.vertex_count = h.vertex_count;
  r.owned_vertex_count = h.owned_vertex_count;
  r.tet_count = h.tet_count;
  r.boundary_tet_count = h.boundary_tet_count;
  r.link_count = h.link_count;
  r.crc = crc32_of(buffer_.data(), buffer_.size());
  std::memcpy(r.bounds, s.bounds, sizeof r.bounds);
  write_at(r.offset, buffer_.data(), buffer_.size());
  next_offset_ = align_page(r.offset + l.bytes);
  added_[s.id] = 1;
}

void StoreWriter::finish(const std::vector<std::vector<uint32_t>>& neighbours, nlohmann::json manifest) {
  for (uint8_t a : added_) {
    if (!a) throw std::logic_error("finish() before every segment was added");
  }
  std::vector<uint32_t> flat;
  header_.tet_count = 0;
  for (const SegmentRecord& r : records_) header_.tet_count += r.tet_count;
  for (size_t s = 0; s < records_.size(); ++s) {
    records_[s].neighbour_begin = static_cast<uint32_t>(flat.size());
    records_[s].neighbour_count = static_cast<uint32_t>(neighbours[s].size());
    flat.insert(flat.end(), neighbours[s].begin(), neighbours[s].end());
  }
  header_.neighbours_offset = next_offset_;
  header_.neighbour_total = flat.size();
  if (!flat.empty()) write_at(header_.neighbours_offset, flat.data(), flat.size() * 4);
  header_.file_bytes = header_.neighbours_offset + flat.size() * 4;
  if (::ftruncate(fd_, static_cast<off_t>(header_.file_bytes)) != 0) io_error(temp_ / "segments.bin", "truncate failed");
  header_.neighbours_crc = crc32_of(flat.data(), flat.size() * 4);
  header_.directory_crc = crc32_of(records_.data(), records_.size() * sizeof(SegmentRecord));
  write_at(header_.directory_offset, records_.data(), records_.size() * sizeof(SegmentRecord));
  header_.header_crc = crc32_of(&header_, offsetof(FileHeader, header_crc));
  write_at(0, &header_, sizeof header_);
  if (::fsync(fd_) != 0) io_error(temp_ / "segments.bin", "sync failed");
  ::close(fd_);
  fd_ = -1;
  manifest["files"]["segments.bin"] = {{"bytes", header_.file_bytes}};
  if (header_.compression != 0) {
    manifest["version"] = kCompressedFormatVersion;
    manifest["files"]["segments.bin"]["compression"] = compression_name(static_cast<Compression>(header_.compression));
  }
  write_manifest(temp_ / "manifest.json", std::move(manifest));
  sync_directory(temp_);
  std::filesystem::path old;
  if (std::filesystem::exists(directory_)) {
    if (!replace_) throw std::runtime_error(directory_.string() + ": appeared while writing; the new store stays in " + temp_.string());
    old = directory_;
    old += ".old";
    std::filesystem::remove_all(old);
    std::filesystem::rename(directory_, old);
  }
  std::filesystem::rename(temp_, directory_);
  finished_ = true;
  sync_directory(directory_.parent_path().empty() ? std::filesystem::path(".") : directory_.parent_path());
  if (!old.empty()) std::filesystem::remove_all(old);
}

}  // namespace tetrascope::storage
