// `tetrascope preprocess`: the multi-triangulation of dissertation §6.3.1-6.3.2.
//
// Level 0 is the input mesh, partitioned by octree + METIS (§6.1). Level i+1 comes from the
// mesh M(i) of level i: partition it again (the mesh turned 45° about its longest box axis
// through the centroid on every odd level, so that the borders frozen at one level fall
// inside the segments of the next), cut every level-i segment (floor) by the new segments
// (ceilings) into patches, and simplify each ceiling segment with its border vertices
// locked. Stop at the base budget or one segment. A vertex keeps its global id while its
// position and values are unchanged; a moved vertex gets a new id.
//
// Error histograms (§6.3.4): every original vertex is followed down the levels (the tet of
// the current level that holds it); a segment's field error in value slot n is the largest
// difference, at the original vertices it holds whose normalised value falls in slot n,
// between the original value and the segment's interpolated one; the spatial error divides
// that by the segment's local gradient (how far the isosurface through the vertex moved).
// Both are then made monotone: a segment's histogram is at least its children's.
//
// The whole level-0 mesh is held in memory (16 bytes a tet plus the vertices); every later
// level is smaller. Segment-wise work (simplification, error measure) runs on `threads`.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <future>
#include <limits>
#include <numeric>
#include <thread>

#include "box_grid.h"
#include "tet_faces.h"
#include "tetrascope/lod/multires.h"
#include "tetrascope/lod/octree_partition.h"
#include "tetrascope/lod/simplify.h"
#include "tetrascope/lod/streaming_order.h"
#include "tetrascope/storage/mesh_error.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/sha256.h"
#include "tetrascope/storage/store_writer.h"

namespace tetrascope::lod {

nlohmann::json PreprocessReport::to_json() const {
  nlohmann::json levels_json = nlohmann::json::array();
  for (const auto& l : levels) levels_json.push_back({{"level", l.level}, {"segments", l.segments}, {"patches", l.patches}, {"tets", l.tets}, {"vertices", l.vertices}});
  return {{"input_vertices", input_vertices}, {"input_tets", input_tets}, {"levels", levels_json}, {"segments", segments}, {"patches", patches},
          {"store_bytes", store_bytes}, {"dag_bytes", dag_bytes}, {"seconds", seconds},
          {"stage_seconds", {{"read", read_seconds}, {"partition", segment_seconds}, {"simplify", simplify_seconds}, {"write", write_seconds}}}};
}

namespace {

using detail::BoxGrid;
using detail::Vec;
constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr uint32_t kMany = 0xFFFFFFFEu;
constexpr auto& kFace = detail::kTetFace;

// Runs work(item) for items 0..count-1 on `threads` threads; rethrows the first error.
template <class Work>
void parallel_for(size_t count, unsigned threads, Work&& work) {
  std::atomic<size_t> next{0};
  std::vector<std::exception_ptr> errors(threads);
  auto run = [&](unsigned w) {
    try {
      for (size_t i = next++; i < count; i = next++) work(i);
    } catch (...) {
      errors[w] = std::current_exception();
      next = count;
    }
  };
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < threads; ++w) pool.emplace_back(run, w);
  run(0);
  for (auto& t : pool) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

// Every vertex the build knows: the input's, then the ones simplification moved.
struct VertexTable {
  std::vector<float> xyz;     // interleaved
  std::vector<float> values;  // vertex-major, `floats` per vertex
  uint32_t floats = 0;
  size_t size() const { return xyz.size() / 3; }
};

struct BuildNode {
  uint32_t level = 0;
  std::vector<uint32_t> tets;  // global vertex ids; after the next level is cut, grouped by patch
};

struct PatchRange {
  uint32_t ceiling, floor, begin, count;
};

// Normalised value of every histogram channel (an attribute; vectors by magnitude): the
// input's range maps to [0, 1].
struct Channels {
  std::vector<uint32_t> offset, components;  // into a vertex's values
  std::vector<double> lo, scale;
  void normalise(const float* values, double* out) const {
    for (size_t c = 0; c < offset.size(); ++c) {
      double v = 0;
      if (components[c] == 1) {
        v = values[offset[c]];
      } else {
        for (uint32_t k = 0; k < components[c]; ++k) v += double(values[offset[c] + k]) * values[offset[c] + k];
        v = std::sqrt(v);
      }
      v = (v - lo[c]) * scale[c];
      out[c] = std::isfinite(v) ? v : 0.0;  // not clamped: simplified values may leave the range
    }
  }
};

// Regions of one level: octree + METIS over the vertices its tets use, each tet to the lowest
// region among its vertices (§6.1.1), regions numbered by ascending vertex count.
// `lists` are the level's tet lists. Returns the region of every tet, list by list.
std::vector<std::vector<uint32_t>> partition_level(const std::vector<const std::vector<uint32_t>*>& lists, const VertexTable& table, uint32_t parts,
                                                   bool rotate, int seed, std::vector<uint32_t>& local_of, uint32_t* region_count) {
  std::vector<uint32_t> used;
  for (const auto* list : lists)
    for (uint32_t g : *list)
      if (local_of[g] == kNone) {
        local_of[g] = 0;
        used.push_back(g);
      }
  std::sort(used.begin(), used.end());
  for (uint32_t i = 0; i < used.size(); ++i) local_of[used[i]] = i;
  std::vector<float> xyz(3 * used.size());
  for (size_t i = 0; i < used.size(); ++i)
    for (int k = 0; k < 3; ++k) xyz[3 * i + k] = table.xyz[3 * size_t{used[i]} + k];
  if (rotate && !used.empty()) {  // 45° about the longest box axis, through the centroid (§6.3.2)
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300}, centre[3] = {0, 0, 0};
    for (size_t i = 0; i < used.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min<double>(lo[k], xyz[3 * i + k]);
        hi[k] = std::max<double>(hi[k], xyz[3 * i + k]);
        centre[k] += xyz[3 * i + k];
      }
    for (double& c : centre) c /= double(used.size());
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const double c = std::sqrt(0.5);
    for (size_t i = 0; i < used.size(); ++i) {
      double u = xyz[3 * i + a] - centre[a], v = xyz[3 * i + b] - centre[b];
      xyz[3 * i + a] = static_cast<float>(centre[a] + c * (u - v));
      xyz[3 * i + b] = static_cast<float>(centre[b] + c * (u + v));
    }
  }
  std::vector<float> tets_per_vertex(used.size(), 0.0f);
  for (const auto* list : lists)
    for (uint32_t g : *list) tets_per_vertex[local_of[g]] += 0.25f;
  PartitionOptions options;
  options.parts = std::max<uint32_t>(1, parts);
  options.seed = seed;
  options.leaf_vertices = static_cast<uint32_t>(std::clamp<uint64_t>(used.size() / (8 * uint64_t{options.parts}), 8, 2000));
  VertexPartition partition = options.parts > 1 ? partition_vertices(xyz, options, tets_per_vertex) : VertexPartition{};
  if (options.parts == 1) {
    partition.parts = 1;
    partition.part_of_vertex.assign(used.size(), 0);
  }
  std::vector<uint64_t> size(partition.parts, 0);
  for (uint32_t p : partition.part_of_vertex) ++size[p];
  std::vector<uint32_t> by_size;
  for (uint32_t p = 0; p < partition.parts; ++p)
    if (size[p] > 0) by_size.push_back(p);
  std::stable_sort(by_size.begin(), by_size.end(), [&](uint32_t x, uint32_t y) { return size[x] < size[y]; });
  std::vector<uint32_t> number(partition.parts, 0);
  for (uint32_t i = 0; i < by_size.size(); ++i) number[by_size[i]] = i;
  // a region may end up without tets (all its vertices' tets went to lower regions): renumber
  std::vector<std::vector<uint32_t>> region(lists.size());
  std::vector<uint8_t> has_tets(by_size.size(), 0);
  for (size_t l = 0; l < lists.size(); ++l) {
    const auto& tets = *lists[l];
    region[l].resize(tets.size() / 4);
    for (size_t t = 0; t < tets.size() / 4; ++t) {
      uint32_t r = kNone;
      for (int k = 0; k < 4; ++k) r = std::min(r, number[partition.part_of_vertex[local_of[tets[4 * t + k]]]]);
      region[l][t] = r;
      has_tets[r] = 1;
    }
  }
  std::vector<uint32_t> compact(by_size.size(), kNone);
  uint32_t next = 0;
  for (size_t r = 0; r < has_tets.size(); ++r)
    if (has_tets[r]) compact[r] = next++;
  for (auto& list : region)
    for (uint32_t& r : list) r = compact[r];
  for (uint32_t g : used) local_of[g] = kNone;
  *region_count = next;
  return region;
}

// Point location in a small tet mesh: the tet that holds p, or the one it is least outside of.
class Locator {
 public:
  Locator(const storage::TetMesh& m) : m_(m) {
    std::vector<std::array<Vec, 2>> boxes(m.tet_count());
    for (size_t t = 0; t < m.tet_count(); ++t) {
      Vec lo = at(m.tets[4 * t]), hi = lo;
      for (int k = 1; k < 4; ++k) {
        Vec p = at(m.tets[4 * t + k]);
        for (int i = 0; i < 3; ++i) {
          lo[i] = std::min(lo[i], p[i]);
          hi[i] = std::max(hi[i], p[i]);
        }
      }
      boxes[t] = {lo, hi};
    }
    if (!boxes.empty()) grid_.build(boxes);
  }
  // Returns the tet; bary gets clamped, normalised barycentric weights.
  uint32_t locate(const Vec& p, double bary[4]) const {
    uint32_t best = kNone;
    double best_low = -std::numeric_limits<double>::infinity();
    for (int r = 0; r < 64 && (best == kNone || best_low < -1e-9); ++r) {
      bool any = grid_.ring(p, r, [&](uint32_t t) {
        if (best_low >= -1e-9) return;
        double w[4];
        if (!weights(t, p, w)) return;
        double low = std::min({w[0], w[1], w[2], w[3]});
        if (low > best_low) {
          best_low = low;
          best = t;
          std::copy(w, w + 4, bary);
        }
      });
      if (!any || (best != kNone && r >= 1)) break;  // outside: the best of the nearest cells
    }
    if (best == kNone) {
      best = 0;
      bary[0] = 1;
      bary[1] = bary[2] = bary[3] = 0;
    }
    double sum = 0;
    for (int k = 0; k < 4; ++k) sum += bary[k] = std::max(bary[k], 0.0);
    for (int k = 0; k < 4; ++k) bary[k] = sum > 0 ? bary[k] / sum : 0.25;
    return best;
  }

 private:
  Vec at(uint32_t v) const { return {m_.x[v], m_.y[v], m_.z[v]}; }
  bool weights(uint32_t t, const Vec& p, double w[4]) const {
    const uint32_t* tet = &m_.tets[4 * size_t{t}];
    Vec a = at(tet[0]), b = at(tet[1]), c = at(tet[2]), d = at(tet[3]);
    auto det = [](const Vec& u, const Vec& v, const Vec& x) {
      return u[0] * (v[1] * x[2] - v[2] * x[1]) - u[1] * (v[0] * x[2] - v[2] * x[0]) + u[2] * (v[0] * x[1] - v[1] * x[0]);
    };
    auto sub = [](const Vec& u, const Vec& v) { return Vec{u[0] - v[0], u[1] - v[1], u[2] - v[2]}; };
    Vec ab = sub(b, a), ac = sub(c, a), ad = sub(d, a), ap = sub(p, a);
    double total = det(ab, ac, ad);
    if (!(std::fabs(total) > 0)) return false;
    w[1] = det(ap, ac, ad) / total;
    w[2] = det(ab, ap, ad) / total;
    w[3] = det(ab, ac, ap) / total;
    w[0] = 1 - w[1] - w[2] - w[3];
    return true;
  }
  const storage::TetMesh& m_;
  BoxGrid grid_;
};

// What simplifying one ceiling segment produced.
struct RegionResult {
  storage::TetMesh mesh;                 // simplified, local vertex ids
  std::vector<uint32_t> global;          // per output vertex: kept global id, or kNone (new)
  std::vector<float> field, spatial;     // [channel][bin]
  std::vector<uint32_t> located_tet;     // per original vertex of the region (in its order)
};

}  // namespace

PreprocessReport preprocess(const std::filesystem::path& mesh_path, const std::filesystem::path& store_path, const PreprocessOptions& options,
                            storage::Progress* progress) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  if (options.segment_tets < 256) throw std::invalid_argument("--segment-tets must be at least 256");
  if (options.base_tets < 1) throw std::invalid_argument("--base-tets must be at least 1");
  if (!(options.level_ratio > 0.01 && options.level_ratio < 0.95)) throw std::invalid_argument("--level-ratio must be in (0.01, 0.95)");
  if (options.histogram_bins < 2 || options.histogram_bins > dag::kMaxBins) throw std::invalid_argument("--bins must be 2 to " + std::to_string(dag::kMaxBins));
  if (options.threads < 1 || options.threads > 64) throw std::invalid_argument("--threads must be 1 to 64");
  if (options.max_levels < 1 || options.max_levels > dag::kMaxLevels) throw std::invalid_argument("--max-levels must be 1 to " + std::to_string(dag::kMaxLevels));
  if (!options.replace && std::filesystem::exists(store_path)) throw std::runtime_error(store_path.string() + " exists (use --force to replace it)");
  auto stage = [&](const char* name, double fraction) {
    if (!progress) return;
    if (fraction == 0) progress->begin(name);
    else progress->update(fraction);
  };
  PreprocessReport report;

  // ---- ingest ----
  stage("read", 0);
  std::filesystem::path hashed = mesh_path;
  if (storage::format_from_path(mesh_path) == storage::MeshFormat::kTetgen) hashed.replace_extension(".ele");
  storage::FileHasher sha256(hashed);  // checks the file is regular first; cancelled if reading fails
  storage::ReadStats read_stats;
  storage::TetMesh input = storage::load_mesh(mesh_path, &read_stats, options.read_limits);
  const uint64_t unused_vertices = storage::drop_unused_vertices(input);
  if (input.tet_count() == 0) throw std::runtime_error(mesh_path.string() + ": the mesh has no tetrahedra");
  if (input.vertex_count() >= 0x7FFFFFFFu) throw std::runtime_error(mesh_path.string() + ": too many vertices for one store");
  const uint32_t n0 = static_cast<uint32_t>(input.vertex_count());
  report.input_vertices = n0;
  report.input_tets = input.tet_count();
  VertexTable table;
  table.xyz.resize(3 * size_t{n0});
  for (uint32_t v = 0; v < n0; ++v) {
    table.xyz[3 * size_t{v}] = input.x[v];
    table.xyz[3 * size_t{v} + 1] = input.y[v];
    table.xyz[3 * size_t{v} + 2] = input.z[v];
  }
  std::vector<storage::AttributeInfo> attribute_info;
  for (const auto& a : input.attributes) {
    attribute_info.push_back(a.info);
    table.floats += a.info.components;
  }
  table.values.resize(size_t{n0} * table.floats);
  Channels channels;
  std::vector<std::array<double, 2>> ranges;  // for the simplifier: value range (scalars), [0, longest] (vectors)
  {
    uint32_t base = 0;
    for (const auto& a : input.attributes) {
      const uint32_t c = a.info.components;
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (uint32_t v = 0; v < n0; ++v) {
        double m = 0;
        for (uint32_t k = 0; k < c; ++k) {
          table.values[size_t{v} * table.floats + base + k] = a.values[size_t{v} * c + k];
          m += double(a.values[size_t{v} * c + k]) * a.values[size_t{v} * c + k];
        }
        m = c == 1 ? double(a.values[v]) : std::sqrt(m);
        if (!std::isfinite(m)) continue;
        lo = std::min(lo, m);
        hi = std::max(hi, m);
      }
      if (!std::isfinite(lo)) lo = hi = 0;
      channels.offset.push_back(base);
      channels.components.push_back(c);
      channels.lo.push_back(c == 1 ? lo : 0);
      channels.scale.push_back(c == 1 ? (hi > lo ? 1 / (hi - lo) : 0) : (hi > 0 ? 1 / hi : 0));
      ranges.push_back(c == 1 ? std::array<double, 2>{lo, hi} : std::array<double, 2>{0, hi});
      base += c;
    }
  }
  const storage::Bounds bounds = storage::compute_bounds(input);
  const double diagonal = std::max(1e-30, std::sqrt(std::pow(bounds.max[0] - bounds.min[0], 2) + std::pow(bounds.max[1] - bounds.min[1], 2) +
                                                    std::pow(bounds.max[2] - bounds.min[2], 2)));
  std::vector<uint32_t> level0_tets = std::move(input.tets);
  input = storage::TetMesh();
  report.read_seconds = seconds_since(start);

  const uint32_t C = static_cast<uint32_t>(channels.offset.size()), N = options.histogram_bins;
  const unsigned threads = options.threads;
  std::vector<BuildNode> nodes;
  std::vector<PatchRange> patches;
  std::vector<float> field, spatial;  // per node: [channel][bin]
  std::vector<uint32_t> local_of(n0, kNone);
  // where every original vertex is: node and tet (index in the node's tets)
  std::vector<uint32_t> located_node(n0, kNone), located_tet(n0, kNone);
  std::vector<uint32_t> level0_owner;  // the level-0 segment that owns each input vertex

  // ---- level 0 ----
  auto partition_start = clock::now();
  stage("partition", 0);
  {
    const uint64_t parts = std::max<uint64_t>(1, (level0_tets.size() / 4 + options.segment_tets / 2) / options.segment_tets);
    uint32_t count = 0;
    std::vector<const std::vector<uint32_t>*> lists{&level0_tets};
    auto region = partition_level(lists, table, static_cast<uint32_t>(std::min<uint64_t>(parts, storage::store::kMaxSegments)), false, options.seed, local_of, &count);
    nodes.resize(count);
    std::vector<uint64_t> size(count, 0);
    for (uint32_t r : region[0]) ++size[r];
    for (uint32_t r = 0; r < count; ++r) nodes[r].tets.reserve(4 * size[r]);
    for (size_t t = 0; t < region[0].size(); ++t) {
      auto& list = nodes[region[0][t]].tets;
      for (int k = 0; k < 4; ++k) {
        const uint32_t g = level0_tets[4 * t + k];
        if (located_node[g] == kNone) {
          located_node[g] = region[0][t];
          located_tet[g] = static_cast<uint32_t>(list.size() / 4);
        }
      }
      list.insert(list.end(), level0_tets.begin() + 4 * t, level0_tets.begin() + 4 * t + 4);
    }
    std::vector<uint32_t>().swap(level0_tets);
    // owners: the segment of the vertex's first tet; unused vertices go to segment 0
    level0_owner = located_node;
    for (uint32_t& o : level0_owner)
      if (o == kNone) o = 0;
    field.assign(size_t{count} * C * N, 0.0f);
    spatial.assign(size_t{count} * C * N, 0.0f);
  }
  report.segment_seconds = seconds_since(partition_start);
  // original vertices that lie in the mesh (isolated ones are not followed)
  std::vector<uint32_t> followed;
  for (uint32_t v = 0; v < n0; ++v)
    if (located_node[v] != kNone) followed.push_back(v);

  // ---- coarser levels ----
  const auto simplify_start = clock::now();
  std::vector<uint32_t> level_first{0, static_cast<uint32_t>(nodes.size())};  // nodes of level L: [level_first[L], level_first[L+1])
  auto level_tets = [&](uint32_t L) {
    uint64_t sum = 0;
    for (uint32_t n = level_first[L]; n < level_first[L + 1]; ++n) sum += nodes[n].tets.size() / 4;
    return sum;
  };
  std::vector<uint32_t> vertex_region(n0, kNone);
  for (uint32_t L = 0;; ++L) {
    const uint32_t first = level_first[L], last = level_first[L + 1];
    const uint64_t tets = level_tets(L);
    stage("simplify", std::min(0.99, 1.0 - double(tets) / double(report.input_tets) + 0.01));
    if (tets <= options.base_tets || last - first <= 1 || L + 1 >= options.max_levels) break;
    if (L > 0 && double(tets) > 0.9 * double(level_tets(L - 1))) break;  // locked borders stop the simplification
    // partition M(L) into the ceiling segments of level L+1
    std::vector<const std::vector<uint32_t>*> lists;
    for (uint32_t n = first; n < last; ++n) lists.push_back(&nodes[n].tets);
    if (local_of.size() < table.size()) local_of.resize(table.size(), kNone);
    // ceilings of about segment_tets once simplified; the mesh turned on odd levels (§6.3.2)
    const uint64_t parts = std::max<uint64_t>(1, static_cast<uint64_t>(std::llround(double(tets) * options.level_ratio / options.segment_tets)));
    uint32_t regions = 0;
    auto region = partition_level(lists, table, static_cast<uint32_t>(parts), L % 2 == 1, options.seed + static_cast<int>(L) + 1, local_of, &regions);
    const uint32_t ceiling_base = static_cast<uint32_t>(nodes.size());
    // group every floor segment's tets by ceiling: patches; follow the original vertices
    std::vector<std::vector<std::array<uint32_t, 3>>> region_patches(regions);  // (floor, begin, count)
    std::vector<std::array<uint32_t, 2>> floor_patches(last - first);              // (first patch, count)
    for (uint32_t n = first; n < last; ++n) {
      const auto& r = region[n - first];
      const uint32_t count = static_cast<uint32_t>(r.size());
      std::vector<uint32_t> order(count);
      std::iota(order.begin(), order.end(), 0u);
      std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return r[a] < r[b]; });
      std::vector<uint32_t> sorted(nodes[n].tets.size()), position(count);
      for (uint32_t i = 0; i < count; ++i) {
        std::copy_n(nodes[n].tets.begin() + 4 * size_t{order[i]}, 4, sorted.begin() + 4 * size_t{i});
        position[order[i]] = i;
      }
      nodes[n].tets.swap(sorted);
      floor_patches[n - first] = {static_cast<uint32_t>(patches.size()), 0};
      for (uint32_t i = 0; i < count;) {
        uint32_t j = i;
        while (j < count && r[order[j]] == r[order[i]]) ++j;
        region_patches[r[order[i]]].push_back({n, i, j - i});
        patches.push_back({ceiling_base + r[order[i]], n, i, j - i});
        ++floor_patches[n - first][1];
        i = j;
      }
      region[n - first].swap(position);  // now: old tet index -> new index
    }
    // original vertices per ceiling, in `followed` order
    std::vector<std::vector<uint32_t>> region_vertices(regions);
    for (uint32_t v : followed) {
      const uint32_t n = located_node[v];
      const uint32_t t = region[n - first][located_tet[v]];
      located_tet[v] = t;
      // the ceiling of tet t: the patch range that holds it
      uint32_t ceiling = 0;
      const auto [fp, fc] = floor_patches[n - first];
      for (uint32_t p = fp; p < fp + fc; ++p) {
        const PatchRange& q = patches[p];
        if (t >= q.begin && t < q.begin + q.count) {
          ceiling = q.ceiling - ceiling_base;
          break;
        }
      }
      region_vertices[ceiling].push_back(v);
    }
    // vertices on the border between ceilings are locked
    if (vertex_region.size() < table.size()) vertex_region.resize(table.size(), kNone);
    for (uint32_t k = 0; k < regions; ++k)
      for (const auto& [n, begin, count] : region_patches[k])
        for (size_t i = 4 * size_t{begin}; i < 4 * (size_t{begin} + count); ++i) {
          uint32_t& vr = vertex_region[nodes[n].tets[i]];
          vr = vr == kNone || vr == k ? k : kMany;
        }
    // simplify every ceiling segment, its border locked
    std::vector<RegionResult> results(regions);
    std::atomic<uint32_t> done{0};
    parallel_for(regions, threads, [&](size_t k) {
      RegionResult& out = results[k];
      std::vector<uint32_t> global;
      for (const auto& [n, begin, count] : region_patches[k])
        global.insert(global.end(), nodes[n].tets.begin() + 4 * size_t{begin}, nodes[n].tets.begin() + 4 * (size_t{begin} + count));
      std::vector<uint32_t> tets_global = global;
      std::sort(global.begin(), global.end());
      global.erase(std::unique(global.begin(), global.end()), global.end());
      storage::TetMesh m;
      const size_t nv = global.size();
      m.x.resize(nv);
      m.y.resize(nv);
      m.z.resize(nv);
      std::vector<uint8_t> locked(nv, 0);
      for (size_t l = 0; l < nv; ++l) {
        m.x[l] = table.xyz[3 * size_t{global[l]}];
        m.y[l] = table.xyz[3 * size_t{global[l]} + 1];
        m.z[l] = table.xyz[3 * size_t{global[l]} + 2];
        locked[l] = vertex_region[global[l]] == kMany;
      }
      for (size_t a = 0, base = 0; a < attribute_info.size(); base += attribute_info[a].components, ++a) {
        storage::Attribute attribute{attribute_info[a], std::vector<float>(nv * attribute_info[a].components)};
        for (size_t l = 0; l < nv; ++l)
          for (uint32_t c = 0; c < attribute_info[a].components; ++c)
            attribute.values[l * attribute_info[a].components + c] = table.values[size_t{global[l]} * table.floats + base + c];
        m.attributes.push_back(std::move(attribute));
      }
      m.tets.resize(tets_global.size());
      for (size_t i = 0; i < tets_global.size(); ++i)
        m.tets[i] = static_cast<uint32_t>(std::lower_bound(global.begin(), global.end(), tets_global[i]) - global.begin());
      SimplifyOptions so;
      so.target_tets = std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(options.level_ratio * double(m.tet_count()))));
      so.frame = bounds;
      so.attribute_ranges = ranges;
      so.threads = 1;
      so.seed = static_cast<uint32_t>(options.seed);
      const storage::TetMesh before = m;
      SimplifyReport sr = simplify(m, so, locked);
      out.global.resize(m.vertex_count());
      for (size_t l = 0; l < m.vertex_count(); ++l) {
        const uint32_t src = sr.source_vertex[l];
        bool same = m.x[l] == before.x[src] && m.y[l] == before.y[src] && m.z[l] == before.z[src];
        for (size_t a = 0; a < m.attributes.size() && same; ++a) {
          const uint32_t c = m.attributes[a].info.components;
          same = std::memcmp(&m.attributes[a].values[l * c], &before.attributes[a].values[size_t{src} * c], 4 * c) == 0;
        }
        out.global[l] = same ? global[src] : kNone;
      }
      // error at the original vertices this ceiling holds
      out.field.assign(size_t{C} * N, 0.0f);
      out.spatial.assign(size_t{C} * N, 0.0f);
      Locator locator(m);
      std::vector<double> original(C), approx(C), corner(4 * size_t{C});
      std::vector<float> values(table.floats);
      out.located_tet.resize(region_vertices[k].size());
      for (size_t i = 0; i < region_vertices[k].size(); ++i) {
        const uint32_t v = region_vertices[k][i];
        double bary[4];
        const Vec p{table.xyz[3 * size_t{v}], table.xyz[3 * size_t{v} + 1], table.xyz[3 * size_t{v} + 2]};
        const uint32_t t = locator.locate(p, bary);
        out.located_tet[i] = t;
        if (C == 0) continue;
        channels.normalise(&table.values[size_t{v} * table.floats], original.data());
        const uint32_t* tet = &m.tets[4 * size_t{t}];
        for (int j = 0; j < 4; ++j) {
          size_t base = 0;
          for (size_t a = 0; a < m.attributes.size(); ++a) {
            const uint32_t c = m.attributes[a].info.components;
            for (uint32_t q = 0; q < c; ++q) values[base + q] = m.attributes[a].values[size_t{tet[j]} * c + q];
            base += c;
          }
          channels.normalise(values.data(), &corner[static_cast<size_t>(j) * C]);
        }
        // gradient of each channel in the tet (per unit of the diagonal)
        double P[4][3];
        for (int j = 0; j < 4; ++j) {
          P[j][0] = m.x[tet[j]] / diagonal;
          P[j][1] = m.y[tet[j]] / diagonal;
          P[j][2] = m.z[tet[j]] / diagonal;
        }
        double e[3][3];
        for (int j = 0; j < 3; ++j)
          for (int q = 0; q < 3; ++q) e[j][q] = P[j + 1][q] - P[0][q];
        const double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
        for (uint32_t c = 0; c < C; ++c) {
          double a = 0;
          for (int j = 0; j < 4; ++j) a += bary[j] * corner[static_cast<size_t>(j) * C + c];
          const double err = std::fabs(a - original[c]);
          const uint32_t bin = std::min<uint32_t>(N - 1, static_cast<uint32_t>(std::clamp(original[c], 0.0, 1.0) * N));
          float& f = out.field[size_t{c} * N + bin];
          f = std::max(f, static_cast<float>(err));
          // isosurface displacement ~ error / |gradient| (Cramer's rule for the gradient)
          double g2 = 0;
          if (std::fabs(det) > 0) {
            double d[3];
            for (int j = 0; j < 3; ++j) d[j] = corner[static_cast<size_t>(j + 1) * C + c] - corner[c];
            double grad[3];
            for (int q = 0; q < 3; ++q) {
              double m3[3][3];
              for (int r = 0; r < 3; ++r)
                for (int s = 0; s < 3; ++s) m3[r][s] = s == q ? d[r] : e[r][s];
              grad[q] = (m3[0][0] * (m3[1][1] * m3[2][2] - m3[1][2] * m3[2][1]) - m3[0][1] * (m3[1][0] * m3[2][2] - m3[1][2] * m3[2][0]) +
                         m3[0][2] * (m3[1][0] * m3[2][1] - m3[1][1] * m3[2][0])) / det;
            }
            g2 = grad[0] * grad[0] + grad[1] * grad[1] + grad[2] * grad[2];
          }
          const double distance = err > 0 ? (g2 > 0 ? std::min(1.0, err / std::sqrt(g2)) : 1.0) : 0.0;
          float& s = out.spatial[size_t{c} * N + bin];
          s = std::max(s, static_cast<float>(distance));
        }
      }
      out.mesh = std::move(m);
      ++done;
    });
    // new vertices get ids in ceiling order (deterministic); ceilings become level L+1
    field.resize(field.size() + size_t{regions} * C * N, 0.0f);
    spatial.resize(spatial.size() + size_t{regions} * C * N, 0.0f);
    for (uint32_t k = 0; k < regions; ++k) {
      RegionResult& res = results[k];
      const storage::TetMesh& m = res.mesh;
      for (size_t l = 0; l < m.vertex_count(); ++l) {
        if (res.global[l] != kNone) continue;
        res.global[l] = static_cast<uint32_t>(table.size());
        table.xyz.insert(table.xyz.end(), {m.x[l], m.y[l], m.z[l]});
        for (const auto& a : m.attributes) {
          const uint32_t c = a.info.components;
          table.values.insert(table.values.end(), a.values.begin() + l * c, a.values.begin() + (l + 1) * c);
        }
      }
      if (table.size() >= 0xFFFFFFF0u) throw std::runtime_error("too many vertices for one store");
      BuildNode node;
      node.level = L + 1;
      node.tets.resize(m.tets.size());
      for (size_t i = 0; i < m.tets.size(); ++i) node.tets[i] = res.global[m.tets[i]];
      const uint32_t id = static_cast<uint32_t>(nodes.size());
      nodes.push_back(std::move(node));
      std::copy(res.field.begin(), res.field.end(), field.begin() + size_t{id} * C * N);
      std::copy(res.spatial.begin(), res.spatial.end(), spatial.begin() + size_t{id} * C * N);
      for (size_t i = 0; i < region_vertices[k].size(); ++i) {
        located_node[region_vertices[k][i]] = id;
        located_tet[region_vertices[k][i]] = res.located_tet[i];
      }
      res = RegionResult();
    }
    // reset the border marks
    std::fill(vertex_region.begin(), vertex_region.end(), kNone);
    level_first.push_back(static_cast<uint32_t>(nodes.size()));
  }
  const uint32_t levels = static_cast<uint32_t>(level_first.size() - 1);
  const uint32_t node_count = static_cast<uint32_t>(nodes.size());
  if (node_count > storage::store::kMaxSegments) throw std::runtime_error("too many segments");
  // the coarsest segments hang from the root; patches grouped by ceiling, roots first
  std::vector<PatchRange> all;
  for (uint32_t n = level_first[levels - 1]; n < node_count; ++n) all.push_back({dag::kRoot, n, 0, static_cast<uint32_t>(nodes[n].tets.size() / 4)});
  std::stable_sort(patches.begin(), patches.end(), [](const PatchRange& a, const PatchRange& b) { return a.ceiling < b.ceiling; });
  all.insert(all.end(), patches.begin(), patches.end());
  std::vector<PatchRange>().swap(patches);
  // monotone histograms: a segment's error is at least its children's (children have lower ids)
  for (const PatchRange& p : all) {
    if (p.ceiling == dag::kRoot) continue;
    for (size_t i = 0; i < size_t{C} * N; ++i) {
      field[size_t{p.ceiling} * C * N + i] = std::max(field[size_t{p.ceiling} * C * N + i], field[size_t{p.floor} * C * N + i]);
      spatial[size_t{p.ceiling} * C * N + i] = std::max(spatial[size_t{p.ceiling} * C * N + i], spatial[size_t{p.floor} * C * N + i]);
    }
  }
  report.simplify_seconds = seconds_since(simplify_start);

  // ---- write the store ----
  const auto write_start = clock::now();
  stage("write", 0);
  const uint64_t vertex_total = table.size();
  // owners: input vertices by the level-0 partition, later ones by the first segment using them
  std::vector<uint32_t> owner(vertex_total, kNone);
  std::copy(level0_owner.begin(), level0_owner.end(), owner.begin());
  for (uint32_t n = 0; n < node_count; ++n)
    for (uint32_t g : nodes[n].tets)
      if (owner[g] == kNone) owner[g] = n;
  std::vector<std::vector<uint32_t>> owned(node_count);
  for (uint64_t g = 0; g < vertex_total; ++g) owned[owner[g]].push_back(static_cast<uint32_t>(g));
  // faces: paired inside a segment, then across the segments of the same level
  struct FaceKey {
    uint32_t v[3], node, face;
    bool operator<(const FaceKey& o) const { return std::tie(v[0], v[1], v[2], node, face) < std::tie(o.v[0], o.v[1], o.v[2], o.node, o.face); }
    bool same(const FaceKey& o) const { return v[0] == o.v[0] && v[1] == o.v[1] && v[2] == o.v[2]; }
  };
  std::vector<std::vector<uint32_t>> opposites(node_count);
  std::vector<std::vector<storage::store::BorderLink>> links(node_count);
  std::vector<std::vector<uint32_t>> neighbours(node_count);
  for (uint32_t L = 0; L < levels; ++L) {
    std::vector<std::vector<FaceKey>> unpaired(level_first[L + 1] - level_first[L]);
    parallel_for(unpaired.size(), threads, [&](size_t i) {
      const uint32_t n = level_first[L] + static_cast<uint32_t>(i);
      const auto& tets = nodes[n].tets;
      const uint32_t faces = static_cast<uint32_t>(tets.size());
      std::vector<FaceKey> keys(faces);
      for (uint32_t f = 0; f < faces; ++f) {
        FaceKey& k = keys[f];
        for (int j = 0; j < 3; ++j) k.v[j] = tets[4 * size_t{f / 4} + kFace[f % 4][j]];
        std::sort(k.v, k.v + 3);
        k.node = n;
        k.face = f;
      }
      std::sort(keys.begin(), keys.end());
      auto& opp = opposites[n];
      opp.assign(faces, storage::store::kMeshBoundary);
      for (size_t a = 0; a < keys.size();) {
        size_t b = a + 1;
        while (b < keys.size() && keys[b].same(keys[a])) ++b;
        if (b - a == 2) {
          opp[keys[a].face] = keys[a + 1].face;
          opp[keys[a + 1].face] = keys[a].face;
        } else {
          for (size_t c = a; c < b; ++c) unpaired[i].push_back(keys[c]);
        }
        a = b;
      }
    });
    std::vector<FaceKey> rest;
    for (auto& u : unpaired) rest.insert(rest.end(), u.begin(), u.end());
    std::sort(rest.begin(), rest.end());
    for (size_t a = 0; a < rest.size();) {
      size_t b = a + 1;
      while (b < rest.size() && rest[b].same(rest[a])) ++b;
      if (b - a == 2 && rest[a].node != rest[a + 1].node) {
        const FaceKey &x = rest[a], &y = rest[a + 1];
        opposites[x.node][x.face] = storage::store::kSegmentBorder;
        opposites[y.node][y.face] = storage::store::kSegmentBorder;
        links[x.node].push_back({x.face, y.node, y.face});
        links[y.node].push_back({y.face, x.node, x.face});
        neighbours[x.node].push_back(y.node);
        neighbours[y.node].push_back(x.node);
      }
      a = b;
    }
  }
  std::vector<std::array<float, 6>> node_bounds(node_count);
  for (uint32_t n = 0; n < node_count; ++n) {
    auto& b = node_bounds[n];
    b = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
         std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest()};
    auto extend = [&](uint32_t g) {
      for (int k = 0; k < 3; ++k) {
        b[k] = std::min(b[k], table.xyz[3 * size_t{g} + k]);
        b[3 + k] = std::max(b[3 + k], table.xyz[3 * size_t{g} + k]);
      }
    };
    for (uint32_t g : nodes[n].tets) extend(g);
    for (uint32_t g : owned[n]) extend(g);
    // shared copies' owners are neighbours too
    for (uint32_t g : nodes[n].tets)
      if (owner[g] != n) {
        neighbours[n].push_back(owner[g]);
        neighbours[owner[g]].push_back(n);
      }
  }
  for (auto& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  // level 0 in streaming order (§6.1.3), then the coarser levels
  std::vector<std::vector<uint32_t>> level0_neighbours(level_first[1]);
  for (uint32_t n = 0; n < level_first[1]; ++n)
    for (uint32_t m : neighbours[n])
      if (m < level_first[1]) level0_neighbours[n].push_back(m);
  StreamOrder order = streaming_order(level0_neighbours, std::span<const std::array<float, 6>>(node_bounds.data(), level_first[1]));
  std::vector<uint32_t> write_order = order.order;
  for (uint32_t n = level_first[1]; n < node_count; ++n) write_order.push_back(n);

  storage::StoreWriter writer(store_path, options.replace, vertex_total, node_count, table.floats);
  std::vector<uint32_t> local(vertex_total, kNone);
  uint64_t written = 0;
  for (uint32_t n : write_order) {
    storage::SegmentData data;
    data.id = n;
    data.global_ids = owned[n];
    data.owned_vertex_count = static_cast<uint32_t>(owned[n].size());
    std::vector<uint32_t> shared;
    for (uint32_t g : nodes[n].tets)
      if (owner[g] != n) shared.push_back(g);
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
    for (const auto& a : attribute_info) {
      for (size_t l = 0; l < nv; ++l)
        for (uint32_t c = 0; c < a.components; ++c) data.attributes[base + l * a.components + c] = table.values[size_t{data.global_ids[l]} * table.floats + value_base + c];
      base += nv * a.components;
      value_base += a.components;
    }
    data.tets.resize(nodes[n].tets.size());
    for (size_t i = 0; i < data.tets.size(); ++i) data.tets[i] = local[nodes[n].tets[i]];
    for (uint32_t g : data.global_ids) local[g] = kNone;
    // tets are grouped by patch (dag.bin), not border-first: every tet counts as a border tet
    data.boundary_tet_count = static_cast<uint32_t>(data.tets.size() / 4);
    data.opposites = std::move(opposites[n]);
    data.links = std::move(links[n]);
    std::sort(data.links.begin(), data.links.end(), [](const storage::store::BorderLink& a, const storage::store::BorderLink& b) { return a.face < b.face; });
    std::copy(node_bounds[n].begin(), node_bounds[n].end(), data.bounds);
    writer.add_segment(data);
    stage("write", 0.9 * double(++written) / node_count);
  }
  // dag.bin
  std::vector<dag::Node> dag_nodes(node_count);
  std::vector<dag::Patch> dag_patches(all.size());
  for (uint32_t n = 0; n < node_count; ++n) {
    dag::Node& d = dag_nodes[n];
    d.level = nodes[n].level;
    d.tet_count = static_cast<uint32_t>(nodes[n].tets.size() / 4);
    std::copy(node_bounds[n].begin(), node_bounds[n].end(), d.bounds);
  }
  std::vector<uint32_t> parent_count(node_count, 0);
  for (uint32_t p = 0; p < all.size(); ++p) {
    dag_patches[p] = {all[p].ceiling, all[p].floor, all[p].begin, all[p].count};
    ++parent_count[all[p].floor];
    if (all[p].ceiling != dag::kRoot) {
      dag::Node& c = dag_nodes[all[p].ceiling];
      if (c.child_count == 0) c.first_child = p;
      ++c.child_count;
    }
  }
  for (uint32_t n = 0, at = 0; n < node_count; ++n) {
    dag_nodes[n].first_parent = at;
    dag_nodes[n].parent_count = parent_count[n];
    at += parent_count[n];
  }
  std::vector<float> histograms(size_t{node_count} * C * 2 * N);
  for (uint32_t n = 0; n < node_count; ++n)
    for (uint32_t c = 0; c < C; ++c) {
      std::copy_n(field.begin() + (size_t{n} * C + c) * N, N, histograms.begin() + ((size_t{n} * C + c) * 2) * N);
      std::copy_n(spatial.begin() + (size_t{n} * C + c) * N, N, histograms.begin() + ((size_t{n} * C + c) * 2 + 1) * N);
    }
  const std::filesystem::path dag_path = writer.temp_directory() / "dag.bin";
  write_dag(dag_path, levels, dag_nodes, dag_patches, C, N, histograms);
  report.dag_bytes = std::filesystem::file_size(dag_path);

  // ---- manifest ----
  uint64_t stored_tets = 0;
  for (const auto& node : nodes) stored_tets += node.tets.size() / 4;
  nlohmann::json manifest;
  manifest["format"] = "tetrascope-store";
  manifest["version"] = storage::store::kFormatVersion;
  std::error_code ec;
  manifest["source"] = {{"file", std::filesystem::absolute(mesh_path).string()}, {"format", storage::format_name(storage::format_from_path(mesh_path))},
                        {"bytes", std::filesystem::file_size(hashed, ec)}, {"sha256", sha256.get()}};
  manifest["counts"] = {{"vertices", vertex_total}, {"tetrahedra", stored_tets}, {"segments", node_count},
                        {"degenerate_tetrahedra", read_stats.degenerate}, {"reoriented_tetrahedra", read_stats.inverted},
                        {"dropped_unused_vertices", unused_vertices}, {"dropped_repeated_vertex_tetrahedra", read_stats.repeated_vertex}};
  nlohmann::json attribute_list = nlohmann::json::array();
  for (size_t a = 0; a < attribute_info.size(); ++a) {
    const double lo = attribute_info[a].components == 1 ? ranges[a][0] : 0, hi = ranges[a][1];
    attribute_list.push_back({{"name", attribute_info[a].name}, {"components", attribute_info[a].components}, {"min", lo}, {"max", hi},
                              {"range_of", attribute_info[a].components == 1 ? "value" : "magnitude"},
                              {"normalisation", {{"offset", lo}, {"scale", hi > lo ? 1.0 / (hi - lo) : 1.0}}}});
  }
  manifest["attributes"] = attribute_list;
  manifest["bounds"] = {{"min", {bounds.min[0], bounds.min[1], bounds.min[2]}}, {"max", {bounds.max[0], bounds.max[1], bounds.max[2]}}};
  manifest["stream"] = {{"tags", order.tags}, {"max_workload_segments", order.max_workload}};
  nlohmann::json level_list = nlohmann::json::array();
  for (uint32_t L = 0; L < levels; ++L) {
    LevelReport lr;
    lr.level = L;
    lr.segments = level_first[L + 1] - level_first[L];
    lr.tets = level_tets(L);
    std::vector<uint32_t> used;
    for (uint32_t n = level_first[L]; n < level_first[L + 1]; ++n) used.insert(used.end(), nodes[n].tets.begin(), nodes[n].tets.end());
    std::sort(used.begin(), used.end());
    lr.vertices = static_cast<uint64_t>(std::unique(used.begin(), used.end()) - used.begin());
    for (const auto& p : all)
      if (p.floor >= level_first[L] && p.floor < level_first[L + 1]) ++lr.patches;
    report.levels.push_back(lr);
    level_list.push_back({{"level", L}, {"first_segment", level_first[L]}, {"segments", lr.segments}, {"tets", lr.tets}, {"vertices", lr.vertices}, {"patches", lr.patches}});
  }
  report.segments = node_count;
  report.patches = static_cast<uint32_t>(all.size());
  manifest["multiresolution"] = {{"dag", "dag.bin"}, {"input", {{"vertices", n0}, {"tetrahedra", report.input_tets}}}, {"levels", level_list},
                                 {"patches", all.size()}, {"histogram_bins", N},
                                 {"build", {{"segment_tets", options.segment_tets}, {"base_tets", options.base_tets}, {"level_ratio", options.level_ratio}, {"seed", options.seed}}}};
  stage("write", 0.95);
  writer.finish(neighbours, manifest);
  report.store_bytes = writer.bytes_written() + report.dag_bytes;
  report.write_seconds = seconds_since(write_start);
  report.seconds = seconds_since(start);
  if (progress) progress->finish();
  return report;
}

}  // namespace tetrascope::lod
