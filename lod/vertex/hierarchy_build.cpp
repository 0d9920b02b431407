// The binary vertex hierarchy's build (§5.2.1): the simplifier's collapses, replayed on the
// input to find, per collapse, the tets it consumes and makes, and from them the order
// between collapses, the fan each one removes, its region's sphere and value ranges.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::lod {
namespace {

float value_of(const VertexHierarchy& h, uint32_t vertex, uint32_t attribute, const std::vector<uint32_t>& first) {
  return attribute_scalar(&h.values[size_t{vertex} * h.value_floats + first[attribute]], h.attributes[attribute].components);
}

// The replay's state: per input vertex slot its vertex now and the tets around it; per tet
// its slots and the last collapse that made it.
struct Replay {
  std::vector<uint32_t> current;                // slot -> vertex id
  std::vector<std::vector<uint32_t>> star;      // slot -> tets
  std::vector<uint32_t> slots;                  // 4 per tet
  std::vector<uint32_t> made_by;                // per tet: the last collapse that changed it
  std::vector<float> subtree;                   // per vertex and attribute: lo, hi of the leaves below
};

void erase_from(std::vector<uint32_t>& star, uint32_t t) {
  auto it = std::find(star.begin(), star.end(), t);
  if (it != star.end()) {
    *it = star.back();
    star.pop_back();
  }
}

void replay_collapse(VertexHierarchy& h, Replay& r, uint32_t i, uint32_t keep, uint32_t gone, std::vector<uint32_t>& before) {
  const uint32_t attributes = static_cast<uint32_t>(h.attributes.size());
  const uint32_t made = h.input_vertices + i;
  VertexNode& node = h.nodes[i];
  node.child = {r.current[keep], r.current[gone]};
  const float* centre = &h.positions[3 * size_t{made}];
  float* range = h.ranges.data() + 2 * size_t{i} * attributes;
  for (uint32_t a = 0; a < attributes; ++a) {
    range[2 * a] = std::min(r.subtree[2 * (size_t{node.child[0]} * attributes + a)], r.subtree[2 * (size_t{node.child[1]} * attributes + a)]);
    range[2 * a + 1] = std::max(r.subtree[2 * (size_t{node.child[0]} * attributes + a) + 1], r.subtree[2 * (size_t{node.child[1]} * attributes + a) + 1]);
  }
  float* own = r.subtree.data() + 2 * size_t{made} * attributes;
  std::copy(range, range + 2 * attributes, own);  // the new vertex's subtree: its children's leaves
  double radius2 = 0;
  before.clear();
  auto visit = [&](uint32_t t) {
    if (r.made_by[t] != kNoCollapse) before.push_back(r.made_by[t]);
    for (int k = 0; k < 4; ++k) {
      const uint32_t v = r.current[r.slots[4 * size_t{t} + k]];
      const float* p = &h.positions[3 * size_t{v}];
      radius2 = std::max(radius2, double(p[0] - centre[0]) * (p[0] - centre[0]) + double(p[1] - centre[1]) * (p[1] - centre[1]) + double(p[2] - centre[2]) * (p[2] - centre[2]));
      for (uint32_t a = 0; a < attributes; ++a) {
        range[2 * a] = std::min(range[2 * a], r.subtree[2 * (size_t{v} * attributes + a)]);
        range[2 * a + 1] = std::max(range[2 * a + 1], r.subtree[2 * (size_t{v} * attributes + a) + 1]);
      }
    }
  };
  for (uint32_t t : r.star[keep]) visit(t);
  for (uint32_t t : r.star[gone]) visit(t);
  node.radius = static_cast<float>(std::sqrt(radius2));
  for (uint32_t t : r.star[gone]) {  // only other vertices' stars change in this loop
    uint32_t* s = &r.slots[4 * size_t{t}];
    const bool fan = std::count(s, s + 4, keep) != 0;
    if (fan) {
      h.killer[t] = i;
      ++node.fan;
      for (int k = 0; k < 4; ++k)
        if (s[k] != gone) erase_from(r.star[s[k]], t);
    } else {
      std::replace(s, s + 4, gone, keep);
      r.star[keep].push_back(t);
    }
  }
  r.star[gone].clear();
  for (uint32_t t : r.star[keep]) r.made_by[t] = i;
  r.current[keep] = made;
  std::sort(before.begin(), before.end());
  before.erase(std::unique(before.begin(), before.end()), before.end());
}

// The CSR of `lists` (offsets, then the items).
void to_csr(const std::vector<std::vector<uint32_t>>& lists, std::vector<uint32_t>& offsets, std::vector<uint32_t>& items) {
  offsets.assign(lists.size() + 1, 0);
  for (size_t i = 0; i < lists.size(); ++i) offsets[i + 1] = offsets[i] + static_cast<uint32_t>(lists[i].size());
  items.clear();
  items.reserve(offsets.back());
  for (const auto& l : lists) items.insert(items.end(), l.begin(), l.end());
}

}  // namespace

uint64_t VertexHierarchy::base_tets() const {
  return static_cast<uint64_t>(std::count(killer.begin(), killer.end(), kNoCollapse));
}

uint32_t VertexHierarchy::depth() const {
  std::vector<uint32_t> level(collapse_count(), 1);
  uint32_t deepest = 0;
  for (uint32_t i = collapse_count(); i-- > 0;) {
    for (uint32_t k = after_offsets[i]; k < after_offsets[i + 1]; ++k) level[i] = std::max(level[i], level[after[k]] + 1);
    deepest = std::max(deepest, level[i]);
  }
  return deepest;
}

VertexHierarchy build_vertex_hierarchy(const storage::TetMesh& mesh, const VertexHierarchyOptions& options, VertexHierarchyReport* report) {
  const auto start = std::chrono::steady_clock::now();
  storage::TetMesh copy = mesh;
  SimplifyOptions so;
  so.target_tets = options.base_tets ? options.base_tets : std::max<uint64_t>(500, mesh.tet_count() / 200);
  so.record_collapses = true;
  so.independent = options.independent;
  so.independent_stars = options.independent;
  so.threads = options.threads;
  SimplifyReport simplified = simplify(copy, so);
  const auto simplified_at = std::chrono::steady_clock::now();

  VertexHierarchy h;
  const uint32_t V = static_cast<uint32_t>(mesh.vertex_count()), C = static_cast<uint32_t>(simplified.collapse_log.size());
  h.input_vertices = V;
  std::vector<uint32_t> first;
  for (const auto& a : mesh.attributes) {
    h.attributes.push_back(a.info);
    first.push_back(h.value_floats);
    h.value_floats += a.info.components;
  }
  const uint32_t A = static_cast<uint32_t>(h.attributes.size()), F = h.value_floats;
  h.positions.resize(3 * (size_t{V} + C));
  h.values.resize(size_t{F} * (size_t{V} + C));
  for (uint32_t v = 0; v < V; ++v) {
    h.positions[3 * size_t{v}] = mesh.x[v];
    h.positions[3 * size_t{v} + 1] = mesh.y[v];
    h.positions[3 * size_t{v} + 2] = mesh.z[v];
    for (uint32_t a = 0; a < A; ++a)
      for (uint32_t k = 0; k < h.attributes[a].components; ++k) h.values[size_t{v} * F + first[a] + k] = mesh.attributes[a].values[size_t{v} * h.attributes[a].components + k];
  }
  for (uint32_t i = 0; i < C; ++i) {
    std::copy(simplified.collapse_log[i].position.begin(), simplified.collapse_log[i].position.end(), &h.positions[3 * (size_t{V} + i)]);
    const float* values = simplified.collapse_values.data() + size_t{i} * F;  // F may be 0
    std::copy(values, values + F, h.values.data() + (size_t{V} + i) * F);
  }
  // collapsed vertices' tensors interpolated: PSD kept where the input's were, derived scalars from them
  storage::refresh_tensor_values(h.attributes, h.values.data() + size_t{V} * F, C);
  h.tets = mesh.tets;
  h.killer.assign(mesh.tet_count(), kNoCollapse);
  h.nodes.resize(C);
  h.ranges.resize(2 * size_t{C} * A);

  Replay r;
  r.current.resize(V);
  for (uint32_t v = 0; v < V; ++v) r.current[v] = v;
  r.star.resize(V);
  r.slots = mesh.tets;
  r.made_by.assign(mesh.tet_count(), kNoCollapse);
  for (uint32_t t = 0; t < mesh.tet_count(); ++t)
    for (int k = 0; k < 4; ++k) r.star[mesh.tets[4 * size_t{t} + k]].push_back(t);
  r.subtree.resize(2 * (size_t{V} + C) * A);
  for (uint32_t v = 0; v < V; ++v)
    for (uint32_t a = 0; a < A; ++a) r.subtree[2 * (size_t{v} * A + a)] = r.subtree[2 * (size_t{v} * A + a) + 1] = value_of(h, v, a, first);
  std::vector<std::vector<uint32_t>> before(C), after(C);
  for (uint32_t i = 0; i < C; ++i) {
    const SimplifyCollapse& c = simplified.collapse_log[i];
    replay_collapse(h, r, i, c.keep, c.gone, before[i]);
    // the new vertex's own value widens its subtree's range (a quadric-optimal value may lie outside)
    for (uint32_t a = 0; a < A; ++a) {
      const float own = value_of(h, V + i, a, first);
      float* s = &r.subtree[2 * ((size_t{V} + i) * A + a)];
      s[0] = std::min(s[0], own);
      s[1] = std::max(s[1], own);
      h.ranges[2 * (size_t{i} * A + a)] = std::min(h.ranges[2 * (size_t{i} * A + a)], own);
      h.ranges[2 * (size_t{i} * A + a) + 1] = std::max(h.ranges[2 * (size_t{i} * A + a) + 1], own);
    }
    float error = c.cost;
    for (uint32_t child : h.nodes[i].child)
      if (child >= V) error = std::max(error, h.nodes[child - V].error);
    h.nodes[i].error = std::max(error, 0.0f);
    for (uint32_t j : before[i]) after[j].push_back(i);
  }
  to_csr(before, h.before_offsets, h.before);
  to_csr(after, h.after_offsets, h.after);
  if (report) {
    report->input_tets = mesh.tet_count();
    report->base_tets = h.base_tets();
    report->collapses = C;
    report->depth = h.depth();
    report->simplify_seconds = std::chrono::duration<double>(simplified_at - start).count();
    report->build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return h;
}

}  // namespace tetrascope::lod
