// Whole-store checks beyond the per-block ones of Store::open / map_segment: every vertex is
// are symmetric and join faces with the same vertices, links across segments point back,
// and border tets come first.
#include "tetrascope/storage/store_verify.h"

#include "tetrascope/storage/boundary_tags.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>

#include "tetrascope/storage/boundary_tags.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::storage {

using namespace store;

nlohmann::json VerifyReport::to_json() const {
  return {{"ok", ok}, {"problems", problems}, {"segments", segments}, {"vertices", vertices}, {"tetrahedra", tets},
          {"shared_vertex_copies", shared_vertex_copies}, {"border_faces", border_faces}, {"boundary_faces", boundary_faces}};
}

namespace {
constexpr size_t kMaxProblems = 20;

// The face's key in global vertex ids (comparable across segments).
FaceVertices face_vertices(const SegmentView& v, uint32_t face) {
  FaceVertices g = tet_face(v.tets, face / 4, int(face % 4));
  for (uint32_t& id : g) id = v.global_ids[id];
  return face_key(g);
}

// Records one problem; only the first kMaxProblems are kept.
void add_problem(VerifyReport& r, const std::string& text) {
  if (r.problems.size() < kMaxProblems) r.problems.push_back(text);
}

// Copies local vertex l's attributes, vertex-major, into out.
void copy_attributes(const Store& store, const SegmentView& v, uint32_t l, float* out) {
  // attribute a of local vertex l sits at vertex_count * offset_a + l * components_a (attribute-major)
  uint32_t offset = 0;
  for (const StoreAttribute& a : store.manifest().attributes) {
    for (uint32_t k = 0; k < a.components; ++k) out[offset + k] = v.attributes[size_t{v.vertex_count} * offset + size_t{l} * a.components + k];
    offset += a.components;
  }
}

// Pass 1: each vertex's owner, and each owned vertex's coordinates and attributes in `data`
// (3 + floats per global vertex); reports vertices owned twice or not at all.
void check_owners(const Store& store, SegmentCache& cache, std::vector<uint32_t>& owner, std::vector<float>& data, Progress* progress, VerifyReport& r) {
  const FileHeader& h = store.header();
  const uint32_t floats = h.floats_per_vertex;
  if (progress) progress->begin("check segments");
  for (uint32_t s = 0; s < h.segment_count && r.problems.size() < kMaxProblems; ++s) {
    auto mapped = cache.get(s);
    const SegmentView& v = mapped->view();
    for (uint32_t l = 0; l < v.owned_vertex_count; ++l) {
      const uint32_t g = v.global_ids[l];
      if (owner[g] != 0xFFFFFFFFu) {
        add_problem(r, "segment " + std::to_string(s) + ": vertex " + std::to_string(g) + " is also owned by segment " + std::to_string(owner[g]));
        continue;
      }
      owner[g] = s;
      float* d = &data[size_t{g} * (3 + floats)];
      d[0] = v.x[l];
      d[1] = v.y[l];
      d[2] = v.z[l];
      copy_attributes(store, v, l, d + 3);
    }
    if (progress) progress->update(0.5 * (s + 1) / h.segment_count);
  }
  for (uint64_t g = 0; g < h.vertex_count && r.problems.size() < kMaxProblems; ++g) {
    if (owner[g] == 0xFFFFFFFFu) add_problem(r, "vertex " + std::to_string(g) + " is owned by no segment");
  }
}

// Reports overlapping blocks of segments.bin and padding between them that is not zero.
void check_padding(const Store& store, const std::filesystem::path& directory, VerifyReport& r) {
  // every byte outside the checksummed blocks is padding and must be zero
  const FileHeader& h = store.header();
  std::vector<std::pair<uint64_t, uint64_t>> blocks{{0, sizeof(FileHeader)},
                                                    {h.directory_offset, h.directory_offset + uint64_t{h.segment_count} * sizeof(SegmentRecord)},
                                                    {h.neighbours_offset, h.neighbours_offset + 4 * h.neighbour_total}};
  for (uint32_t s = 0; s < h.segment_count; ++s) blocks.push_back({store.record(s).offset, store.record(s).offset + store.record(s).bytes});
  std::sort(blocks.begin(), blocks.end());
  std::ifstream in(directory / "segments.bin", std::ios::binary);
  std::vector<char> gap;
  uint64_t at = 0;
  for (auto [begin, end] : blocks) {
    if (begin < at) {
      add_problem(r, "segments.bin: blocks overlap at byte " + std::to_string(begin));
    } else if (begin > at) {
      gap.resize(static_cast<size_t>(begin - at));
      in.seekg(static_cast<std::streamoff>(at));
      in.read(gap.data(), static_cast<std::streamsize>(gap.size()));
      for (size_t i = 0; i < gap.size(); ++i) {
        if (gap[i] != 0) {
          add_problem(r, "segments.bin: byte " + std::to_string(at + i) + ": padding is not zero");
          break;
        }
      }
    }
    at = std::max(at, end);
  }
}

// Pass 2 for segment s: shared copies equal their owner's (`copy` is scratch of floats per
// vertex), opposites are symmetric, border tets come first, links point back.
void check_segment(const Store& store, SegmentCache& cache, uint32_t s, bool multiresolution, const std::vector<uint32_t>& owner, const std::vector<float>& data,
                   std::vector<float>& copy, VerifyReport& r) {
  const uint32_t floats = store.header().floats_per_vertex;
  auto mapped = cache.get(s);
  const SegmentView& v = mapped->view();
  const std::string where = "segment " + std::to_string(s) + ": ";
  for (uint32_t l = v.owned_vertex_count; l < v.vertex_count; ++l) {
    const uint32_t g = v.global_ids[l];
    ++r.shared_vertex_copies;
    if (owner[g] == s) add_problem(r, where + "shared vertex " + std::to_string(g) + " is owned by this segment itself");
    const float* d = &data[size_t{g} * (3 + floats)];
    if (d[0] != v.x[l] || d[1] != v.y[l] || d[2] != v.z[l]) add_problem(r, where + "shared vertex " + std::to_string(g) + " differs from its owner's coordinates");
    copy_attributes(store, v, l, copy.data());
    if (floats > 0 && std::memcmp(copy.data(), d + 3, floats * sizeof(float)) != 0) add_problem(r, where + "shared vertex " + std::to_string(g) + " differs from its owner's attributes");
  }
  const uint32_t faces = 4 * v.tet_count;
  for (uint32_t f = 0; f < faces; ++f) {
    const uint32_t o = v.opposites[f];
    if (o == kMeshBoundary) {
      ++r.boundary_faces;
    } else if (o == kSegmentBorder) {
      ++r.border_faces;
      if (f / 4 >= v.boundary_tet_count) add_problem(r, where + "tet " + std::to_string(f / 4) + " has a border face but is not among the first " + std::to_string(v.boundary_tet_count));
    } else if (v.opposites[o] != f || o / 4 == f / 4) {
      add_problem(r, where + "opposites of faces " + std::to_string(f) + " and " + std::to_string(o) + " are not symmetric");
    } else if (face_vertices(v, f) != face_vertices(v, o)) {
      add_problem(r, where + "faces " + std::to_string(f) + " and " + std::to_string(o) + " are opposites but have different vertices");
    }
  }
  // a multiresolution store groups tets by patch (dag.bin) and counts them all as border tets
  for (uint32_t t = 0; t < v.boundary_tet_count && !multiresolution; ++t) {
    bool border = false;
    for (int f = 0; f < 4; ++f) border |= v.opposites[4 * t + f] == kSegmentBorder;
    if (!border) add_problem(r, where + "tet " + std::to_string(t) + " is listed as a border tet but has no border face");
  }
  for (const BorderLink& link : v.links) {
    auto remote = cache.get(link.segment);
    const SegmentView& w = remote->view();
    auto it = std::lower_bound(w.links.begin(), w.links.end(), link.remote_face, [](const BorderLink& a, uint32_t face) { return a.face < face; });
    if (it == w.links.end() || it->face != link.remote_face || it->segment != s || it->remote_face != link.face) {
      add_problem(r, where + "link of face " + std::to_string(link.face) + " to segment " + std::to_string(link.segment) + " does not point back");
    } else if (face_vertices(v, link.face) != face_vertices(w, link.remote_face)) {
      add_problem(r, where + "face " + std::to_string(link.face) + " and its partner in segment " + std::to_string(link.segment) + " have different vertices");
    }
    auto n = store.neighbours(s);
    if (!std::binary_search(n.begin(), n.end(), link.segment)) add_problem(r, where + "links to segment " + std::to_string(link.segment) + ", which is not listed as a neighbour");
  }
}
}  // namespace

VerifyReport verify_store(const std::filesystem::path& directory, Progress* progress) {
  VerifyReport r;
  try {
    auto store = Store::open(directory);
    const FileHeader& h = store->header();
    r.segments = h.segment_count;
    r.vertices = h.vertex_count;
    r.tets = h.tet_count;
    const uint32_t floats = h.floats_per_vertex;
    const bool multiresolution = store->manifest().json.contains("multiresolution");
    std::vector<float> copy(floats);
    SegmentCache cache(*store, 256ull << 20);
    // pass 1: owners, and each owned vertex's data
    std::vector<uint32_t> owner(h.vertex_count, 0xFFFFFFFFu);
    std::vector<float> data(h.vertex_count * (3 + uint64_t{floats}));
    check_owners(*store, cache, owner, data, progress, r);
    check_padding(*store, directory, r);
    // pass 2: shared copies, opposites, links, border tets first
    for (uint32_t s = 0; s < h.segment_count && r.problems.size() < kMaxProblems; ++s) {
      check_segment(*store, cache, s, multiresolution, owner, data, copy, r);
      if (progress) progress->update(0.5 + 0.5 * (s + 1) / h.segment_count);
    }
    open_boundary_tags(*store);  // boundary_tags.bin, when the manifest lists it: checksums, names, ids
  } catch (const std::exception& e) {
    add_problem(r, e.what());
  }
  r.ok = r.problems.empty();
  if (progress) progress->finish();
  return r;
}

}  // namespace tetrascope::storage
