// Compressed segments: the cut-border stream decodes to exactly the tets and
// opposites it was made from; a store built with 16-bit indices or the stream holds the same
// tets per segment as an uncompressed one, passes verify and gives the same cut; a damaged
// stream is refused with a message, never read past its end.
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <random>

#include "cli_run.h"
#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_verify.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::testing {
namespace {

using storage::store::BorderLink;
using storage::store::Compression;
using storage::store::kMeshBoundary;
using storage::store::kSegmentBorder;

// A cube of 5 tets (positive orientation) next to a second cube sharing face x = 1; 10 tets.
std::vector<uint32_t> two_cubes() {
  // vertices: (i, j, k) -> i + 3 * j + 6 * k, i in 0..2, j, k in 0..1
  auto v = [](uint32_t i, uint32_t j, uint32_t k) { return i + 3 * j + 6 * k; };
  std::vector<uint32_t> tets;
  for (uint32_t i = 0; i < 2; ++i) {
    const uint32_t c[8] = {v(i, 0, 0), v(i + 1, 0, 0), v(i + 1, 1, 0), v(i, 1, 0), v(i, 0, 1), v(i + 1, 0, 1), v(i + 1, 1, 1), v(i, 1, 1)};
    // the two ways of cutting a cube into 5 tets, alternating so that shared faces match
    constexpr int kOdd[20] = {0, 1, 3, 4, 1, 2, 3, 6, 1, 4, 5, 6, 3, 4, 6, 7, 1, 3, 4, 6};
    constexpr int kEven[20] = {0, 1, 2, 5, 0, 2, 3, 7, 0, 4, 5, 7, 2, 5, 6, 7, 0, 2, 5, 7};
    for (int corner : i % 2 ? kOdd : kEven) tets.push_back(c[corner]);
  }
  return tets;
}

struct Coded {
  std::vector<uint32_t> tets, opposites;
  std::vector<BorderLink> links;
  std::vector<uint8_t> stream;
  uint32_t vertex_count = 0;
};

// Pairs the faces of `tets`; the first `border` unpaired faces become segment-border links.
Coded code(std::vector<uint32_t> tets, uint32_t vertex_count, size_t border) {
  Coded c;
  c.tets = std::move(tets);
  c.vertex_count = vertex_count;
  c.opposites = pair_faces(c.tets).opposite;
  for (uint32_t f = 0; f < c.opposites.size() && c.links.size() < border; ++f) {
    if (c.opposites[f] != kMeshBoundary) continue;
    c.opposites[f] = kSegmentBorder;
    c.links.push_back({f, 1, 0});
  }
  storage::encode_tets(c.tets, c.opposites, c.stream);
  return c;
}

std::string decode(const Coded& c, std::span<const uint8_t> stream, std::vector<uint32_t>& tets, std::vector<uint32_t>& opposites) {
  tets.assign(c.tets.size(), 0);
  opposites.assign(c.tets.size(), 0);
  return storage::decode_tets(stream, c.vertex_count, static_cast<uint32_t>(c.tets.size() / 4), c.links, tets, opposites);
}

TEST(SegmentCodec, TwoCubesDecodeToTheSameTetsAndOpposites) {
  const Coded c = code(two_cubes(), 12, 3);
  std::vector<uint32_t> tets, opposites;
  ASSERT_EQ(decode(c, c.stream, tets, opposites), "");
  EXPECT_EQ(tets, c.tets);
  EXPECT_EQ(opposites, c.opposites);
  EXPECT_LT(c.stream.size(), 2 * c.tets.size());  // under two bytes a vertex index, adjacency included
}

TEST(SegmentCodec, ShuffledTetsKeepTheirOrderAndVertexOrder) {
  // a 6x6x6 grid of cubes, 5 tets each, tets shuffled and each one's vertices rotated evenly
  const int k = 6;
  auto at = [&](int i, int j, int l) { return uint32_t((l * (k + 1) + j) * (k + 1) + i); };
  std::vector<std::array<uint32_t, 4>> list;
  for (int l = 0; l < k; ++l)
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < k; ++i) {
        uint32_t c[8] = {at(i, j, l), at(i + 1, j, l), at(i + 1, j + 1, l), at(i, j + 1, l), at(i, j, l + 1), at(i + 1, j, l + 1), at(i + 1, j + 1, l + 1), at(i, j + 1, l + 1)};
        if ((i + j + l) % 2) {
          list.insert(list.end(), {{c[0], c[1], c[3], c[4]}, {c[1], c[2], c[3], c[6]}, {c[1], c[4], c[5], c[6]}, {c[3], c[4], c[6], c[7]}, {c[1], c[3], c[4], c[6]}});
        } else {
          list.insert(list.end(), {{c[0], c[1], c[2], c[5]}, {c[0], c[2], c[3], c[7]}, {c[0], c[4], c[5], c[7]}, {c[2], c[5], c[6], c[7]}, {c[0], c[2], c[5], c[7]}});
        }
      }
  std::mt19937 rng(3);
  std::shuffle(list.begin(), list.end(), rng);
  std::vector<uint32_t> tets;
  for (auto& t : list) {
    const int r = int(rng() % 3);  // an even permutation of the last three keeps the orientation
    for (int i = 0; i < r; ++i) t = {t[0], t[2], t[3], t[1]};
    tets.insert(tets.end(), t.begin(), t.end());
  }
  const Coded c = code(tets, uint32_t((k + 1) * (k + 1) * (k + 1)), 40);
  std::vector<uint32_t> decoded, opposites;
  ASSERT_EQ(decode(c, c.stream, decoded, opposites), "");
  EXPECT_EQ(decoded, c.tets);
  EXPECT_EQ(opposites, c.opposites);
}

TEST(SegmentCodec, EmptySegmentIsAnEmptyStream) {
  const Coded c = code({}, 0, 0);
  EXPECT_TRUE(c.stream.empty());
  std::vector<uint32_t> tets, opposites;
  EXPECT_EQ(decode(c, c.stream, tets, opposites), "");
}

TEST(HostileSegmentStream, TruncatedAtEveryByteIsRefused) {
  const Coded c = code(two_cubes(), 12, 3);
  std::vector<uint32_t> tets, opposites;
  for (size_t n = 0; n < c.stream.size(); ++n) {
    const std::vector<uint8_t> cut(c.stream.begin(), c.stream.begin() + static_cast<std::ptrdiff_t>(n));  // exact size: ASan sees any overread
    const std::string error = decode(c, cut, tets, opposites);
    EXPECT_NE(error.find("stream ends early"), std::string::npos) << "cut at " << n << ": " << error;
  }
}

TEST(HostileSegmentStream, TrailingBytesAreRefused) {
  Coded c = code(two_cubes(), 12, 3);
  c.stream.push_back(0);
  std::vector<uint32_t> tets, opposites;
  EXPECT_EQ(decode(c, c.stream, tets, opposites), "stream has 1 bytes after the last tet");
}

TEST(HostileSegmentStream, EveryFlippedByteDecodesToValidIndicesOrIsRefused) {
  const Coded c = code(two_cubes(), 12, 3);
  std::vector<uint32_t> tets, opposites;
  size_t refused = 0, tries = 0;
  for (size_t at = 0; at < c.stream.size(); ++at) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> bytes = c.stream;
      bytes[at] = static_cast<uint8_t>(bytes[at] ^ (1u << bit));
      ++tries;
      const std::string error = decode(c, bytes, tets, opposites);
      if (!error.empty()) {
        ++refused;
        continue;
      }
      // what decodes must at least be in range and symmetric: the loader relies on that
      for (uint32_t v : tets) EXPECT_LT(v, c.vertex_count);
      for (uint32_t f = 0; f < opposites.size(); ++f) {
        const uint32_t o = opposites[f];
        if (o == kMeshBoundary || o == kSegmentBorder) continue;
        ASSERT_LT(o, opposites.size());
        EXPECT_EQ(opposites[o], f);
        EXPECT_EQ(face_key(tet_face(tets, f / 4, int(f % 4))), face_key(tet_face(tets, o / 4, int(o % 4))));
      }
    }
  }
  EXPECT_GT(refused, tries / 2);
}

TEST(HostileSegmentStream, AVertexIdPastTheSegmentIsRefused) {
  const Coded c = code(two_cubes(), 12, 0);
  std::vector<uint8_t> bytes = c.stream;
  std::vector<uint32_t> tets, opposites;
  ASSERT_EQ(bytes[0], 24);  // the first tet has no earlier neighbour: four explicit vertices
  bytes[1] = 0x7E;          // zigzag(63)
  EXPECT_NE(decode(c, bytes, tets, opposites).find("tet 0: vertex 63 out of range (12 vertices)"), std::string::npos);
}

TEST(HostileSegmentStream, AStreamThatPairsAFaceTwiceIsRefused) {
  // tet 0: vertices 0 1 2 3; tets 1 and 2 both name face 0 of tet 0 as their gate
  const std::vector<uint8_t> stream = {24, 0, 2, 2, 2, /**/ 0, 0, 0, 2, /**/ 0, 4, 0, 2};
  std::vector<uint32_t> tets(12), opposites(12);
  EXPECT_EQ(storage::decode_tets(stream, 6, 3, {}, tets, opposites), "tet 2: face 0 is paired twice");
}

TEST(HostileSegmentStream, AGateBeforeTheFirstTetIsRefused) {
  const std::vector<uint8_t> stream = {24, 0, 2, 2, 2, /**/ 0, 4, 0, 2};  // tet 1 names tet -1
  std::vector<uint32_t> tets(8), opposites(8);
  EXPECT_EQ(storage::decode_tets(stream, 6, 2, {}, tets, opposites), "tet 1: refers to tet 2 back, before the first");
}

TEST(HostileSegmentStream, ALinkOnAnInnerFaceIsRefused) {
  Coded c = code(two_cubes(), 12, 0);
  const uint32_t inner = [&] {
    for (uint32_t f = 0; f < c.opposites.size(); ++f)
      if (c.opposites[f] != kMeshBoundary) return f;
    return 0u;
  }();
  c.links.push_back({inner, 1, 0});
  std::vector<uint32_t> tets, opposites;
  EXPECT_NE(decode(c, c.stream, tets, opposites).find("is inside the segment"), std::string::npos);
}

// The sample preprocessed three ways (once for the whole run).
std::filesystem::path sample_store(Compression compression) {
  static const std::filesystem::path dir = run_scratch_dir("segment_codec_stores");
  const auto path = dir / storage::compression_name(compression);
  if (!std::filesystem::exists(path)) {
    lod::PreprocessOptions options;
    options.threads = 2;
    options.compression = compression;
    lod::preprocess(sample_mesh(), path, options);
  }
  return path;
}

// The tets of `patch` (a range of its floor segment), each as its 4 global vertex ids, sorted:
// the cut-border store keeps each tet and its vertex order, and reorders tets inside a patch.
std::vector<std::array<uint32_t, 4>> patch_tets(const storage::SegmentView& v, const lod::dag::Patch& patch) {
  std::vector<std::array<uint32_t, 4>> out;
  for (uint32_t t = patch.tet_begin; t < patch.tet_begin + patch.tet_count; ++t) {
    out.push_back({v.global_ids[v.tets[4 * t]], v.global_ids[v.tets[4 * t + 1]], v.global_ids[v.tets[4 * t + 2]], v.global_ids[v.tets[4 * t + 3]]});
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(CompressedStore, EverySegmentHoldsTheSameTetsAsUncompressed) {
  auto plain = storage::Store::open(sample_store(Compression::kNone));
  for (Compression compression : {Compression::kIndex16, Compression::kCutBorder}) {
    SCOPED_TRACE(storage::compression_name(compression));
    auto packed = storage::Store::open(sample_store(compression));
    EXPECT_EQ(packed->compression(), compression);
    EXPECT_EQ(packed->manifest().version, storage::store::kCompressedFormatVersion);
    ASSERT_EQ(packed->segment_count(), plain->segment_count());
    auto dag = lod::open_dag(*packed);
    ASSERT_TRUE(dag);
    uint64_t plain_bytes = 0, packed_bytes = 0;
    for (uint32_t s = 0; s < plain->segment_count(); ++s) {
      auto a = plain->map_segment(s);
      auto b = packed->map_segment(s);
      const auto& va = a->view();
      const auto& vb = b->view();
      ASSERT_TRUE(std::equal(va.global_ids.begin(), va.global_ids.end(), vb.global_ids.begin(), vb.global_ids.end())) << "segment " << s;
      if (compression == Compression::kIndex16) {  // the very same arrays
        ASSERT_TRUE(std::equal(va.tets.begin(), va.tets.end(), vb.tets.begin(), vb.tets.end())) << "segment " << s;
        ASSERT_TRUE(std::equal(va.opposites.begin(), va.opposites.end(), vb.opposites.begin(), vb.opposites.end())) << "segment " << s;
      } else {  // the same tets in every patch
        ASSERT_EQ(va.tet_count, vb.tet_count);
        for (uint32_t p : dag->parent_patches(s)) ASSERT_EQ(patch_tets(va, dag->patch(p)), patch_tets(vb, dag->patch(p))) << "segment " << s << " patch " << p;
      }
      plain_bytes += plain->record(s).bytes;
      packed_bytes += packed->record(s).bytes;
    }
    EXPECT_LT(packed_bytes, plain_bytes);
    auto report = storage::verify_store(sample_store(compression));
    EXPECT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems[0]);
  }
}

TEST(CompressedStore, TheRenderedImageIsTheSameAsUncompressed) {
  const auto dir = scratch_dir("segment_codec_render");
  std::string first;
  for (Compression compression : {Compression::kNone, Compression::kIndex16, Compression::kCutBorder}) {
    const auto out = dir / (std::string(storage::compression_name(compression)) + ".png");
    CliResult r = run_cli("render " + sample_store(compression).string() + " --budget 20000 --size 128x128 --camera azimuth=30,elevation=20,distance=0.8 -o " + out.string(), 120);
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string image = read_file(out);
    if (first.empty()) first = image;
    else EXPECT_TRUE(image == first) << storage::compression_name(compression) << ": the image differs from the uncompressed store's";
  }
}

TEST(CompressedStore, Index16TheCutIsTheSameMeshAsUncompressed) {
  const auto dir = scratch_dir("segment_codec_cut");
  std::string first;
  for (Compression compression : {Compression::kNone, Compression::kIndex16}) {
    const auto out = dir / (std::string(storage::compression_name(compression)) + ".vtk");
    CliResult r = run_cli("cut " + sample_store(compression).string() + " --budget 20000 --camera azimuth=30,elevation=20,distance=0.8 -o " + out.string(), 120);
    ASSERT_EQ(r.status, 0) << r.out;
    std::string mesh = read_file(out);
    mesh.erase(0, mesh.find('\n', mesh.find('\n') + 1));  // the title line names the store
    if (first.empty()) first = mesh;
    else EXPECT_TRUE(mesh == first) << storage::compression_name(compression) << ": the cut differs from the uncompressed store's";
  }
}

// Rewrites one segment's bytes in segments.bin and every checksum over them, so that only the
// decoder stands between the damage and the loader.
void damage_with_fixed_checksums(const std::filesystem::path& store, uint32_t segment, const std::function<void(std::string&, size_t stream_at)>& damage) {
  std::string file = read_file(store / "segments.bin");
  storage::store::FileHeader h;
  std::memcpy(&h, file.data(), sizeof h);
  const size_t record_at = h.directory_offset + segment * sizeof(storage::store::SegmentRecord);
  storage::store::SegmentRecord r;
  std::memcpy(&r, file.data() + record_at, sizeof r);
  const auto fixed = storage::store::segment_layout(r.vertex_count, r.tet_count, r.link_count, h.floats_per_vertex, Compression::kCutBorder);
  std::string bytes = file.substr(r.offset, r.bytes);
  damage(bytes, fixed.bytes);
  file.replace(r.offset, r.bytes, bytes);
  r.crc = storage::crc32_of(bytes.data(), bytes.size());
  std::memcpy(file.data() + record_at, &r, sizeof r);
  h.directory_crc = storage::crc32_of(file.data() + h.directory_offset, size_t{h.segment_count} * sizeof r);
  h.header_crc = storage::crc32_of(&h, offsetof(storage::store::FileHeader, header_crc));
  std::memcpy(file.data(), &h, sizeof h);
  write_file(store / "segments.bin", file);
}

TEST(HostileStore, CutBorderStreamDamagedUnderValidChecksumsIsRefused) {
  const auto dir = scratch_dir("segment_codec_damaged");
  std::filesystem::copy(sample_store(Compression::kCutBorder), dir / "s");
  // the first tet's first vertex becomes a huge id; every checksum still matches
  damage_with_fixed_checksums(dir / "s", 0, [](std::string& bytes, size_t stream_at) {
    ASSERT_EQ(static_cast<uint8_t>(bytes[stream_at]), 24u);  // a free tet
    for (int i = 1; i <= 4; ++i) bytes[stream_at + size_t(i)] = static_cast<char>(0xFF);
    bytes[stream_at + 5] = 0x0F;
  });
  auto report = storage::verify_store(dir / "s");
  ASSERT_FALSE(report.ok);
  EXPECT_NE(report.problems[0].find("segment 0: connectivity stream: tet 0: vertex"), std::string::npos) << report.problems[0];
  try {
    storage::Store::open(dir / "s")->map_segment(0);
    ADD_FAILURE() << "the loader accepted a damaged stream";
  } catch (const storage::StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
  }
}

// Puts header `h` (its checksum recomputed) at the start of `file`, writes it as the store's
// segments.bin and expects opening the store to fail with a message containing `expected`.
void write_header_and_expect_refused(const std::filesystem::path& store, std::string& file, storage::store::FileHeader h, const std::string& expected) {
  h.header_crc = storage::crc32_of(&h, offsetof(storage::store::FileHeader, header_crc));
  std::memcpy(file.data(), &h, sizeof h);
  write_file(store / "segments.bin", file);
  try {
    storage::Store::open(store);
    ADD_FAILURE() << "opened";
  } catch (const storage::StoreError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(HostileStore, CutBorderRecordClaimingMoreTetsThanItsStreamCanHoldIsRefused) {
  // a segment's tet count bounds what decoding it allocates (32 bytes a tet); a record may
  // claim at most one tet for every kMinStreamBytesPerTet bytes of its stream
  const auto dir = scratch_dir("segment_codec_tet_bomb");
  std::filesystem::copy(sample_store(Compression::kCutBorder), dir / "s");
  std::string file = read_file(dir / "s" / "segments.bin");
  storage::store::FileHeader h;
  std::memcpy(&h, file.data(), sizeof h);
  storage::store::SegmentRecord r;
  std::memcpy(&r, file.data() + h.directory_offset, sizeof r);
  const auto fixed = storage::store::segment_layout(r.vertex_count, r.tet_count, r.link_count, h.floats_per_vertex, Compression::kCutBorder);
  ASSERT_GE(r.bytes - fixed.bytes, storage::store::kMinStreamBytesPerTet * r.tet_count);  // the real record is within the limit
  r.tet_count = static_cast<uint32_t>((r.bytes - fixed.bytes) / storage::store::kMinStreamBytesPerTet + 1);
  std::memcpy(file.data() + h.directory_offset, &r, sizeof r);
  h.directory_crc = storage::crc32_of(file.data() + h.directory_offset, size_t{h.segment_count} * sizeof r);
  write_header_and_expect_refused(dir / "s", file, h, "segment 0: size does not match its counts");
}

TEST(HostileStore, CompressedStoreClaimingVersion1IsRefused) {
  const auto dir = scratch_dir("segment_codec_version");
  std::filesystem::copy(sample_store(Compression::kCutBorder), dir / "s");
  // an older writer's version with a compression set: refused by name, not misread
  std::string file = read_file(dir / "s" / "segments.bin");
  storage::store::FileHeader h;
  std::memcpy(&h, file.data(), sizeof h);
  h.version = storage::store::kFormatVersion;
  write_header_and_expect_refused(dir / "s", file, h, "unknown segment compression 2");
}

}  // namespace
}  // namespace tetrascope::testing
