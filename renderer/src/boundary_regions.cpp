// Boundary regions by tags or by feature edges: a flood fill (union-find) over the boundary
// triangles across the edges whose dihedral angle is below the feature angle (ParaView's
// "Feature Edges" and "Connectivity" filters in one step), then small regions merged into the
// neighbour they share the longest border with, smallest first.
#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <queue>
#include <unordered_map>

#include "tetrascope/core/vec3.h"
#include "tetrascope/renderer/boundary_regions.h"

namespace tetrascope::renderer {

namespace {

Vec3 corner(std::span<const float> xyz, uint32_t v) { return {xyz[3 * size_t{v}], xyz[3 * size_t{v} + 1], xyz[3 * size_t{v} + 2]}; }

class Disjoint {
 public:
  explicit Disjoint(size_t n) : parent_(n) {
    for (size_t i = 0; i < n; ++i) parent_[i] = static_cast<uint32_t>(i);
  }
  uint32_t find(uint32_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<uint32_t> parent_;
};

// Two triangles sharing an edge (only edges shared by exactly two: a non-manifold edge joins
// nothing), and the edge's length.
struct SharedEdge {
  uint32_t face[2];
  double length;
};

std::vector<SharedEdge> shared_edges(std::span<const float> xyz, std::span<const std::array<uint32_t, 3>> triangles) {
  struct Side {
    uint32_t a, b, face;
    bool operator<(const Side& o) const { return a != o.a ? a < o.a : b != o.b ? b < o.b : face < o.face; }
  };
  std::vector<Side> sides;
  sides.reserve(3 * triangles.size());
  for (uint32_t f = 0; f < triangles.size(); ++f)
    for (int i = 0; i < 3; ++i) {
      const auto [a, b] = std::minmax(triangles[f][i], triangles[f][(i + 1) % 3]);
      sides.push_back({a, b, f});
    }
  std::sort(sides.begin(), sides.end());
  std::vector<SharedEdge> out;
  for (size_t i = 0; i < sides.size();) {
    size_t j = i + 1;
    while (j < sides.size() && sides[j].a == sides[i].a && sides[j].b == sides[i].b) ++j;
    if (j - i == 2) out.push_back({{sides[i].face, sides[i + 1].face}, length(corner(xyz, sides[i].a) - corner(xyz, sides[i].b))});
    i = j;
  }
  return out;
}

// Merges components (labels 0..count-1 per triangle) smaller than `min_triangles`, and then
// the smallest while more than `max_regions` remain, into the neighbour each shares the longest
// border with. Components with no neighbour stay; past `max_regions` the smallest of those
// share one region. Returns the new label of each old one.
std::vector<uint32_t> merge_small(const std::vector<uint32_t>& label, uint32_t count, const std::vector<SharedEdge>& edges, uint64_t min_triangles,
                                  uint32_t max_regions) {
  std::vector<uint64_t> size(count, 0);
  for (uint32_t l : label) ++size[l];
  std::vector<std::unordered_map<uint32_t, double>> border(count);
  for (const SharedEdge& e : edges) {
    const uint32_t a = label[e.face[0]], b = label[e.face[1]];
    if (a == b) continue;
    border[a][b] += e.length;
    border[b][a] += e.length;
  }
  Disjoint into(count);
  using Entry = std::pair<uint64_t, uint32_t>;  // size, component
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (uint32_t c = 0; c < count; ++c) queue.push({size[c], c});
  std::vector<uint8_t> gone(count, 0);
  uint32_t alive = count;
  std::vector<uint32_t> alone;  // components with no neighbour left, smallest first
  while (!queue.empty()) {
    const auto [n, c] = queue.top();
    queue.pop();
    if (gone[c] || n != size[c]) continue;  // merged, or grown since
    if (n >= min_triangles && alive <= max_regions) break;
    if (border[c].empty()) {
      alone.push_back(c);
      continue;
    }
    const uint32_t d = std::max_element(border[c].begin(), border[c].end(), [](const auto& x, const auto& y) {
                         return x.second != y.second ? x.second < y.second : x.first > y.first;
                       })->first;
    for (const auto& [e, length] : border[c]) {
      border[e].erase(c);
      if (e == d) continue;
      border[d][e] += length;
      border[e][d] += length;
    }
    border[c].clear();
    size[d] += size[c];
    gone[c] = 1;
    into.unite(d, c);
    --alive;
    queue.push({size[d], d});
  }
  std::vector<uint32_t> out(count);
  for (uint32_t c = 0; c < count; ++c) out[c] = into.find(c);
  // past the cap, the smallest components with no neighbour join the largest of them (one pass:
  // a mesh of a million loose tets has a million)
  if (alive > max_regions && alone.size() > 1) {
    const size_t joining = std::min<size_t>(alive - max_regions, alone.size() - 1);
    std::vector<uint8_t> joins(count, 0);
    for (size_t i = 0; i < joining; ++i) joins[alone[i]] = 1;
    for (uint32_t& o : out)
      if (joins[o]) o = alone.back();
  }
  return out;
}

// Each region's triangles, area, box, and whether it lies on the domain's box.
void summarise(std::span<const float> xyz, std::span<const std::array<uint32_t, 3>> triangles, BoundaryRegions& out) {
  storage::Bounds domain{{1e300, 1e300, 1e300}, {-1e300, -1e300, -1e300}};
  for (const auto& t : triangles)
    for (uint32_t v : t)
      for (int k = 0; k < 3; ++k) {
        domain.min[k] = std::min(domain.min[k], double(xyz[3 * size_t{v} + k]));
        domain.max[k] = std::max(domain.max[k], double(xyz[3 * size_t{v} + k]));
      }
  const double diagonal = length(Vec3{domain.max[0] - domain.min[0], domain.max[1] - domain.min[1], domain.max[2] - domain.min[2]});
  const double slack = 1e-6 * diagonal;  // positions are floats
  // the faces of the box a point lies on, one bit each (min x, max x, min y, ...)
  auto on_faces = [&](uint32_t v) {
    uint32_t bits = 0;
    for (int k = 0; k < 3; ++k) {
      if (xyz[3 * size_t{v} + k] <= domain.min[k] + slack) bits |= 1u << (2 * k);
      if (xyz[3 * size_t{v} + k] >= domain.max[k] - slack) bits |= 1u << (2 * k + 1);
    }
    return bits;
  };
  std::vector<uint32_t> reached(out.regions.size(), 0);
  std::vector<uint8_t> flat_on_box(out.regions.size(), 0);
  for (auto& r : out.regions) r.bounds = {{1e300, 1e300, 1e300}, {-1e300, -1e300, -1e300}};
  for (size_t f = 0; f < triangles.size(); ++f) {
    const uint32_t id = out.triangle_region[f];
    BoundaryRegion& r = out.regions[id];
    const auto& t = triangles[f];
    ++r.triangles;
    r.area += 0.5 * length(cross(corner(xyz, t[1]) - corner(xyz, t[0]), corner(xyz, t[2]) - corner(xyz, t[0])));
    uint32_t all = 0x3F;
    for (uint32_t v : t) {
      const uint32_t bits = on_faces(v);
      reached[id] |= bits;
      all &= bits;
      for (int k = 0; k < 3; ++k) {
        r.bounds.min[k] = std::min(r.bounds.min[k], double(xyz[3 * size_t{v} + k]));
        r.bounds.max[k] = std::max(r.bounds.max[k], double(xyz[3 * size_t{v} + k]));
      }
    }
    if (all) flat_on_box[id] = 1;
  }
  for (size_t id = 0; id < out.regions.size(); ++id) out.regions[id].touches_domain_box = flat_on_box[id] || std::popcount(reached[id]) >= 2;
}

}  // namespace

BoundaryRegions find_boundary_regions(std::span<const float> xyz, std::span<const std::array<uint32_t, 3>> triangles, std::span<const uint32_t> tags,
                                      std::span<const std::string> tag_names, const RegionOptions& options) {
  const bool tagged = !tags.empty() && tags.size() == triangles.size();
  const std::vector<SharedEdge> edges = shared_edges(xyz, triangles);
  std::vector<Vec3> normal(triangles.size());
  for (size_t f = 0; f < triangles.size(); ++f) {
    const auto& t = triangles[f];
    normal[f] = normalise(cross(corner(xyz, t[1]) - corner(xyz, t[0]), corner(xyz, t[2]) - corner(xyz, t[0])), Vec3{0, 0, 0});
  }
  const double min_cos = std::cos(options.feature_angle_degrees * std::numbers::pi / 180);
  Disjoint fill(triangles.size());
  if (!tagged)
    for (const SharedEdge& e : edges) {
      const uint32_t f = e.face[0], g = e.face[1];
      // a degenerate triangle (no normal) says nothing about the angle: it joins its neighbours
      const bool degenerate = dot(normal[f], normal[f]) == 0 || dot(normal[g], normal[g]) == 0;
      if (degenerate || dot(normal[f], normal[g]) >= min_cos) fill.unite(f, g);
    }
  // components (with tags: one a tag, however its pieces lie), numbered in order of their first triangle
  std::vector<uint32_t> label(triangles.size());
  std::unordered_map<uint32_t, uint32_t> component;
  for (uint32_t f = 0; f < triangles.size(); ++f)
    label[f] = component.try_emplace(tagged ? tags[f] : fill.find(f), static_cast<uint32_t>(component.size())).first->second;
  const uint32_t count = static_cast<uint32_t>(component.size());
  // tagged regions are kept however small and however many; feature regions below the share are merged
  std::vector<uint32_t> merged(count);
  for (uint32_t c = 0; c < count; ++c) merged[c] = c;
  if (!tagged)
    merged = merge_small(label, count, edges, std::max<uint64_t>(options.min_region_triangles, static_cast<uint64_t>(std::ceil(options.min_region_share * triangles.size()))),
                         std::max(1u, options.max_regions));
  // regions numbered by decreasing area
  std::unordered_map<uint32_t, double> area;
  for (uint32_t f = 0; f < triangles.size(); ++f) {
    const auto& t = triangles[f];
    area[merged[label[f]]] += length(cross(corner(xyz, t[1]) - corner(xyz, t[0]), corner(xyz, t[2]) - corner(xyz, t[0])));
  }
  std::vector<std::pair<double, uint32_t>> by_area;
  for (const auto& [c, a] : area) by_area.push_back({a, c});
  std::sort(by_area.begin(), by_area.end(), [](const auto& x, const auto& y) { return x.first != y.first ? x.first > y.first : x.second < y.second; });
  std::unordered_map<uint32_t, uint32_t> id_of;
  for (uint32_t i = 0; i < by_area.size(); ++i) id_of[by_area[i].second] = i;
  BoundaryRegions out;
  out.regions.resize(by_area.size());
  out.triangle_region.resize(triangles.size());
  for (uint32_t f = 0; f < triangles.size(); ++f) out.triangle_region[f] = id_of[merged[label[f]]];
  for (uint32_t i = 0; i < out.regions.size(); ++i) out.regions[i].id = i;
  if (tagged)
    for (uint32_t f = 0; f < triangles.size(); ++f) {
      BoundaryRegion& r = out.regions[out.triangle_region[f]];
      if (!r.name.empty()) continue;
      r.name = tags[f] < tag_names.size() && !tag_names[tags[f]].empty() ? tag_names[tags[f]] : "tag " + std::to_string(tags[f]);
    }
  summarise(xyz, triangles, out);
  return out;
}

}  // namespace tetrascope::renderer
