// Stage 4 of `tetrascope preprocess`: the multi-triangulation into a store. segments.bin holds
// every level's segments (level 0 in streaming order, §6.1.3, then the coarser levels), each
// with its face adjacency inside the segment and links to the segments of the same level;
// dag.bin the DAG and the error histograms; manifest.json the counts and build parameters.
#include <algorithm>
#include <array>
#include <cstring>
#include <limits>

#include "mt_stages.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/mt/streaming_order.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/core/parallel_for.h"
#include "tetrascope/storage/boundary_tags.h"
#include "tetrascope/storage/store_writer.h"
#include "tetrascope/storage/tensor.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::lod::mt {
namespace {

// Which segment stores each vertex: input vertices by the level-0 partition, later ones by
// the first segment that uses them.
struct VertexOwners {
  std::vector<uint32_t> owner;               // per global vertex
  std::vector<std::vector<uint32_t>> owned;  // per segment, ascending
};

VertexOwners vertex_owners(const Hierarchy& h, uint64_t vertex_total) {
  const uint32_t node_count = static_cast<uint32_t>(h.nodes.size());
  VertexOwners out;
  out.owner.assign(vertex_total, kNone);
  std::copy(h.level0_owner.begin(), h.level0_owner.end(), out.owner.begin());
  std::vector<uint32_t> buffer;
  for (uint32_t n = h.level_first[1]; n < node_count; ++n)  // every input vertex has its owner
    for (uint32_t g : h.nodes.read(n, buffer))
      if (out.owner[g] == kNone) out.owner[g] = n;
  out.owned.resize(node_count);
  for (uint64_t g = 0; g < vertex_total; ++g) out.owned[out.owner[g]].push_back(static_cast<uint32_t>(g));
  return out;
}

// The faces of each segment shared with another segment of its level; the faces inside a
// segment are paired again as it is written (segment_data), so that only the borders are held.
struct SegmentAdjacency {
  std::vector<std::vector<storage::store::BorderLink>> links;      // per segment
  std::vector<std::vector<uint32_t>> neighbours;                   // per segment, may repeat
};

// Each segment's tets as stored: with the cut-border coding, every patch's tets reordered
// depth first (mt_tet_order.cpp); then its faces paired inside it, and the open ones across the
// segments of the same level.
SegmentAdjacency pair_segment_faces(Hierarchy& h, std::span<const PatchRange> arcs, bool order_patches, unsigned threads) {
  const uint32_t node_count = static_cast<uint32_t>(h.nodes.size());
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> patches(node_count);  // per floor: (begin, count)
  if (order_patches)
    for (const PatchRange& a : arcs) patches[a.floor].push_back({a.begin, a.count});
  SegmentAdjacency out;
  out.links.resize(node_count);
  out.neighbours.resize(node_count);
  struct Scratch {
    FacePairingScratch pairing;
    std::vector<uint32_t> tets, opposite, buffer;
    PatchOrderer orderer;
  };
  std::vector<Scratch> scratch(std::max(1u, threads));  // one per worker
  for (uint32_t L = 0; L < h.level_count(); ++L) {
    std::vector<std::vector<OpenFace>> unpaired(h.level_first[L + 1] - h.level_first[L]);
    parallel_for(unpaired.size(), threads, [&](size_t i, unsigned worker) {
      const uint32_t n = h.level_first[L] + static_cast<uint32_t>(i);
      Scratch& s = scratch[worker];
      const std::span<const uint32_t> ids = h.nodes.read(n, s.buffer);
      s.tets.assign(ids.begin(), ids.end());
      if (!patches[n].empty()) {
        s.orderer.order(s.tets, patches[n]);
        h.nodes.write(n, 0, s.tets);
      }
      pair_faces(s.tets, s.pairing, s.opposite);  // unpaired faces: kNoOppositeFace == kMeshBoundary
      for (uint32_t f = 0; f < s.opposite.size(); ++f)
        if (s.opposite[f] == storage::store::kMeshBoundary) unpaired[i].push_back({face_key(tet_face(s.tets, f / 4, int(f % 4))), n, f});
    });
    size_t open = 0;
    for (const auto& u : unpaired) open += u.size();
    std::vector<OpenFace> rest;  // sized once: growing could take twice its bytes, at the writer's peak
    rest.reserve(open);
    for (auto& u : unpaired) {
      rest.insert(rest.end(), u.begin(), u.end());
      std::vector<OpenFace>().swap(u);
    }
    pair_open_faces(rest, [&](const OpenFace& x, const OpenFace& y) {
      if (x.segment == y.segment) return;
      out.links[x.segment].push_back({x.face, y.segment, y.face});
      out.links[y.segment].push_back({y.face, x.segment, x.face});
      out.neighbours[x.segment].push_back(y.segment);
      out.neighbours[y.segment].push_back(x.segment);
    });
    for (uint32_t n = h.level_first[L]; n < h.level_first[L + 1]; ++n) out.links[n].shrink_to_fit();  // held until written
  }
  return out;
}

// Bounds of every segment (its tets' vertices and its owned ones); segments that share a
// vertex copy become neighbours. Sorts and dedups the neighbour lists.
std::vector<std::array<float, 6>> segment_bounds(const Hierarchy& h, const VertexTable& table, const VertexOwners& owners,
                                                 std::vector<std::vector<uint32_t>>& neighbours) {
  const uint32_t node_count = static_cast<uint32_t>(h.nodes.size());
  std::vector<std::array<float, 6>> node_bounds(node_count);
  std::vector<uint32_t> buffer;
  for (uint32_t n = 0; n < node_count; ++n) {
    const std::span<const uint32_t> ids = h.nodes.read(n, buffer);
    auto& b = node_bounds[n];
    b = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
         std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest()};
    auto extend = [&](uint32_t g) {
      for (int k = 0; k < 3; ++k) {
        b[k] = std::min(b[k], table.xyz[3 * size_t{g} + k]);
        b[3 + k] = std::max(b[3 + k], table.xyz[3 * size_t{g} + k]);
      }
    };
    for (uint32_t g : ids) extend(g);
    for (uint32_t g : owners.owned[n]) extend(g);
    // shared copies' owners are neighbours too
    for (uint32_t g : ids)
      if (owners.owner[g] != n) {
        neighbours[n].push_back(owners.owner[g]);
        neighbours[owners.owner[g]].push_back(n);
      }
  }
  for (auto& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return node_bounds;
}

// Segment n as stored: owned vertices, then shared copies (ascending global id), local tets.
// `local` is all kNone on entry and on return.
storage::SegmentData segment_data(uint32_t n, const StoreInput& in, const VertexOwners& owners, SegmentAdjacency& adjacency,
                                  const std::array<float, 6>& bounds, std::vector<uint32_t>& local, FacePairingScratch& pairing, std::vector<uint32_t>& buffer) {
  const VertexTable& table = in.mesh.table;
  const std::span<const uint32_t> node_tets = in.hierarchy.nodes.read(n, buffer);
  storage::SegmentData data;
  data.id = n;
  data.global_ids = owners.owned[n];
  data.owned_vertex_count = static_cast<uint32_t>(owners.owned[n].size());
  std::vector<uint32_t> shared;
  for (uint32_t g : node_tets)
    if (owners.owner[g] != n) shared.push_back(g);
  std::sort(shared.begin(), shared.end());
  shared.erase(std::unique(shared.begin(), shared.end()), shared.end());
  data.global_ids.insert(data.global_ids.end(), shared.begin(), shared.end());
  const size_t nv = data.global_ids.size();
  for (size_t l = 0; l < nv; ++l) local[data.global_ids[l]] = static_cast<uint32_t>(l);
  data.x.resize(nv);
  data.y.resize(nv);
  data.z.resize(nv);
  data.attributes.resize(nv * table.floats);
  for (size_t l = 0; l < nv; ++l) {
    const uint32_t g = data.global_ids[l];
    data.x[l] = table.xyz[3 * size_t{g}];
    data.y[l] = table.xyz[3 * size_t{g} + 1];
    data.z[l] = table.xyz[3 * size_t{g} + 2];
  }
  size_t base = 0, value_base = 0;
  for (const auto& a : in.mesh.attributes) {
    for (size_t l = 0; l < nv; ++l)
      for (uint32_t c = 0; c < a.components; ++c) data.attributes[base + l * a.components + c] = table.values[size_t{data.global_ids[l]} * table.floats + value_base + c];
    base += nv * a.components;
    value_base += a.components;
  }
  data.tets.resize(node_tets.size());
  for (size_t i = 0; i < data.tets.size(); ++i) data.tets[i] = local[node_tets[i]];
  for (uint32_t g : data.global_ids) local[g] = kNone;
  // tets are grouped by patch (dag.bin), not border-first: every tet counts as a border tet
  data.boundary_tet_count = static_cast<uint32_t>(data.tets.size() / 4);
  pair_faces(node_tets, pairing, data.opposites);  // the same pairing as pair_segment_faces'
  data.links = std::move(adjacency.links[n]);
  for (const storage::store::BorderLink& link : data.links) data.opposites[link.face] = storage::store::kSegmentBorder;
  std::sort(data.links.begin(), data.links.end(), [](const storage::store::BorderLink& a, const storage::store::BorderLink& b) { return a.face < b.face; });
  std::copy(bounds.begin(), bounds.end(), data.bounds);
  return data;
}

// dag.bin into the store's temporary directory; returns its size.
uint64_t write_dag_file(const StoreInput& in, const std::vector<std::array<float, 6>>& node_bounds, const std::filesystem::path& directory) {
  const Hierarchy& h = in.hierarchy;
  const uint32_t node_count = static_cast<uint32_t>(h.nodes.size());
  const uint32_t C = static_cast<uint32_t>(in.mesh.channels.size()), N = in.options.histogram_bins;
  std::vector<dag::Node> dag_nodes(node_count);
  std::vector<dag::Patch> dag_patches(in.arcs.size());
  for (uint32_t n = 0; n < node_count; ++n) {
    dag::Node& d = dag_nodes[n];
    d.level = h.nodes.level(n);
    d.tet_count = static_cast<uint32_t>(h.nodes.tet_count(n));
    std::copy(node_bounds[n].begin(), node_bounds[n].end(), d.bounds);
  }
  std::vector<uint32_t> parent_count(node_count, 0);
  for (uint32_t p = 0; p < in.arcs.size(); ++p) {
    dag_patches[p] = {in.arcs[p].ceiling, in.arcs[p].floor, in.arcs[p].begin, in.arcs[p].count};
    ++parent_count[in.arcs[p].floor];
    if (in.arcs[p].ceiling != dag::kRoot) {
      dag::Node& c = dag_nodes[in.arcs[p].ceiling];
      if (c.child_count == 0) c.first_child = p;
      ++c.child_count;
    }
  }
  for (uint32_t n = 0, at = 0; n < node_count; ++n) {
    dag_nodes[n].first_parent = at;
    dag_nodes[n].parent_count = parent_count[n];
    at += parent_count[n];
  }
  constexpr uint32_t K = dag::kKinds;
  std::vector<float> histograms(size_t{node_count} * C * K * N);
  for (uint32_t n = 0; n < node_count; ++n)
    for (uint32_t c = 0; c < C; ++c) {
      float* out = &histograms[(size_t{n} * C + c) * K * N];
      std::copy_n(h.field.begin() + (size_t{n} * C + c) * N, N, out);
      std::copy_n(h.spatial.begin() + (size_t{n} * C + c) * N, N, out + N);
      std::copy_n(h.mass.begin() + (size_t{n} * C + c) * 4 * N, 4 * N, out + 2 * N);
    }
  const std::filesystem::path dag_path = directory / "dag.bin";
  write_dag(dag_path, h.level_count(), dag_nodes, dag_patches, C, N, histograms);
  return std::filesystem::file_size(dag_path);
}

// Per level: segments, patches (arcs whose floor is on the level), tets and distinct vertices.
std::vector<LevelReport> level_reports(const Hierarchy& h, std::span<const PatchRange> arcs, uint64_t vertex_total) {
  std::vector<LevelReport> out;
  std::vector<uint32_t> buffer;
  std::vector<uint8_t> used;
  for (uint32_t L = 0; L < h.level_count(); ++L) {
    LevelReport lr;
    lr.level = L;
    lr.segments = h.level_first[L + 1] - h.level_first[L];
    lr.tets = h.level_tets(L);
    used.assign(vertex_total, 0);
    for (uint32_t n = h.level_first[L]; n < h.level_first[L + 1]; ++n)
      for (uint32_t g : h.nodes.read(n, buffer)) used[g] = 1;
    lr.vertices = static_cast<uint64_t>(std::count(used.begin(), used.end(), uint8_t{1}));
    for (const auto& p : arcs)
      if (p.floor >= h.level_first[L] && p.floor < h.level_first[L + 1]) ++lr.patches;
    out.push_back(lr);
  }
  return out;
}

nlohmann::json manifest_json(const StoreInput& in, const StreamOrder& order, const std::vector<LevelReport>& levels) {
  const IngestedMesh& mesh = in.mesh;
  const Hierarchy& h = in.hierarchy;
  uint64_t stored_tets = 0;
  for (uint32_t n = 0; n < h.nodes.size(); ++n) stored_tets += h.nodes.tet_count(n);
  const std::filesystem::path hashed = storage::fingerprinted_file(in.mesh_path);
  nlohmann::json manifest;
  manifest["format"] = "tetrascope-store";
  manifest["version"] = storage::store::kFormatVersion;
  std::error_code ec;
  manifest["source"] = {{"file", std::filesystem::absolute(in.mesh_path).string()}, {"format", storage::format_name(storage::format_from_path(in.mesh_path))},
                        {"bytes", std::filesystem::file_size(hashed, ec)}, {"sha256", in.source_sha256()}};
  manifest["counts"] = {{"vertices", mesh.table.size()}, {"tetrahedra", stored_tets}, {"segments", h.nodes.size()},
                        {"degenerate_tetrahedra", mesh.read_stats.degenerate}, {"reoriented_tetrahedra", mesh.read_stats.inverted},
                        {"dropped_unused_vertices", mesh.dropped_unused_vertices}, {"dropped_repeated_vertex_tetrahedra", mesh.read_stats.repeated_vertex}};
  nlohmann::json attribute_list = nlohmann::json::array();
  for (size_t a = 0; a < mesh.attributes.size(); ++a) {
    const double lo = mesh.attributes[a].components == 1 ? mesh.ranges[a][0] : 0, hi = mesh.ranges[a][1];
    attribute_list.push_back({{"name", mesh.attributes[a].name}, {"components", mesh.attributes[a].components}, {"min", lo}, {"max", hi},
                              {"range_of", mesh.attributes[a].components == 1 ? "value" : "magnitude"},
                              {"normalisation", {{"offset", lo}, {"scale", hi > lo ? 1.0 / (hi - lo) : 1.0}}}});
    if (a < mesh.component_ranges.size() && !mesh.component_ranges[a].empty()) attribute_list.back()["component_ranges"] = mesh.component_ranges[a];
    storage::add_attribute_kind_json(attribute_list.back(), mesh.attributes[a]);
  }
  manifest["attributes"] = attribute_list;
  const storage::Bounds& bounds = mesh.bounds;
  manifest["bounds"] = {{"min", {bounds.min[0], bounds.min[1], bounds.min[2]}}, {"max", {bounds.max[0], bounds.max[1], bounds.max[2]}}};
  manifest["stream"] = {{"tags", order.tags}, {"max_workload_segments", order.max_workload}};
  nlohmann::json level_list = nlohmann::json::array();
  for (const LevelReport& lr : levels)
    level_list.push_back({{"level", lr.level}, {"first_segment", h.level_first[lr.level]}, {"segments", lr.segments}, {"tets", lr.tets}, {"vertices", lr.vertices},
                          {"patches", lr.patches}});
  const PreprocessOptions& options = in.options;
  manifest["multiresolution"] = {{"dag", "dag.bin"}, {"model", model_name(options.model)}, {"input", {{"vertices", mesh.input_vertices}, {"tetrahedra", mesh.input_tets}}}, {"levels", level_list},
                                 {"patches", in.arcs.size()}, {"histogram_bins", options.histogram_bins},
                                 {"build", {{"segment_tets", options.segment_tets}, {"grading", mesh.grading}, {"min_segments", options.min_segments}, {"base_tets", options.base_tets}, {"level_ratio", options.level_ratio}, {"level_targets", options.common_error ? "error" : "ratio"}, {"variants", options.variants}, {"seed", options.seed}}}};
  if (options.model == MultiresModel::kBinary)
    manifest["multiresolution"]["build"]["binary"] = {{"dependency_ratio", options.dependency_ratio}, {"dependencies", h.dependencies}};
  if (h.variants && !h.variants->empty()) manifest["multiresolution"]["variants"] = {{"file", "variants.bin"}, {"tets", h.variants->tets()}};
  if (in.vertices)
    manifest["multiresolution"]["vertices"] = {{"file", kVertexHierarchyFile}, {"collapses", in.vertices->collapse_count()}, {"base_tets", in.vertices->base_tets()}};
  return manifest;
}

// An order-free fingerprint of a set of tets (each by its sorted vertex ids): two sums of
// 64-bit mixes, so two sets agree on it only when they hold the same tets.
struct TetFingerprint {
  uint64_t count = 0, a = 0, b = 0;
  static uint64_t mix(uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
  }
  void add(std::array<uint32_t, 4> t) {
    std::sort(t.begin(), t.end());
    const uint64_t lo = (uint64_t{t[0]} << 32) | t[1], hi = (uint64_t{t[2]} << 32) | t[3];
    ++count;
    a += mix(lo ^ mix(hi));
    b += mix(hi + 0x632BE59BD9B4E019ull * mix(lo + 1));
  }
  bool operator==(const TetFingerprint&) const = default;
};

TetFingerprint fingerprint_of(const std::vector<uint32_t>& tets) {
  TetFingerprint f;
  for (size_t t = 0; t + 3 < tets.size(); t += 4) f.add({tets[t], tets[t + 1], tets[t + 2], tets[t + 3]});
  return f;
}

// Whether the hierarchy's leaves are the store's input vertices bit for bit (the same
// numbering, positions and values), so that vertices.bin can leave them to segments.bin.
bool leaves_match(const VertexHierarchy& h, const VertexTable& table) {
  const size_t V = h.input_vertices, F = h.value_floats;
  if (table.size() < V || table.floats != F) return false;
  auto same = [](const float* a, const float* b, size_t floats) { return floats == 0 || std::memcmp(a, b, floats * sizeof(float)) == 0; };
  return same(h.positions.data(), table.xyz.data(), 3 * V) && same(h.values.data(), table.values.data(), F * V);
}

}  // namespace

StoreOutput write_mt_store(const StoreInput& in, const StageProgress& stage) {
  Hierarchy& h = in.hierarchy;
  const VertexTable& table = in.mesh.table;
  const uint32_t node_count = static_cast<uint32_t>(h.nodes.size());
  const uint64_t vertex_total = table.size();
  const VertexOwners owners = vertex_owners(h, vertex_total);
  SegmentAdjacency adjacency = pair_segment_faces(h, in.arcs, in.options.compression == storage::store::Compression::kCutBorder, in.options.threads);
  const std::vector<std::array<float, 6>> node_bounds = segment_bounds(h, table, owners, adjacency.neighbours);
  // level 0 in streaming order (§6.1.3), then the coarser levels
  const uint32_t level0 = h.level_first[1];
  std::vector<std::vector<uint32_t>> level0_neighbours(level0);
  for (uint32_t n = 0; n < level0; ++n)
    for (uint32_t m : adjacency.neighbours[n])
      if (m < level0) level0_neighbours[n].push_back(m);
  const StreamOrder order = streaming_order(level0_neighbours, std::span<const std::array<float, 6>>(node_bounds.data(), level0));
  std::vector<uint32_t> write_order = order.order;
  for (uint32_t n = level0; n < node_count; ++n) write_order.push_back(n);

  storage::StoreWriter writer(in.store_path, in.options.replace, vertex_total, node_count, table.floats, in.options.compression);
  std::vector<uint32_t> local(vertex_total, kNone), buffer;
  FacePairingScratch pairing;
  uint64_t written = 0;
  TetFingerprint finest;  // the input's tets as the finest level's segments hold them
  for (uint32_t n : write_order) {
    storage::SegmentData data = segment_data(n, in, owners, adjacency, node_bounds[n], local, pairing, buffer);
    if (n < level0 && in.vertices)
      for (size_t t = 0; t + 3 < data.tets.size(); t += 4)
        finest.add({data.global_ids[data.tets[t]], data.global_ids[data.tets[t + 1]], data.global_ids[data.tets[t + 2]], data.global_ids[data.tets[t + 3]]});
    writer.add_segment(std::move(data));
    stage("write", 0.9 * double(++written) / node_count);
  }
  StoreOutput out;
  out.dag_bytes = write_dag_file(in, node_bounds, writer.temp_directory());
  if (h.variants) out.variants_bytes = h.variants->write(writer.temp_directory() / "variants.bin", node_count);
  if (in.vertices) {
    // what the store holds already is left out of vertices.bin, where it is the same
    const bool leaves = leaves_match(*in.vertices, table);
    write_vertex_hierarchy(writer.temp_directory() / kVertexHierarchyFile, *in.vertices,
                           {.leaves_in_store = leaves, .tets_in_store = leaves && fingerprint_of(in.vertices->tets) == finest});
    out.vertices_bytes = std::filesystem::file_size(writer.temp_directory() / kVertexHierarchyFile);
  }
  if (!in.mesh.face_tags.empty()) out.boundary_tags_bytes = storage::write_boundary_tags(writer.temp_directory() / storage::kBoundaryTagsFile, in.mesh.face_tags);
  out.levels = level_reports(h, in.arcs, vertex_total);
  nlohmann::json manifest = manifest_json(in, order, out.levels);
  if (!in.mesh.face_tags.empty()) manifest["boundary_tags"] = storage::boundary_tags_manifest(in.mesh.face_tags, out.boundary_tags_bytes);
  stage("write", 0.95);
  writer.finish(adjacency.neighbours, manifest);
  out.store_bytes = writer.bytes_written() + out.dag_bytes + out.variants_bytes + out.vertices_bytes + out.boundary_tags_bytes;
  return out;
}

}  // namespace tetrascope::lod::mt
