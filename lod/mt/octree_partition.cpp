// Octree + METIS vertex partition, dissertation §6.1.1 (after Sondershaus 2007): leaves hold
// at most K vertices; a graph joins leaves whose boxes share a face (not an edge or a
// corner), node weight = vertices in the leaf, edge weight = distance between leaf centres;
// METIS k-way cuts it into balanced parts.
#include "tetrascope/lod/mt/octree_partition.h"

#include <metis.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace tetrascope::lod {
namespace {

constexpr int kMaxDepth = 20;  // boxes in units of 2^-20 of the root; coincident points stop here

struct Node {
  uint32_t begin, end;     // range in the vertex index array
  uint32_t lo[3];
  int depth;
};

// The leaf graph in CSR form: leaves whose boxes share a face (a leaf's high face lies on
// another's low face, per axis and coordinate, and the two overlap across it).
void leaf_adjacency(VertexPartition& result) {
  const size_t leaves = result.leaves.size();
  std::vector<std::vector<uint32_t>> neighbours(leaves);
  for (int axis = 0; axis < 3; ++axis) {
    std::unordered_map<uint32_t, std::vector<uint32_t>> low_faces;
    for (uint32_t l = 0; l < leaves; ++l) low_faces[result.leaves[l].lo[axis]].push_back(l);
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (uint32_t a = 0; a < leaves; ++a) {
      const OctreeLeaf& A = result.leaves[a];
      auto it = low_faces.find(A.hi[axis]);
      if (it == low_faces.end()) continue;
      for (uint32_t b : it->second) {
        const OctreeLeaf& B = result.leaves[b];
        if (A.lo[u] < B.hi[u] && B.lo[u] < A.hi[u] && A.lo[v] < B.hi[v] && B.lo[v] < A.hi[v]) {
          neighbours[a].push_back(b);
          neighbours[b].push_back(a);
        }
      }
    }
  }
  result.adjacency_begin.assign(1, 0);
  for (auto& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    result.adjacency.insert(result.adjacency.end(), list.begin(), list.end());
    result.adjacency_begin.push_back(static_cast<uint32_t>(result.adjacency.size()));
  }
}

// Whether the leaf graph is one component (a breadth-first walk from leaf 0).
bool leaf_graph_connected(const VertexPartition& result) {
  const size_t leaves = result.leaves.size();
  if (leaves == 0) return true;
  std::vector<uint8_t> seen(leaves, 0);
  std::vector<uint32_t> queue{0};
  seen[0] = 1;
  for (size_t at = 0; at < queue.size(); ++at)
    for (uint32_t e = result.adjacency_begin[queue[at]]; e < result.adjacency_begin[queue[at] + 1]; ++e)
      if (!seen[result.adjacency[e]]) {
        seen[result.adjacency[e]] = 1;
        queue.push_back(result.adjacency[e]);
      }
  return queue.size() == leaves;
}

// Every vertex's integer position at the finest level, in a cube around the bounds.
std::vector<std::array<uint32_t, 3>> finest_cells(std::span<const float> xyz, size_t n) {
  // root box: a cube around the bounds
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = hi[k] = xyz[static_cast<size_t>(k)];
  }
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min<double>(lo[k], xyz[3 * i + k]);
      hi[k] = std::max<double>(hi[k], xyz[3 * i + k]);
    }
  }
  double size = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30}) * (1 + 1e-9);
  const uint32_t cells = 1u << kMaxDepth;
  // integer position of every vertex at the finest level
  std::vector<std::array<uint32_t, 3>> cell(n);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      double t = (xyz[3 * i + k] - lo[k]) / size * cells;
      cell[i][k] = static_cast<uint32_t>(std::clamp(t, 0.0, double(cells - 1)));
    }
  }
  return cell;
}

// Splits the root box into octants until a box holds at most k_leaf vertices (or reaches
// kMaxDepth); fills result's leaves, in octant order, and leaf_of_vertex.
void build_octree(const std::vector<std::array<uint32_t, 3>>& cell, uint32_t k_leaf, VertexPartition& result) {
  const size_t n = cell.size();
  const uint32_t cells = 1u << kMaxDepth;
  std::vector<uint32_t> order(n), scratch(n);
  for (size_t i = 0; i < n; ++i) order[i] = static_cast<uint32_t>(i);
  result.leaf_of_vertex.assign(n, 0);

  std::vector<Node> stack{{0, static_cast<uint32_t>(n), {0, 0, 0}, 0}};
  while (!stack.empty()) {
    Node node = stack.back();
    stack.pop_back();
    const uint32_t count = node.end - node.begin;
    const uint32_t extent = cells >> node.depth;
    if (count <= k_leaf || node.depth == kMaxDepth) {
      if (count == 0) continue;
      OctreeLeaf leaf{};
      for (int k = 0; k < 3; ++k) {
        leaf.lo[k] = node.lo[k];
        leaf.hi[k] = node.lo[k] + extent;
      }
      leaf.vertex_count = count;
      uint32_t id = static_cast<uint32_t>(result.leaves.size());
      result.leaves.push_back(leaf);
      for (uint32_t i = node.begin; i < node.end; ++i) result.leaf_of_vertex[order[i]] = id;
      continue;
    }
    // split into 8 children by counting sort on the octant
    const uint32_t half = extent / 2;
    uint32_t counts[8] = {};
    auto octant = [&](uint32_t v) {
      int o = 0;
      for (int k = 0; k < 3; ++k) o |= (cell[v][k] >= node.lo[k] + half ? 1 : 0) << k;
      return o;
    };
    for (uint32_t i = node.begin; i < node.end; ++i) ++counts[octant(order[i])];
    uint32_t starts[8], at = node.begin;
    for (int o = 0; o < 8; ++o) {
      starts[o] = at;
      at += counts[o];
    }
    uint32_t fill[8];
    std::copy(starts, starts + 8, fill);
    for (uint32_t i = node.begin; i < node.end; ++i) scratch[fill[octant(order[i])]++] = order[i];
    std::copy(scratch.begin() + node.begin, scratch.begin() + node.end, order.begin() + node.begin);
    for (int o = 7; o >= 0; --o) {  // pushed in reverse so leaves come out in octant order
      Node child{starts[o], starts[o] + counts[o], {node.lo[0], node.lo[1], node.lo[2]}, node.depth + 1};
      for (int k = 0; k < 3; ++k) {
        if (o & (1 << k)) child.lo[k] += half;
      }
      stack.push_back(child);
    }
  }
}

// Cuts the leaf graph into `parts` (> 1) parts with METIS; fills result's part_of_leaf and
// contiguous. n is the vertex count.
void cut_leaf_graph(VertexPartition& result, uint32_t parts, const PartitionOptions& options, std::span<const float> tets_per_vertex, size_t n) {
  const size_t leaves = result.leaves.size();
  std::vector<idx_t> xadj(result.adjacency_begin.begin(), result.adjacency_begin.end());
  std::vector<idx_t> adjncy(result.adjacency.begin(), result.adjacency.end());
  // Node weight: the leaf's vertices (§6.1.1), or its share of the tets when given, which
  // balances tets where the tets-per-vertex ratio varies (vertices on the mesh boundary
  // have fewer tets).
  idx_t ncon = 1;
  std::vector<idx_t> vwgt(leaves), adjwgt(adjncy.size());
  if (tets_per_vertex.empty()) {
    for (size_t l = 0; l < leaves; ++l) vwgt[l] = static_cast<idx_t>(result.leaves[l].vertex_count);
  } else {
    std::vector<double> leaf_tets(leaves, 0.0);
    for (size_t v = 0; v < n; ++v) leaf_tets[result.leaf_of_vertex[v]] += tets_per_vertex[v];
    for (size_t l = 0; l < leaves; ++l) vwgt[l] = std::max<idx_t>(1, static_cast<idx_t>(std::lround(leaf_tets[l])));
  }
  auto centre = [&](uint32_t l, int k) { return 0.5 * (double(result.leaves[l].lo[k]) + result.leaves[l].hi[k]); };
  double longest = 1;
  std::vector<double> distance(adjncy.size());
  for (uint32_t a = 0; a < leaves; ++a) {
    for (uint32_t e = result.adjacency_begin[a]; e < result.adjacency_begin[a + 1]; ++e) {
      uint32_t b = result.adjacency[e];
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += (centre(a, k) - centre(b, k)) * (centre(a, k) - centre(b, k));
      distance[e] = std::sqrt(d2);
      longest = std::max(longest, distance[e]);
    }
  }
  for (size_t e = 0; e < adjncy.size(); ++e) adjwgt[e] = 1 + static_cast<idx_t>(std::lround(1000.0 * distance[e] / longest));
  idx_t nvtxs = static_cast<idx_t>(leaves), nparts = static_cast<idx_t>(parts), objval = 0;
  std::vector<idx_t> part(leaves);
  // METIS draws from GKlib's random generator, one for the whole process and seeded by each
  // call: two partitions at once (ranks played by threads in mt_share_test) would draw from
  // one stream and cut differently from the same seed
  static std::mutex metis_mutex;
  const std::lock_guard metis_lock(metis_mutex);
  idx_t metis_options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(metis_options);
  metis_options[METIS_OPTION_SEED] = options.seed;
  // contiguous parts only where the leaf graph is connected: METIS refuses them otherwise,
  // and says "METIS Error" on the console, which a user reads as a failure
  const bool connected = leaf_graph_connected(result);
  metis_options[METIS_OPTION_CONTIG] = connected ? 1 : 0;
  metis_options[METIS_OPTION_NUMBERING] = 0;
  int rc = METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr, adjwgt.data(), &nparts, nullptr,
                               nullptr, metis_options, &objval, part.data());
  result.contiguous = connected && rc == METIS_OK;
  if (connected && rc != METIS_OK) {  // contiguity failed all the same: cut without it
    metis_options[METIS_OPTION_CONTIG] = 0;
    rc = METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr, adjwgt.data(), &nparts, nullptr,
                             nullptr, metis_options, &objval, part.data());
  }
  if (rc != METIS_OK) throw std::runtime_error("METIS failed to partition " + std::to_string(leaves) + " octree leaves (code " + std::to_string(rc) + ")");
  for (size_t l = 0; l < leaves; ++l) result.part_of_leaf[l] = static_cast<uint32_t>(part[l]);
}

}  // namespace

VertexPartition partition_vertices(std::span<const float> xyz, const PartitionOptions& options, std::span<const float> tets_per_vertex) {
  const size_t n = xyz.size() / 3;
  if (n == 0) throw std::runtime_error("partition: no vertices");
  VertexPartition result;
  const uint32_t k_leaf = std::max<uint32_t>(1, options.leaf_vertices);
  build_octree(finest_cells(xyz, n), k_leaf, result);

  leaf_adjacency(result);
  const size_t leaves = result.leaves.size();

  const uint32_t parts = std::max<uint32_t>(1, std::min<uint32_t>(options.parts, static_cast<uint32_t>(leaves)));
  result.parts = parts;
  result.part_of_leaf.assign(leaves, 0);
  if (parts > 1) {
    cut_leaf_graph(result, parts, options, tets_per_vertex, n);
  } else {
    result.contiguous = true;
  }
  result.part_of_vertex.resize(n);
  for (size_t i = 0; i < n; ++i) result.part_of_vertex[i] = result.part_of_leaf[result.leaf_of_vertex[i]];
  return result;
}

SegmentPartition partition_segments(std::span<const float> xyz, uint32_t parts, uint32_t leaf_vertices, int seed,
                                    std::span<const float> tets_per_vertex) {
  const uint64_t vertex_count = xyz.size() / 3;
  PartitionOptions options;
  options.seed = seed;
  options.parts = std::max<uint32_t>(1, parts);
  options.leaf_vertices = leaf_vertices ? leaf_vertices
                                        : static_cast<uint32_t>(std::clamp<uint64_t>(vertex_count / (8 * uint64_t{options.parts}), kMinAutoLeafVertices,
                                                                                      kMaxAutoLeafVertices));
  VertexPartition partition = partition_vertices(xyz, options, tets_per_vertex);
  std::vector<uint64_t> part_vertices(partition.parts, 0);
  for (uint32_t p : partition.part_of_vertex) ++part_vertices[p];
  std::vector<uint32_t> by_size;
  for (uint32_t p = 0; p < partition.parts; ++p)
    if (part_vertices[p] > 0) by_size.push_back(p);
  std::stable_sort(by_size.begin(), by_size.end(), [&](uint32_t a, uint32_t b) { return part_vertices[a] < part_vertices[b]; });
  std::vector<uint32_t> segment_of_part(partition.parts, 0);
  for (uint32_t s = 0; s < by_size.size(); ++s) segment_of_part[by_size[s]] = s;
  SegmentPartition out;
  out.segments = static_cast<uint32_t>(by_size.size());
  out.leaves = static_cast<uint32_t>(partition.leaves.size());
  out.leaf_vertices = options.leaf_vertices;
  out.contiguous = partition.contiguous;
  out.segment_of_vertex.resize(vertex_count);
  for (uint64_t v = 0; v < vertex_count; ++v) out.segment_of_vertex[v] = segment_of_part[partition.part_of_vertex[v]];
  return out;
}

}  // namespace tetrascope::lod
