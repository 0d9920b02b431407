// dag.bin: writing, and reading with every check a reader of an untrusted file needs.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include "tetrascope/core/tet_topology.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::lod {

using namespace dag;

namespace {

uint64_t align16(uint64_t v) { return (v + 15) & ~uint64_t{15}; }

template <class T>
uint32_t crc_of(std::span<const T> items) {
  return storage::crc32_of(items.data(), items.size_bytes());
}

}  // namespace

void write_dag(const std::filesystem::path& file, uint32_t levels, std::span<const Node> nodes, std::span<const Patch> patches, uint32_t channels,
               uint32_t bins, std::span<const float> histograms, uint32_t kinds) {
  if (kinds != kKinds && kinds != kKindsV1) throw std::invalid_argument("write_dag: " + std::to_string(kinds) + " histograms a node");
  if (histograms.size() != size_t{nodes.size()} * channels * kinds * bins) throw std::invalid_argument("write_dag: histograms of the wrong size");
  // parents: patch ids grouped by floor node, ascending
  std::vector<uint32_t> parents(patches.size());
  for (uint32_t p = 0; p < patches.size(); ++p) parents[p] = p;
  std::stable_sort(parents.begin(), parents.end(), [&](uint32_t a, uint32_t b) { return patches[a].floor < patches[b].floor; });
  Header h{};
  std::memcpy(h.magic, kFileMagic, sizeof h.magic);
  h.version = kinds == kKinds ? kFormatVersion : 1;
  h.header_bytes = sizeof(Header);
  h.level_count = levels;
  h.node_count = static_cast<uint32_t>(nodes.size());
  h.patch_count = static_cast<uint32_t>(patches.size());
  h.channel_count = channels;
  h.bins = bins;
  h.nodes_offset = align16(sizeof(Header));
  h.patches_offset = align16(h.nodes_offset + nodes.size_bytes());
  h.parents_offset = align16(h.patches_offset + patches.size_bytes());
  h.histograms_offset = align16(h.parents_offset + 4 * parents.size());
  h.file_bytes = h.histograms_offset + histograms.size_bytes();
  h.nodes_crc = crc_of(nodes);
  h.patches_crc = crc_of(patches);
  h.parents_crc = crc_of(std::span<const uint32_t>(parents));
  h.histograms_crc = crc_of(histograms);
  h.header_crc = storage::crc32_of(&h, offsetof(Header, header_crc));
  std::vector<char> bytes(h.file_bytes, 0);
  auto put = [&](uint64_t offset, const void* data, size_t size) {
    if (size) std::memcpy(bytes.data() + offset, data, size);  // (an empty span's data may be null)
  };
  put(0, &h, sizeof h);
  put(h.nodes_offset, nodes.data(), nodes.size_bytes());
  put(h.patches_offset, patches.data(), patches.size_bytes());
  put(h.parents_offset, parents.data(), 4 * parents.size());
  put(h.histograms_offset, histograms.data(), histograms.size_bytes());
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.flush();
  if (!out) throw std::runtime_error(file.string() + ": cannot write (disk full?)");
}

std::unique_ptr<Dag> Dag::open(const std::filesystem::path& file, std::span<const uint32_t> segment_tets) {
  const std::string name = file.string() + ": ";
  auto fail = [&](const std::string& what) { throw DagError(name + what); };
  std::ifstream in(file, std::ios::binary);
  if (!in) throw DagIoError(name + "cannot open");
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto dag = std::unique_ptr<Dag>(new Dag());
  Header& h = dag->header_;
  if (bytes.size() < sizeof(Header)) fail("too short for a header (" + std::to_string(bytes.size()) + " bytes)");
  std::memcpy(&h, bytes.data(), sizeof h);
  if (std::memcmp(h.magic, kFileMagic, sizeof h.magic) != 0) fail("not a tetrascope DAG (bad magic)");
  if (h.version != kFormatVersion && h.version != 1) fail("format version " + std::to_string(h.version) + ", this build reads 1 and " + std::to_string(kFormatVersion));
  dag->kinds_ = h.version == 1 ? kKindsV1 : kKinds;
  if (h.header_crc != storage::crc32_of(&h, offsetof(Header, header_crc))) fail("header checksum mismatch");
  if (h.header_bytes != sizeof(Header) || h.file_bytes != bytes.size()) fail("file size " + std::to_string(bytes.size()) + " does not match the header's " + std::to_string(h.file_bytes));
  if (h.node_count != segment_tets.size()) fail(std::to_string(h.node_count) + " nodes for " + std::to_string(segment_tets.size()) + " segments");
  if (h.level_count == 0 || h.level_count > kMaxLevels) fail("bad level count " + std::to_string(h.level_count));
  if (h.bins == 0 || h.bins > kMaxBins || h.channel_count > 1024) fail("bad histogram shape");
  auto block = [&](uint64_t offset, uint64_t count, uint64_t item, uint32_t crc, const char* what, auto& out) {
    if (offset % 4 != 0 || offset > h.file_bytes || count > (h.file_bytes - offset) / item) fail(std::string(what) + " block out of the file");
    out.resize(count);
    if (count) std::memcpy(out.data(), bytes.data() + offset, count * item);
    if (storage::crc32_of(out.data(), count * item) != crc) fail(std::string(what) + " checksum mismatch");
  };
  block(h.nodes_offset, h.node_count, sizeof(Node), h.nodes_crc, "nodes", dag->nodes_);
  block(h.patches_offset, h.patch_count, sizeof(Patch), h.patches_crc, "patches", dag->patches_);
  block(h.parents_offset, h.patch_count, 4, h.parents_crc, "parents", dag->parents_);
  block(h.histograms_offset, uint64_t{h.node_count} * h.channel_count * dag->kinds_ * h.bins, 4, h.histograms_crc, "histograms", dag->histograms_);
  // patches: grouped by ceiling, roots first; each floor's patches tile its tets exactly
  uint32_t p = 0;
  while (p < h.patch_count && dag->patches_[p].ceiling == kRoot) ++p;
  dag->root_patches_ = p;
  if (p == 0) fail("no root patches");
  std::vector<uint32_t> covered(h.node_count, 0);
  for (uint32_t i = 0; i < h.patch_count; ++i) {
    const Patch& q = dag->patches_[i];
    const std::string where = "patch " + std::to_string(i) + ": ";
    if (q.floor >= h.node_count) fail(where + "floor node " + std::to_string(q.floor) + " out of range");
    if (i >= p && q.ceiling >= h.node_count) fail(where + "ceiling node out of range");
    if (i > p && q.ceiling < dag->patches_[i - 1].ceiling) fail(where + "patches are not grouped by ceiling");
    if (q.tet_count == 0 || q.tet_begin > segment_tets[q.floor] || q.tet_count > segment_tets[q.floor] - q.tet_begin) fail(where + "tet range out of its floor segment");
    if (q.ceiling != kRoot && dag->nodes_.size() > q.ceiling && dag->nodes_[q.ceiling].level != dag->nodes_[q.floor].level + 1) fail(where + "does not join consecutive levels");
    covered[q.floor] += q.tet_count;
  }
  for (uint32_t n = 0; n < h.node_count; ++n) {
    const Node& node = dag->nodes_[n];
    const std::string where = "node " + std::to_string(n) + ": ";
    if (node.level >= h.level_count) fail(where + "level out of range");
    if (node.tet_count != segment_tets[n]) fail(where + "tet count differs from its segment's");
    if (covered[n] != node.tet_count) fail(where + "its patches cover " + std::to_string(covered[n]) + " of its " + std::to_string(node.tet_count) + " tets");
    if (node.first_child > h.patch_count || node.child_count > h.patch_count - node.first_child) fail(where + "child patches out of range");
    for (uint32_t c = node.first_child; c < node.first_child + node.child_count; ++c) {
      if (dag->patches_[c].ceiling != n) fail(where + "child patch " + std::to_string(c) + " has another ceiling");
    }
    if ((node.level == 0) != (node.child_count == 0)) fail(where + (node.level == 0 ? "a finest segment with child patches" : "a coarse segment without child patches"));
    if (node.first_parent > h.patch_count || node.parent_count == 0 || node.parent_count > h.patch_count - node.first_parent) fail(where + "parent patches out of range");
    for (uint32_t i = node.first_parent; i < node.first_parent + node.parent_count; ++i) {
      if (dag->parents_[i] >= h.patch_count || dag->patches_[dag->parents_[i]].floor != n) fail(where + "parent list names a patch of another floor");
    }
    // the patch ranges tile the tets in order
    uint32_t at = 0;
    std::vector<std::pair<uint32_t, uint32_t>> ranges;
    for (uint32_t i = node.first_parent; i < node.first_parent + node.parent_count; ++i) ranges.push_back({dag->patches_[dag->parents_[i]].tet_begin, dag->patches_[dag->parents_[i]].tet_count});
    std::sort(ranges.begin(), ranges.end());
    for (auto [begin, count] : ranges) {
      if (begin != at) fail(where + "patch ranges overlap or leave a gap at tet " + std::to_string(at));
      at += count;
    }
    for (float b : node.bounds)
      if (!std::isfinite(b)) fail(where + "bounds are not finite");
  }
  uint64_t covered_children = 0;
  for (uint32_t n = 0; n < h.node_count; ++n) covered_children += dag->nodes_[n].child_count;
  if (covered_children + p != h.patch_count) fail("child patch lists do not cover every patch once");
  // every value finite; the errors and masses (kinds 0-2) not negative (centroids may be)
  for (size_t i = 0; i < dag->histograms_.size(); ++i) {
    const float v = dag->histograms_[i];
    if (!std::isfinite(v) || (v < 0 && (i / h.bins) % dag->kinds_ < 3)) fail("a histogram value is negative or not finite");
  }
  return dag;
}

std::unique_ptr<Dag> open_dag(const storage::Store& store) {
  if (!store.manifest().json.contains("multiresolution")) return nullptr;
  std::vector<uint32_t> tets(store.segment_count());
  for (uint32_t s = 0; s < tets.size(); ++s) tets[s] = store.record(s).tet_count;
  return Dag::open(store.path() / "dag.bin", tets);
}

std::vector<std::string> verify_dag(const storage::Store& store, const Dag& dag, size_t limit) {
  std::vector<std::string> problems;
  auto problem = [&](const std::string& text) {
    if (problems.size() < limit) problems.push_back(text);
  };
  using Face = std::array<uint32_t, 3>;
  // faces (global ids) that appear once among the given tet ranges and are not on the
  // boundary of the whole mesh (which simplification may change)
  auto boundary = [&](const std::vector<std::pair<uint32_t, std::pair<uint32_t, uint32_t>>>& ranges) {
    std::vector<Face> faces;
    for (const auto& [segment, range] : ranges) {
      auto mapped = store.map_segment(segment);
      const auto& v = mapped->view();
      for (uint32_t t = range.first; t < range.first + range.second; ++t)
        for (int f = 0; f < 4; ++f) {
          if (v.opposites[4 * size_t{t} + f] == storage::store::kMeshBoundary) continue;
          Face face = tet_face(v.tets, t, f);
          for (uint32_t& g : face) g = v.global_ids[g];
          faces.push_back(face_key(face));
        }
    }
    std::sort(faces.begin(), faces.end());
    std::vector<Face> once;
    for (size_t i = 0; i < faces.size();) {
      size_t j = i + 1;
      while (j < faces.size() && faces[j] == faces[i]) ++j;
      if (j - i == 1) once.push_back(faces[i]);
      i = j;
    }
    return once;
  };
  for (uint32_t n = 0; n < dag.node_count() && problems.size() < limit; ++n) {
    const dag::Node& node = dag.node(n);
    if (node.child_count == 0) continue;
    std::vector<std::pair<uint32_t, std::pair<uint32_t, uint32_t>>> own{{n, {0, node.tet_count}}}, children;
    for (const auto& p : dag.child_patches(n)) children.push_back({p.floor, {p.tet_begin, p.tet_count}});
    const auto mine = boundary(own), theirs = boundary(children);
    if (mine != theirs) {
      std::vector<Face> only_mine, only_theirs;
      std::set_difference(mine.begin(), mine.end(), theirs.begin(), theirs.end(), std::back_inserter(only_mine));
      std::set_difference(theirs.begin(), theirs.end(), mine.begin(), mine.end(), std::back_inserter(only_theirs));
      auto first = [](const std::vector<Face>& f) {
        return f.empty() ? std::string("-") : std::to_string(f[0][0]) + "," + std::to_string(f[0][1]) + "," + std::to_string(f[0][2]);
      };
      problem("segment " + std::to_string(n) + " (level " + std::to_string(node.level) + "): its boundary differs from its child patches' (refining it would break the mesh): " +
              std::to_string(only_mine.size()) + " faces only in it (first " + first(only_mine) + "), " + std::to_string(only_theirs.size()) +
              " only in the children (first " + first(only_theirs) + ")");
    }
    for (const auto& p : dag.child_patches(n))
      for (uint32_t c = 0; c < dag.channel_count(); ++c)
        for (uint32_t b = 0; b < dag.bins(); ++b)
          if (dag.field_histogram(n, c)[b] < dag.field_histogram(p.floor, c)[b] || dag.spatial_histogram(n, c)[b] < dag.spatial_histogram(p.floor, c)[b]) {
            problem("segment " + std::to_string(n) + ": error histogram below its child segment " + std::to_string(p.floor) + "'s");
            b = dag.bins();
            c = dag.channel_count();
          }
  }
  return problems;
}

}  // namespace tetrascope::lod
