// boundary_tags.bin (boundary_tags.h). Little-endian:
//   header (32 bytes): magic "TSBTAGS1", uint32 version (1), uint32 tags N, uint64 triangles T,
//     uint32 CRC-32 of the body, uint32 CRC-32 of the header's first 28 bytes
//   body: per tag uint32 length L (1..255) and L bytes of its name; zero padding to 4 bytes;
//     then T entries of uint32[4]: three global vertex ids, ascending, and the tag (< N)
#include "tetrascope/storage/boundary_tags.h"

#include <algorithm>
#include <cstring>
#include <fstream>

#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::storage {
namespace {

constexpr char kMagic[8] = {'T', 'S', 'B', 'T', 'A', 'G', 'S', '1'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 32, kNameBytes = 255;

[[noreturn]] void damaged(const std::string& what) {
  throw BoundaryTagsError(std::string(kBoundaryTagsFile) + ": " + what + "; preprocess the mesh again (or delete " + kBoundaryTagsFile +
                          " and its manifest entry to take regions from sharp edges)");
}

void put32(std::string& out, uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xFF));
}
uint32_t get32(const std::string& in, size_t at) {
  uint32_t v = 0;
  for (int k = 0; k < 4; ++k) v |= uint32_t{static_cast<uint8_t>(in[at + static_cast<size_t>(k)])} << (8 * k);
  return v;
}

}  // namespace

uint64_t write_boundary_tags(const std::filesystem::path& path, const FaceTags& tags) {
  std::string body;
  for (const std::string& name : tags.names) {
    const std::string kept = name.substr(0, kNameBytes);
    put32(body, static_cast<uint32_t>(kept.empty() ? 1 : kept.size()));
    body += kept.empty() ? std::string("?") : kept;
  }
  while (body.size() % 4) body.push_back('\0');
  for (size_t t = 0; t < tags.triangles.size(); ++t) {
    std::array<uint32_t, 3> ids = tags.triangles[t];
    std::sort(ids.begin(), ids.end());
    for (uint32_t v : ids) put32(body, v);
    put32(body, tags.tags[t]);
  }
  std::string header(kMagic, 8);
  put32(header, kVersion);
  put32(header, static_cast<uint32_t>(tags.names.size()));
  const uint64_t count = tags.triangles.size();
  put32(header, static_cast<uint32_t>(count & 0xFFFFFFFFu));
  put32(header, static_cast<uint32_t>(count >> 32));
  put32(header, crc32_of(body.data(), body.size()));
  put32(header, crc32_of(header.data(), header.size()));
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  out.write(body.data(), static_cast<std::streamsize>(body.size()));
  out.flush();
  if (!out) throw StoreIoError(path.string() + ": cannot be written");
  return header.size() + body.size();
}

FaceTags read_boundary_tags(const std::filesystem::path& path, uint64_t vertex_count) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StoreIoError(path.string() + ": cannot be read");
  const std::string data((std::istreambuf_iterator<char>(in)), {});
  if (data.size() < kHeaderBytes || std::memcmp(data.data(), kMagic, 8) != 0) damaged("not a boundary tags file, or its header is truncated");
  if (crc32_of(data.data(), kHeaderBytes - 4) != get32(data, kHeaderBytes - 4)) damaged("the header fails its checksum");
  if (const uint32_t version = get32(data, 8); version != kVersion) damaged("version " + std::to_string(version) + " (this build reads 1)");
  const uint32_t tag_count = get32(data, 12);
  const uint64_t count = get32(data, 16) | uint64_t{get32(data, 20)} << 32;
  if (tag_count > MeshStream::kMaxFaceTags) damaged(std::to_string(tag_count) + " tags (at most " + std::to_string(MeshStream::kMaxFaceTags) + ")");
  if (count > (data.size() - kHeaderBytes) / 16) damaged("truncated (" + std::to_string(count) + " triangles do not fit)");
  if (crc32_of(data.data() + kHeaderBytes, data.size() - kHeaderBytes) != get32(data, 24)) damaged("the body fails its checksum");
  FaceTags out;
  size_t at = kHeaderBytes;
  for (uint32_t t = 0; t < tag_count; ++t) {
    if (at + 4 > data.size()) damaged("the names are truncated");
    const uint32_t length = get32(data, at);
    at += 4;
    if (length == 0 || length > kNameBytes || length > data.size() - at) damaged("tag " + std::to_string(t) + " has a name of bad length");
    std::string name = data.substr(at, length);
    if (std::any_of(name.begin(), name.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; })) damaged("tag " + std::to_string(t) + "'s name holds a control character");
    out.names.push_back(std::move(name));
    at += length;
  }
  at = (at + 3) / 4 * 4;
  if (at > data.size() || data.size() - at != 16 * count) damaged("its size does not match its counts");
  out.triangles.resize(count);
  out.tags.resize(count);
  for (uint64_t t = 0; t < count; ++t, at += 16) {
    auto& tri = out.triangles[t];
    for (size_t k = 0; k < 3; ++k) tri[k] = get32(data, at + 4 * k);
    out.tags[t] = get32(data, at + 12);
    if (!(tri[0] < tri[1] && tri[1] < tri[2]) || tri[2] >= vertex_count)
      damaged("triangle " + std::to_string(t) + " names vertices out of order or past the store's " + std::to_string(vertex_count));
    if (out.tags[t] >= tag_count) damaged("triangle " + std::to_string(t) + " has tag " + std::to_string(out.tags[t]) + " of " + std::to_string(tag_count));
  }
  return out;
}

std::optional<FaceTags> open_boundary_tags(const Store& store) {
  const nlohmann::json& m = store.manifest().json;
  if (!m.contains("boundary_tags")) return std::nullopt;
  const nlohmann::json& entry = m["boundary_tags"];
  if (!entry.is_object() || entry.value("file", "") != kBoundaryTagsFile || !entry.contains("tags") || !entry.contains("triangles") ||
      !entry["tags"].is_number_unsigned() || !entry["triangles"].is_number_unsigned())
    damaged("the manifest's boundary_tags entry is malformed");
  const std::filesystem::path file = store.path() / kBoundaryTagsFile;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) damaged("missing, though the manifest lists it");
  FaceTags tags = read_boundary_tags(file, store.manifest().vertex_count);
  if (tags.names.size() != entry["tags"].get<uint64_t>() || tags.triangles.size() != entry["triangles"].get<uint64_t>())
    damaged("its counts differ from the manifest's");
  return tags;
}

nlohmann::json boundary_tags_manifest(const FaceTags& tags, uint64_t bytes) {
  return {{"file", kBoundaryTagsFile}, {"tags", tags.names.size()}, {"triangles", tags.triangles.size()}, {"bytes", bytes}};
}

}  // namespace tetrascope::storage
