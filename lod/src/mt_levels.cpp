// Stage 2 of `tetrascope preprocess`: the levels of the multi-triangulation (dissertation
// §6.3.1-6.3.2). Level 0 is the input, partitioned by the same step as `tetrascope segment`
// (partition_segments, §6.1.1). Each coarser level partitions the mesh of the level below
// (turned 45° on odd levels), cuts its segments into patches by the new segments (ceilings)
// and simplifies every ceiling with its border vertices locked. Once a level is one segment
// the next ones are too, each the whole mesh simplified again, until the base is met.
//
// Under MPI (ranks.h) every rank builds the same partitions and patches; each simplifies the
// ceilings it owns (mt_share.cpp) and, once the results are exchanged, every rank adds the
// level in ceiling order, as one rank alone would.
//
// Every original vertex is followed down the levels (the tet of the current level that holds
// it), so that each ceiling's error histograms (mt_histograms.cpp) are measured at the
// original vertices it covers.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <numeric>

#include "mt_stages.h"
#include "tetrascope/lod/level_targets.h"
#include "tetrascope/lod/octree_partition.h"
#include "tetrascope/lod/simplify.h"
#include "tetrascope/storage/parallel_for.h"
#include "tetrascope/storage/store_format.h"

namespace tetrascope::lod::mt {
namespace {

constexpr uint32_t kMany = 0xFFFFFFFEu;  // a vertex used by several ceilings: locked

// Turns points 45° about the longest axis of their box, through their centroid (§6.3.2).
void rotate_45(std::vector<float>& xyz) {
  const size_t count = xyz.size() / 3;
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300}, centre[3] = {0, 0, 0};
  for (size_t i = 0; i < count; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min<double>(lo[k], xyz[3 * i + k]);
      hi[k] = std::max<double>(hi[k], xyz[3 * i + k]);
      centre[k] += xyz[3 * i + k];
    }
  for (double& c : centre) c /= double(count);
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
  const int a = (axis + 1) % 3, b = (axis + 2) % 3;
  const double c = std::sqrt(0.5);
  for (size_t i = 0; i < count; ++i) {
    double u = xyz[3 * i + a] - centre[a], v = xyz[3 * i + b] - centre[b];
    xyz[3 * i + a] = static_cast<float>(centre[a] + c * (u - v));
    xyz[3 * i + b] = static_cast<float>(centre[b] + c * (u + v));
  }
}

// Regions of one level: partition_segments over the vertices its tets use, each tet to the
// lowest region among its vertices, regions left without tets dropped. `lists` are the
// level's tet lists; `local_of` is all kNone on entry and on return. Returns the region of
// every tet, list by list.
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
  if (rotate && !used.empty()) rotate_45(xyz);
  std::vector<float> tets_per_vertex(used.size(), 0.0f);
  for (const auto* list : lists)
    for (uint32_t g : *list) tets_per_vertex[local_of[g]] += 0.25f;
  const SegmentPartition partition = partition_segments(xyz, parts, 0, seed, tets_per_vertex);
  std::vector<std::vector<uint32_t>> region(lists.size());
  std::vector<uint8_t> has_tets(partition.segments, 0);
  for (size_t l = 0; l < lists.size(); ++l) {
    const auto& tets = *lists[l];
    region[l].resize(tets.size() / 4);
    for (size_t t = 0; t < tets.size() / 4; ++t) {
      uint32_t r = kNone;
      for (int k = 0; k < 4; ++k) r = std::min(r, partition.segment_of_vertex[local_of[tets[4 * t + k]]]);
      region[l][t] = r;
      has_tets[r] = 1;
    }
  }
  // a region may end up without tets (all its vertices' tets went to lower regions): renumber
  std::vector<uint32_t> compact(partition.segments, kNone);
  uint32_t next = 0;
  for (size_t r = 0; r < has_tets.size(); ++r)
    if (has_tets[r]) compact[r] = next++;
  for (auto& list : region)
    for (uint32_t& r : list) r = compact[r];
  for (uint32_t g : used) local_of[g] = kNone;
  *region_count = next;
  return region;
}

// A ceiling's tets: ranges of floor segments' tets.
struct CeilingPatch {
  uint32_t floor, begin, count;
};

// Which rank works on each ceiling of a level, and the ceilings of this rank (all of them
// when the build runs alone).
struct CeilingShare {
  std::vector<uint32_t> owner;
  std::vector<uint32_t> mine;
};

// State carried from level to level.
class LevelBuilder {
 public:
  LevelBuilder(IngestedMesh& mesh, const PreprocessOptions& options, const StageProgress& stage) : mesh_(mesh), options_(options), stage_(stage) {}

  Hierarchy run() {
    using clock = std::chrono::steady_clock;
    const auto partition_start = clock::now();
    stage_("partition", 0);
    partition_level0();
    out_.partition_seconds = std::chrono::duration<double>(clock::now() - partition_start).count();
    out_.level_first = {0, static_cast<uint32_t>(out_.nodes.size())};
    // the levels to come and their work, predicted, for simplify's progress
    for (double t = double(mesh_.input_tets); t > double(options_.base_tets) && work_total_ < 1e300; t *= options_.level_ratio) {
      work_total_ += level_work(t);
      if (options_.level_ratio >= 1) break;
    }
    for (uint32_t level = 0;; ++level) {
      const uint64_t tets = out_.level_tets(level);
      stage_("simplify", simplify_fraction(work_done_));
      // A level of one segment goes on: its ceiling is the whole mesh, with nothing locked
      // but what the simplifier keeps on the mesh boundary, until the base is met or it stalls.
      if (tets <= options_.base_tets || level + 1 >= options_.max_levels) break;
      if (level > 0 && double(tets) > 0.9 * double(out_.level_tets(level - 1))) break;  // locked borders stop the simplification
      build_level(level, tets);
      out_.level_first.push_back(static_cast<uint32_t>(out_.nodes.size()));
    }
    if (out_.nodes.size() > storage::store::kMaxSegments) throw std::runtime_error("too many segments");
    return std::move(out_);
  }

 private:
  uint32_t channel_values() const { return static_cast<uint32_t>(mesh_.channels.size()) * options_.histogram_bins; }

  // Level 0: the input mesh, partitioned as `tetrascope segment` partitions it.
  void partition_level0() {
    const uint32_t n0 = mesh_.input_vertices;
    local_of_.assign(n0, kNone);
    located_node_.assign(n0, kNone);
    located_tet_.assign(n0, kNone);
    vertex_region_.assign(n0, kNone);
    std::vector<uint32_t>& level0_tets = mesh_.tets;
    const uint64_t parts = std::max<uint64_t>(1, (level0_tets.size() / 4 + options_.segment_tets / 2) / options_.segment_tets);
    uint32_t count = 0;
    std::vector<const std::vector<uint32_t>*> lists{&level0_tets};
    auto region = partition_level(lists, mesh_.table, static_cast<uint32_t>(std::min<uint64_t>(parts, storage::store::kMaxSegments)), false, options_.seed,
                                  local_of_, &count);
    out_.nodes.resize(count);
    std::vector<uint64_t> size(count, 0);
    for (uint32_t r : region[0]) ++size[r];
    for (uint32_t r = 0; r < count; ++r) out_.nodes[r].tets.reserve(4 * size[r]);
    for (size_t t = 0; t < region[0].size(); ++t) {
      auto& list = out_.nodes[region[0][t]].tets;
      for (int k = 0; k < 4; ++k) {
        const uint32_t g = level0_tets[4 * t + k];
        if (located_node_[g] == kNone) {
          located_node_[g] = region[0][t];
          located_tet_[g] = static_cast<uint32_t>(list.size() / 4);
        }
      }
      list.insert(list.end(), level0_tets.begin() + 4 * t, level0_tets.begin() + 4 * t + 4);
    }
    std::vector<uint32_t>().swap(level0_tets);
    // owners: the segment of the vertex's first tet; unused vertices go to segment 0
    out_.level0_owner = located_node_;
    for (uint32_t& o : out_.level0_owner)
      if (o == kNone) o = 0;
    out_.field.assign(size_t{count} * channel_values(), 0.0f);
    out_.spatial.assign(size_t{count} * channel_values(), 0.0f);
    // original vertices that lie in the mesh (isolated ones are not followed)
    for (uint32_t v = 0; v < n0; ++v)
      if (located_node_[v] != kNone) followed_.push_back(v);
  }

  // Level `level` + 1 from the mesh of `level` (`tets` tets).
  void build_level(uint32_t level, uint64_t tets) {
    const uint32_t first = out_.level_first[level], last = out_.level_first[level + 1];
    // partition M(level) into the ceiling segments of level + 1
    std::vector<const std::vector<uint32_t>*> lists;
    for (uint32_t n = first; n < last; ++n) lists.push_back(&out_.nodes[n].tets);
    if (local_of_.size() < mesh_.table.size()) local_of_.resize(mesh_.table.size(), kNone);
    // ceilings of about segment_tets once simplified; the mesh turned on odd levels (§6.3.2)
    const double simplified = double(tets) * options_.level_ratio;
    const uint64_t parts = std::max<uint64_t>({1, static_cast<uint64_t>(std::llround(simplified / options_.segment_tets)),
                                               std::min<uint64_t>(options_.min_segments, static_cast<uint64_t>(simplified / std::max(1u, options_.min_segment_tets)))});
    uint32_t regions = 0;
    auto region = partition_level(lists, mesh_.table, static_cast<uint32_t>(parts), level % 2 == 1, options_.seed + static_cast<int>(level) + 1, local_of_,
                                  &regions);
    const std::vector<std::vector<CeilingPatch>> ceiling_patches = cut_into_patches(first, last, regions, region);
    const std::vector<std::vector<uint32_t>> ceiling_vertices = follow_vertices(first, regions, region);
    lock_ceiling_borders(ceiling_patches);
    const CeilingShare share = share_ceilings(ceiling_patches);
    const std::vector<uint64_t> targets = ceiling_targets(ceiling_patches, tets, share);
    std::vector<CeilingResult> results(regions);
    const double work_before = work_done_, work = level_work(double(tets));
    const size_t mine = share.mine.size();
    std::atomic<uint32_t> simplified_ceilings{0};
    std::mutex reporting;
    parallel_for(mine, options_.threads, [&](size_t i, unsigned) {
      const uint32_t k = share.mine[i];
      results[k] = simplify_ceiling(ceiling_patches[k], ceiling_vertices[k], targets[k]);
      const uint32_t done = ++simplified_ceilings;
      std::unique_lock report(reporting, std::try_to_lock);  // a ceiling's end is reported by one worker at a time
      if (report) stage_("simplify", simplify_fraction(work_before + work * done / double(mine)));
    });
    if (shared()) share_results(*options_.ranks, share.owner, results, mesh_.attributes);
    work_done_ = work_before + work;
    add_ceilings(level + 1, results, ceiling_vertices);
    std::fill(vertex_region_.begin(), vertex_region_.end(), kNone);  // reset the border marks
  }

  // Groups every floor segment's tets by ceiling (the patches, appended to out_.patches);
  // `region` becomes, per floor, old tet index -> new index. Returns each ceiling's patches.
  std::vector<std::vector<CeilingPatch>> cut_into_patches(uint32_t first, uint32_t last, uint32_t regions, std::vector<std::vector<uint32_t>>& region) {
    const uint32_t ceiling_base = last;
    std::vector<std::vector<CeilingPatch>> ceiling_patches(regions);
    floor_patches_.assign(last - first, {0, 0});
    for (uint32_t n = first; n < last; ++n) {
      const auto& r = region[n - first];
      const uint32_t count = static_cast<uint32_t>(r.size());
      std::vector<uint32_t> order(count);
      std::iota(order.begin(), order.end(), 0u);
      std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return r[a] < r[b]; });
      std::vector<uint32_t> sorted(out_.nodes[n].tets.size()), position(count);
      for (uint32_t i = 0; i < count; ++i) {
        std::copy_n(out_.nodes[n].tets.begin() + 4 * size_t{order[i]}, 4, sorted.begin() + 4 * size_t{i});
        position[order[i]] = i;
      }
      out_.nodes[n].tets.swap(sorted);
      floor_patches_[n - first] = {static_cast<uint32_t>(out_.patches.size()), 0};
      for (uint32_t i = 0; i < count;) {
        uint32_t j = i;
        while (j < count && r[order[j]] == r[order[i]]) ++j;
        ceiling_patches[r[order[i]]].push_back({n, i, j - i});
        out_.patches.push_back({ceiling_base + r[order[i]], n, i, j - i});
        ++floor_patches_[n - first][1];
        i = j;
      }
      region[n - first].swap(position);
    }
    return ceiling_patches;
  }

  // Moves every followed original vertex to its tet's new index; returns the original
  // vertices per ceiling, in `followed_` order.
  std::vector<std::vector<uint32_t>> follow_vertices(uint32_t first, uint32_t regions, const std::vector<std::vector<uint32_t>>& new_index) {
    const uint32_t ceiling_base = out_.level_first.back();
    std::vector<std::vector<uint32_t>> ceiling_vertices(regions);
    for (uint32_t v : followed_) {
      const uint32_t n = located_node_[v];
      const uint32_t t = new_index[n - first][located_tet_[v]];
      located_tet_[v] = t;
      // the ceiling of tet t: the patch range that holds it
      uint32_t ceiling = 0;
      const auto [fp, fc] = floor_patches_[n - first];
      for (uint32_t p = fp; p < fp + fc; ++p) {
        const PatchRange& q = out_.patches[p];
        if (t >= q.begin && t < q.begin + q.count) {
          ceiling = q.ceiling - ceiling_base;
          break;
        }
      }
      ceiling_vertices[ceiling].push_back(v);
    }
    return ceiling_vertices;
  }

  // Vertices on the border between ceilings are locked.
  void lock_ceiling_borders(const std::vector<std::vector<CeilingPatch>>& ceiling_patches) {
    if (vertex_region_.size() < mesh_.table.size()) vertex_region_.resize(mesh_.table.size(), kNone);
    for (uint32_t k = 0; k < ceiling_patches.size(); ++k)
      for (const auto& [n, begin, count] : ceiling_patches[k])
        for (size_t i = 4 * size_t{begin}; i < 4 * (size_t{begin} + count); ++i) {
          uint32_t& vr = vertex_region_[out_.nodes[n].tets[i]];
          vr = vr == kNone || vr == k ? k : kMany;
        }
  }

  // The tets each ceiling is simplified to (0: the level ratio of its own tets). With
  // common_error, every ceiling is first simplified far with its collapse costs traced, and
  // the level's tets (level_ratio of `tets`) go where the costs are highest (level_targets.h).
  std::vector<uint64_t> ceiling_targets(const std::vector<std::vector<CeilingPatch>>& ceiling_patches, uint64_t tets, const CeilingShare& share) const {
    std::vector<uint64_t> targets(ceiling_patches.size(), 0);
    // the common error is that of QEM's collapse costs: the sampler's levels keep the ratio
    if (!options_.common_error || options_.simplifier == SimplifyMethod::kSample || ceiling_patches.size() < 2) return targets;
    std::vector<CeilingTrace> traces(ceiling_patches.size());
    parallel_for(share.mine.size(), options_.threads, [&](size_t i, unsigned) {
      const uint32_t k = share.mine[i];
      CeilingMesh c = gather_ceiling(ceiling_patches[k]);
      traces[k].tets = c.mesh.tet_count();
      // traced down to level_ratio² of its tets: a smooth ceiling may give up a whole level more
      SimplifyOptions so = ceiling_options(std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(options_.level_ratio * options_.level_ratio * double(traces[k].tets)))));
      so.trace_costs = true;
      traces[k].steps = simplify(c.mesh, so, c.locked).cost_trace;
    });
    if (shared()) share_traces(*options_.ranks, share.owner, traces);
    // every ceiling simplified at least to √level_ratio of its tets (halfway to the ratio, in
    // steps of the ladder), so that every node of the level is coarser than its children
    return common_error_targets(traces, static_cast<uint64_t>(std::llround(options_.level_ratio * double(tets))), std::sqrt(options_.level_ratio));
  }

  // Whether the level's ceilings are shared among the ranks of an MPI launch.
  bool shared() const { return options_.ranks && options_.ranks->size() > 1; }

  // Who simplifies which ceiling: all of them here when alone; else shared by their tets
  // (mt_share.cpp), the same on every rank.
  CeilingShare share_ceilings(const std::vector<std::vector<CeilingPatch>>& ceiling_patches) const {
    CeilingShare share;
    std::vector<uint64_t> work(ceiling_patches.size(), 0);
    for (size_t k = 0; k < ceiling_patches.size(); ++k)
      for (const CeilingPatch& p : ceiling_patches[k]) work[k] += p.count;
    share.owner = ceiling_owners(work, shared() ? static_cast<uint32_t>(options_.ranks->size()) : 1);
    const uint32_t me = shared() ? static_cast<uint32_t>(options_.ranks->rank()) : 0;
    for (uint32_t k = 0; k < share.owner.size(); ++k)
      if (share.owner[k] == me) share.mine.push_back(k);
    return share;
  }

  // A ceiling's patches gathered into a mesh of local ids, its border vertices marked locked.
  struct CeilingMesh {
    storage::TetMesh mesh;
    std::vector<uint8_t> locked;
    std::vector<uint32_t> global;  // per local vertex: global id
  };
  CeilingMesh gather_ceiling(const std::vector<CeilingPatch>& patches) const {
    const VertexTable& table = mesh_.table;
    const auto& attribute_info = mesh_.attributes;
    CeilingMesh out;
    std::vector<uint32_t>& global = out.global;
    for (const auto& [n, begin, count] : patches)
      global.insert(global.end(), out_.nodes[n].tets.begin() + 4 * size_t{begin}, out_.nodes[n].tets.begin() + 4 * (size_t{begin} + count));
    std::vector<uint32_t> tets_global = global;
    std::sort(global.begin(), global.end());
    global.erase(std::unique(global.begin(), global.end()), global.end());
    storage::TetMesh& m = out.mesh;
    const size_t nv = global.size();
    m.x.resize(nv);
    m.y.resize(nv);
    m.z.resize(nv);
    std::vector<uint8_t>& locked = out.locked;
    locked.assign(nv, 0);
    for (size_t l = 0; l < nv; ++l) {
      m.x[l] = table.xyz[3 * size_t{global[l]}];
      m.y[l] = table.xyz[3 * size_t{global[l]} + 1];
      m.z[l] = table.xyz[3 * size_t{global[l]} + 2];
      locked[l] = vertex_region_[global[l]] == kMany;
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
    return out;
  }

  SimplifyOptions ceiling_options(uint64_t target) const {
    SimplifyOptions so;
    so.target_tets = target;
    so.frame = mesh_.bounds;
    so.attribute_ranges = mesh_.ranges;
    so.threads = 1;
    so.seed = static_cast<uint32_t>(options_.seed);
    so.method = options_.simplifier;
    return so;
  }

  // One ceiling simplified with its border locked to `target` tets (0: level_ratio of its
  // tets), its error measured at the original vertices it covers. Runs on worker threads:
  // reads shared state only.
  CeilingResult simplify_ceiling(const std::vector<CeilingPatch>& patches, const std::vector<uint32_t>& original_vertices, uint64_t target) const {
    CeilingResult out;
    CeilingMesh gathered = gather_ceiling(patches);
    storage::TetMesh& m = gathered.mesh;
    const std::vector<uint8_t>& locked = gathered.locked;
    const std::vector<uint32_t>& global = gathered.global;
    const SimplifyOptions so = ceiling_options(target ? target : std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(options_.level_ratio * double(m.tet_count())))));
    const storage::TetMesh before = m;
    SimplifyReport sr = simplify(m, so, locked);
    // a vertex keeps its global id while its position and values are unchanged
    out.global.resize(m.vertex_count());
    for (size_t l = 0; l < m.vertex_count(); ++l) {
      const uint32_t src = sr.source_vertex[l];
      if (src == kNone) {  // a point the sampling simplifier added
        out.global[l] = kNone;
        continue;
      }
      bool same = m.x[l] == before.x[src] && m.y[l] == before.y[src] && m.z[l] == before.z[src];
      for (size_t a = 0; a < m.attributes.size() && same; ++a) {
        const uint32_t c = m.attributes[a].info.components;
        same = std::memcmp(&m.attributes[a].values[l * c], &before.attributes[a].values[size_t{src} * c], 4 * c) == 0;
      }
      out.global[l] = same ? global[src] : kNone;
    }
    out.error = measure_ceiling_error(m, original_vertices, mesh_, options_.histogram_bins);
    out.mesh = std::move(m);
    return out;
  }

  // The simplified ceilings become the nodes of `level`; new vertices get ids in ceiling
  // order (deterministic).
  void add_ceilings(uint32_t level, std::vector<CeilingResult>& results, const std::vector<std::vector<uint32_t>>& ceiling_vertices) {
    VertexTable& table = mesh_.table;
    const size_t values = channel_values();
    out_.field.resize(out_.field.size() + results.size() * values, 0.0f);
    out_.spatial.resize(out_.spatial.size() + results.size() * values, 0.0f);
    for (uint32_t k = 0; k < results.size(); ++k) {
      CeilingResult& res = results[k];
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
      node.level = level;
      node.tets.resize(m.tets.size());
      for (size_t i = 0; i < m.tets.size(); ++i) node.tets[i] = res.global[m.tets[i]];
      const uint32_t id = static_cast<uint32_t>(out_.nodes.size());
      out_.nodes.push_back(std::move(node));
      std::copy(res.error.field.begin(), res.error.field.end(), out_.field.begin() + size_t{id} * values);
      std::copy(res.error.spatial.begin(), res.error.spatial.end(), out_.spatial.begin() + size_t{id} * values);
      for (size_t i = 0; i < ceiling_vertices[k].size(); ++i) {
        located_node_[ceiling_vertices[k][i]] = id;
        located_tet_[ceiling_vertices[k][i]] = res.error.located_tet[i];
      }
      res = CeilingResult();
    }
  }

  // A level's share of simplify's time grows as its tets^0.8 (the coarser levels' small
  // ceilings cost more a tet; measured on bluntfin, oxygen post and disk: bench/job_progress.py),
  // so progress moves with the time spent instead of jumping after the first level.
  static double level_work(double tets) { return std::pow(std::max(1.0, tets), 0.8); }
  double simplify_fraction(double work) const { return work_total_ > 0 ? std::clamp(0.01 + 0.98 * work / work_total_, 0.01, 0.99) : 0.01; }

  IngestedMesh& mesh_;
  const PreprocessOptions& options_;
  const StageProgress& stage_;
  double work_total_ = 0, work_done_ = 0;  // simplify's work, predicted and done
  Hierarchy out_;
  std::vector<uint32_t> local_of_;                          // scratch of partition_level
  std::vector<uint32_t> located_node_, located_tet_;        // where every original vertex is: node, tet in it
  std::vector<uint32_t> followed_;                          // original vertices that lie in the mesh
  std::vector<uint32_t> vertex_region_;                     // ceiling of a vertex, kMany on a border
  std::vector<std::array<uint32_t, 2>> floor_patches_;      // per floor of the level: (first patch, count)
};

}  // namespace

Hierarchy build_levels(IngestedMesh& mesh, const PreprocessOptions& options, const StageProgress& stage) {
  return LevelBuilder(mesh, options, stage).run();
}

}  // namespace tetrascope::lod::mt
