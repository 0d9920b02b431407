// A dataset's boundary regions carried to other meshes of its domain: a face that is one of the
// full-resolution boundary triangles (a cut's finest patches) is found by its corners in a
// sorted table of their hashes; any other face by a bounding volume hierarchy over those
// triangles (median splits, four triangles a leaf), searched nearest first with branch and
// bound; the point-triangle distance after Ericson, Real-Time Collision Detection (2005),
// §5.1.5.
#include <algorithm>
#include <bit>
#include <cmath>
#include <thread>
#include <unordered_map>

#include "tetrascope/core/parallel_for.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"
#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/boundary_tags.h"

namespace tetrascope::renderer {

namespace {

constexpr uint32_t kLeafTriangles = 4;
constexpr uint32_t kFacesPerTask = 1024;  // scene faces a worker takes at a time

// The point of triangle (a, b, c) nearest p.
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denominator = va + vb + vc;
  if (!(std::abs(denominator) > 0)) return a;  // a degenerate triangle
  return a + ab * (vb / denominator) + ac * (vc / denominator);
}

// A triangle's corners in a fixed order (lexicographic), so that the same triangle from two
// meshes compares equal however its corners are numbered, and their hash.
using Corners = std::array<std::array<float, 3>, 3>;
Corners sorted_corners(const float* a, const float* b, const float* c) {
  Corners k{{{a[0], a[1], a[2]}, {b[0], b[1], b[2]}, {c[0], c[1], c[2]}}};
  std::sort(k.begin(), k.end());
  return k;
}
uint64_t corners_hash(const Corners& k) {
  uint64_t h = 1469598103934665603ull;  // FNV-1a over the floats' bits
  for (const auto& p : k)
    for (float v : p) h = (h ^ std::bit_cast<uint32_t>(v)) * 1099511628211ull;
  return h;
}

}  // namespace

struct RegionMap::Tree {
  struct Node {
    float lo[3], hi[3];
    uint32_t first = 0, count = 0;  // a leaf: order[first, first + count); else count 0
    uint32_t right = 0;             // an inner node: its children are this + 1 and right
  };
  std::vector<Node> nodes;
  std::vector<uint32_t> order;
  std::vector<float> normal;  // unit, 3 a triangle
  std::vector<std::pair<uint64_t, uint32_t>> exact;  // (corners_hash, triangle), sorted

  double box_distance(const Node& n, const Vec3& p) const {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double out = std::max({n.lo[k] - p[k], p[k] - n.hi[k], 0.0});
      d2 += out * out;
    }
    return std::sqrt(d2);
  }

  uint32_t build(const std::vector<float>& corners, std::vector<float>& centre, uint32_t begin, uint32_t end) {
    const uint32_t at = static_cast<uint32_t>(nodes.size());
    nodes.emplace_back();
    Node n;
    float clo[3], chi[3];
    for (int k = 0; k < 3; ++k) {
      n.lo[k] = clo[k] = 3e38f;
      n.hi[k] = chi[k] = -3e38f;
    }
    for (uint32_t i = begin; i < end; ++i) {
      const uint32_t t = order[i];
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k) {
          n.lo[k] = std::min(n.lo[k], corners[9 * size_t{t} + 3 * c + k]);
          n.hi[k] = std::max(n.hi[k], corners[9 * size_t{t} + 3 * c + k]);
        }
      for (int k = 0; k < 3; ++k) {
        clo[k] = std::min(clo[k], centre[3 * size_t{t} + k]);
        chi[k] = std::max(chi[k], centre[3 * size_t{t} + k]);
      }
    }
    if (end - begin <= kLeafTriangles) {
      n.first = begin;
      n.count = end - begin;
      nodes[at] = n;
      return at;
    }
    int axis = 0;  // the widest spread of centres
    for (int k = 1; k < 3; ++k)
      if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
    const uint32_t middle = begin + (end - begin) / 2;
    std::nth_element(order.begin() + begin, order.begin() + middle, order.begin() + end,
                     [&](uint32_t a, uint32_t b) { return centre[3 * size_t{a} + axis] < centre[3 * size_t{b} + axis]; });
    build(corners, centre, begin, middle);
    n.right = build(corners, centre, middle, end);
    nodes[at] = n;
    return at;
  }
};

std::vector<uint8_t> hidden_faces(const SceneMesh& scene, std::span<const uint32_t> hidden) {
  std::vector<uint8_t> out;
  if (hidden.empty() || scene.boundary_region.size() != scene.boundary.size()) return out;
  out.resize(scene.boundary.size());
  for (size_t f = 0; f < out.size(); ++f) out[f] = std::binary_search(hidden.begin(), hidden.end(), scene.boundary_region[f]);
  return out;
}

const char* region_source_name(RegionSource source) { return source == RegionSource::kInputTags ? "input tags" : "sharp edges"; }

std::vector<uint32_t> tags_of_triangles(std::span<const std::array<uint32_t, 3>> triangles, std::span<const uint32_t> ids,
                                        const storage::FaceTags& face_tags, std::vector<std::string>& names) {
  auto key = [](std::array<uint32_t, 3> t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  struct Hash {
    size_t operator()(const std::array<uint32_t, 3>& t) const { return (uint64_t{t[0]} * 0x9E3779B97F4A7C15ull) ^ (uint64_t{t[1]} * 0xC2B2AE3D27D4EB4Full) ^ t[2]; }
  };
  std::unordered_map<std::array<uint32_t, 3>, uint32_t, Hash> tag_of;
  tag_of.reserve(face_tags.triangles.size());
  for (size_t t = 0; t < face_tags.triangles.size(); ++t) tag_of.try_emplace(key(face_tags.triangles[t]), face_tags.tags[t]);
  names = face_tags.names;
  const uint32_t untagged = static_cast<uint32_t>(names.size());
  std::vector<uint32_t> out(triangles.size(), untagged);
  bool any = false;
  for (size_t f = 0; f < triangles.size(); ++f) {
    std::array<uint32_t, 3> t = triangles[f];
    if (!ids.empty())
      for (uint32_t& v : t) v = ids[v];
    if (auto it = tag_of.find(key(t)); it != tag_of.end()) {
      out[f] = it->second;
      any = true;
    }
  }
  if (!any) return {};
  names.push_back(kUntaggedRegionName);
  return out;
}

RegionMap::RegionMap(std::vector<float> corners, BoundaryRegions regions, RegionSource source)
    : corners_(std::move(corners)), regions_(std::move(regions)), source_(source), tree_(std::make_unique<Tree>()) {
  const uint32_t count = static_cast<uint32_t>(corners_.size() / 9);
  std::vector<float> centre(3 * size_t{count});
  tree_->normal.resize(3 * size_t{count});
  tree_->order.resize(count);
  for (uint32_t t = 0; t < count; ++t) {
    const float* c = &corners_[9 * size_t{t}];
    const Vec3 a{c[0], c[1], c[2]}, b{c[3], c[4], c[5]}, d{c[6], c[7], c[8]};
    const Vec3 n = normalise(cross(b - a, d - a), Vec3{0, 0, 0});
    for (int k = 0; k < 3; ++k) {
      centre[3 * size_t{t} + k] = (c[k] + c[3 + k] + c[6 + k]) / 3;
      tree_->normal[3 * size_t{t} + k] = static_cast<float>(n[k]);
    }
    tree_->order[t] = t;
    tree_->exact.push_back({corners_hash(sorted_corners(c, c + 3, c + 6)), t});
  }
  std::sort(tree_->exact.begin(), tree_->exact.end());
  if (count) tree_->build(corners_, centre, 0, count);
}

RegionMap::~RegionMap() = default;

namespace {

std::shared_ptr<const RegionMap> map_of(const storage::TetMesh& mesh, std::span<const uint32_t> tags, std::span<const std::string> tag_names,
                                        const storage::FaceTags* face_tags, std::span<const uint32_t> ids, const RegionOptions& options) {
  std::vector<float> xyz(3 * mesh.vertex_count());
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    xyz[3 * v] = mesh.x[v];
    xyz[3 * v + 1] = mesh.y[v];
    xyz[3 * v + 2] = mesh.z[v];
  }
  const std::vector<FaceVertices> faces = boundary_faces(mesh.tets);
  std::vector<std::array<uint32_t, 3>> triangles(faces.begin(), faces.end());
  std::vector<uint32_t> found;
  std::vector<std::string> names;
  if (face_tags) {
    found = tags_of_triangles(triangles, ids, *face_tags, names);
    tags = found;
    tag_names = names;
  }
  const RegionSource source = !tags.empty() && tags.size() == triangles.size() ? RegionSource::kInputTags : RegionSource::kSharpEdges;
  BoundaryRegions regions = find_boundary_regions(xyz, triangles, tags, tag_names, options);
  std::vector<float> corners(9 * triangles.size());
  for (size_t f = 0; f < triangles.size(); ++f)
    for (int c = 0; c < 3; ++c) std::copy_n(&xyz[3 * size_t{triangles[f][c]}], 3, &corners[9 * f + 3 * c]);
  return std::make_shared<const RegionMap>(std::move(corners), std::move(regions), source);
}

}  // namespace

std::shared_ptr<const RegionMap> RegionMap::from(const storage::TetMesh& mesh, std::span<const uint32_t> tags, std::span<const std::string> tag_names,
                                                 const RegionOptions& options) {
  return map_of(mesh, tags, tag_names, nullptr, {}, options);
}

std::shared_ptr<const RegionMap> RegionMap::tagged(const storage::TetMesh& mesh, const storage::FaceTags& face_tags, std::span<const uint32_t> ids,
                                                   const RegionOptions& options) {
  return map_of(mesh, {}, {}, &face_tags, ids, options);
}

std::shared_ptr<const RegionMap> RegionMap::of_store(const storage::Store& store, const lod::Dag& dag, uint64_t cache_bytes,
                                                     const std::optional<storage::FaceTags>& tags) {
  storage::SegmentCache cache(store, cache_bytes);
  lod::Cut finest(dag);
  finest.refine_all();
  const lod::CutMesh cut = lod::assemble_cut(store, cache, finest, false);
  if (tags && !tags->empty()) return tagged(cut.mesh, *tags, cut.global_ids);
  return from(cut.mesh);
}

std::shared_ptr<const RegionMap> RegionMap::of_store(const storage::Store& store, const lod::Dag& dag, uint64_t cache_bytes) {
  return of_store(store, dag, cache_bytes, storage::open_boundary_tags(store));
}

std::vector<uint32_t> RegionMap::classify(const SceneMesh& scene, std::span<const std::array<double, 4>> planes) const {
  std::vector<uint32_t> out(scene.boundary.size(), kNoRegion);
  if (tree_->nodes.empty()) return out;
  const double slack = 1e-5 * scene.diagonal;
  auto at = [&](uint32_t v) { return Vec3{scene.xyz[3 * size_t{v}], scene.xyz[3 * size_t{v} + 1], scene.xyz[3 * size_t{v} + 2]}; };
  auto one = [&](size_t f, std::vector<uint32_t>& stack) {
    const auto& t = scene.boundary[f];
    const Vec3 a = at(t[0]), b = at(t[1]), c = at(t[2]);
    for (const auto& q : planes) {  // a clip's cut face
      auto off = [&](const Vec3& p) { return std::abs(q[0] * p[0] + q[1] * p[1] + q[2] * p[2] - q[3]); };
      if (off(a) <= slack && off(b) <= slack && off(c) <= slack) return;
    }
    // one of the map's own triangles
    const Corners key = sorted_corners(&scene.xyz[3 * size_t{t[0]}], &scene.xyz[3 * size_t{t[1]}], &scene.xyz[3 * size_t{t[2]}]);
    const uint64_t hash = corners_hash(key);
    for (auto it = std::lower_bound(tree_->exact.begin(), tree_->exact.end(), std::pair<uint64_t, uint32_t>{hash, 0}); it != tree_->exact.end() && it->first == hash; ++it) {
      const float* k = &corners_[9 * size_t{it->second}];
      if (sorted_corners(k, k + 3, k + 6) == key) {
        out[f] = regions_.triangle_region[it->second];
        return;
      }
    }
    const Vec3 p = (a + b + c) * (1.0 / 3), n = normalise(cross(b - a, c - a), Vec3{0, 0, 0});
    const double radius = std::max({length(b - a), length(c - b), length(a - c)}) + slack;
    // nearest first: the score is the distance, plus up to half the radius for a triangle
    // facing another way; triangles facing away do not count
    double best = radius;
    uint32_t region = kNoRegion;
    stack.assign(1, 0);
    while (!stack.empty()) {
      const Tree::Node& node = tree_->nodes[stack.back()];
      const uint32_t index = stack.back();
      stack.pop_back();
      if (tree_->box_distance(node, p) > best) continue;
      if (node.count == 0) {
        const uint32_t near = index + 1, far = node.right;
        const bool left_first = tree_->box_distance(tree_->nodes[near], p) <= tree_->box_distance(tree_->nodes[far], p);
        stack.push_back(left_first ? far : near);
        stack.push_back(left_first ? near : far);
        continue;
      }
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const uint32_t r = tree_->order[i];
        const float* m = &tree_->normal[3 * size_t{r}];
        const double facing = dot(n, Vec3{m[0], m[1], m[2]});
        if (facing <= 0) continue;
        const float* k = &corners_[9 * size_t{r}];
        const double d = length(p - closest_on_triangle(p, {k[0], k[1], k[2]}, {k[3], k[4], k[5]}, {k[6], k[7], k[8]}));
        const double score = d + 0.5 * (1 - facing) * radius;
        if (score < best) {
          best = score;
          region = regions_.triangle_region[r];
        }
      }
    }
    out[f] = region;
  };
  const size_t tasks = (scene.boundary.size() + kFacesPerTask - 1) / kFacesPerTask;
  const unsigned workers = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::vector<uint32_t>> stacks(workers);
  parallel_for(tasks, workers, [&](size_t task, unsigned worker) {
    const size_t end = std::min(scene.boundary.size(), (task + 1) * kFacesPerTask);
    for (size_t f = task * kFacesPerTask; f < end; ++f) one(f, stacks[worker]);
  });
  return out;
}

}  // namespace tetrascope::renderer
