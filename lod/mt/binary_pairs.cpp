// The pairing step of the binary segment hierarchy (dissertation §6.2.1): the face-adjacency
// graph of a level's segments, a heavy-edge matching of it into pairs (the new segments), and
// the matching of the new segments by their boundary ratio R = |B| / min(|S1|, |S2|), whose
// pairs may simplify the boundary between them (a dependency, §6.2.1-6.2.2).
//
// The matching is a greedy heavy-edge matching, not METIS: METIS partitions a graph into
// parts of balanced weight but does not promise parts of exactly two face-adjacent segments,
// and the matching its coarsening uses is internal to it. Greedy matching by shared faces
// (heaviest first, ties to the smaller pair, then the lower ids) pairs segments that share the
// most faces, so a merge frees the most border vertices, and it is deterministic.
#include <algorithm>
#include <array>
#include <numeric>

#include "mt_stages.h"

namespace tetrascope::lod::mt {
namespace {

using Face = std::array<uint32_t, 3>;

Face sorted_face(const uint32_t* tet, int skip) {
  Face f{};
  int k = 0;
  for (int i = 0; i < 4; ++i)
    if (i != skip) f[size_t(k++)] = tet[i];
  std::sort(f.begin(), f.end());
  return f;
}

// Faces used once among the node's tets (its boundary), appended with the node's id.
void boundary_faces(std::span<const uint32_t> ids, uint32_t node, std::vector<std::pair<Face, uint32_t>>& out) {
  std::vector<Face> faces;
  faces.reserve(ids.size());
  for (size_t t = 0; t < ids.size() / 4; ++t)
    for (int k = 0; k < 4; ++k) faces.push_back(sorted_face(&ids[4 * t], k));
  std::sort(faces.begin(), faces.end());
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j] == faces[i]) ++j;
    if (j - i == 1) out.emplace_back(faces[i], node);
    i = j;
  }
}

}  // namespace

std::vector<NodeEdge> node_adjacency(const NodeTets& nodes, uint32_t first, uint32_t last) {
  std::vector<std::pair<Face, uint32_t>> faces;
  std::vector<uint32_t> buffer;
  for (uint32_t n = first; n < last; ++n) boundary_faces(nodes.read(n, buffer), n - first, faces);
  std::sort(faces.begin(), faces.end());
  std::vector<NodeEdge> edges;
  for (size_t i = 0; i + 1 < faces.size(); ++i) {
    if (faces[i].first != faces[i + 1].first || faces[i].second == faces[i + 1].second) continue;
    edges.push_back({std::min(faces[i].second, faces[i + 1].second), std::max(faces[i].second, faces[i + 1].second), 1});
    ++i;
  }
  std::sort(edges.begin(), edges.end(), [](const NodeEdge& a, const NodeEdge& b) { return a.a != b.a ? a.a < b.a : a.b < b.b; });
  std::vector<NodeEdge> merged;
  for (const NodeEdge& e : edges) {
    if (!merged.empty() && merged.back().a == e.a && merged.back().b == e.b)
      merged.back().faces += e.faces;
    else
      merged.push_back(e);
  }
  return merged;
}

std::vector<uint32_t> match_pairs(uint32_t count, std::span<const NodeEdge> edges, std::span<const double> weight, std::span<const uint64_t> size,
                                  double min_weight, bool attach_single, uint32_t* groups) {
  std::vector<uint32_t> order(edges.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) {
    if (weight[x] != weight[y]) return weight[x] > weight[y];
    const uint64_t sx = size[edges[x].a] + size[edges[x].b], sy = size[edges[y].a] + size[edges[y].b];
    if (sx != sy) return sx < sy;
    return x < y;
  });
  std::vector<uint32_t> mate(count, kNone);
  for (uint32_t e : order) {
    const NodeEdge& edge = edges[e];
    if (weight[e] < min_weight || mate[edge.a] != kNone || mate[edge.b] != kNone || edge.a == edge.b) continue;
    mate[edge.a] = edge.b;
    mate[edge.b] = edge.a;
  }
  std::vector<uint32_t> group(count, kNone);
  uint32_t next = 0;
  for (uint32_t n = 0; n < count; ++n) {
    if (group[n] != kNone || mate[n] == kNone) continue;
    group[n] = group[mate[n]] = next++;
  }
  // a segment left single joins the pair it shares the heaviest edge with (a merge of three),
  // so that no segment is copied up a level unchanged; one without neighbours stays alone
  std::vector<uint32_t> best(count, kNone);
  if (attach_single)
    for (uint32_t e : order) {
      const NodeEdge& edge = edges[e];
      if (mate[edge.a] == kNone && mate[edge.b] != kNone && best[edge.a] == kNone) best[edge.a] = edge.b;
      if (mate[edge.b] == kNone && mate[edge.a] != kNone && best[edge.b] == kNone) best[edge.b] = edge.a;
    }
  for (uint32_t n = 0; n < count; ++n)
    if (group[n] == kNone && best[n] != kNone) group[n] = group[best[n]];
  for (uint32_t n = 0; n < count; ++n)
    if (group[n] == kNone) group[n] = next++;
  *groups = next;
  return group;
}

BinaryGrouping binary_grouping(const NodeTets& nodes, uint32_t first, uint32_t last, bool copies, double dependency_ratio) {
  const uint32_t count = last - first;
  BinaryGrouping out;
  if (copies) {  // the lowest level: every segment duplicated alone
    out.pair_of_floor.resize(count);
    std::iota(out.pair_of_floor.begin(), out.pair_of_floor.end(), 0u);
    out.ceiling_of_pair = out.pair_of_floor;
    out.pairs = out.ceilings = count;
    return out;
  }
  const std::vector<NodeEdge> edges = node_adjacency(nodes, first, last);
  std::vector<uint64_t> size(count);
  for (uint32_t n = 0; n < count; ++n) size[n] = nodes.tet_count(first + n);
  std::vector<double> faces(edges.size());
  for (size_t e = 0; e < edges.size(); ++e) faces[e] = double(edges[e].faces);
  out.pair_of_floor = match_pairs(count, edges, faces, size, 1, true, &out.pairs);
  // the new segments' graph: the faces between two pairs, weighted by R
  std::vector<uint64_t> pair_size(out.pairs, 0);
  for (uint32_t n = 0; n < count; ++n) pair_size[out.pair_of_floor[n]] += size[n];
  std::vector<NodeEdge> pair_edges;
  for (const NodeEdge& e : edges) {
    const uint32_t a = out.pair_of_floor[e.a], b = out.pair_of_floor[e.b];
    if (a != b) pair_edges.push_back({std::min(a, b), std::max(a, b), e.faces});
  }
  std::sort(pair_edges.begin(), pair_edges.end(), [](const NodeEdge& x, const NodeEdge& y) { return x.a != y.a ? x.a < y.a : x.b < y.b; });
  std::vector<NodeEdge> merged;
  for (const NodeEdge& e : pair_edges) {
    if (!merged.empty() && merged.back().a == e.a && merged.back().b == e.b)
      merged.back().faces += e.faces;
    else
      merged.push_back(e);
  }
  std::vector<double> ratio(merged.size());
  for (size_t e = 0; e < merged.size(); ++e)
    ratio[e] = double(merged[e].faces) / double(std::max<uint64_t>(1, std::min(pair_size[merged[e].a], pair_size[merged[e].b])));
  if (dependency_ratio >= 0) {
    out.ceiling_of_pair = match_pairs(out.pairs, merged, ratio, pair_size, dependency_ratio, false, &out.ceilings);
  } else {
    out.ceiling_of_pair.resize(out.pairs);
    std::iota(out.ceiling_of_pair.begin(), out.ceiling_of_pair.end(), 0u);
    out.ceilings = out.pairs;
  }
  out.dependencies = out.pairs - out.ceilings;
  return out;
}

}  // namespace tetrascope::lod::mt
