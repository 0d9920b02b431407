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
#include <cstdio>
#include <cstring>
#include <mutex>
#include <numeric>

#include "mt_stages.h"
#include "tetrascope/lod/mt/level_targets.h"
#include "tetrascope/lod/mt/octree_partition.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/core/parallel_for.h"
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

// Calls fn(ids) for node n's tets, a chunk at a time (all at once when in memory).
template <class Fn>
void for_each_chunk(const NodeTets& nodes, uint32_t n, std::vector<uint32_t>& buffer, Fn&& fn) {
  constexpr uint64_t kChunk = 1 << 16;
  const uint64_t count = nodes.tet_count(n);
  const uint64_t step = nodes.spilled(n) ? kChunk : std::max<uint64_t>(count, 1);
  for (uint64_t begin = 0; begin < count; begin += step) fn(nodes.read(n, begin, std::min(step, count - begin), buffer));
}

// The regions of one level: partition_segments over the vertices its tets use; a tet goes to
// the lowest region among its vertices, and regions left without tets are dropped.
struct LevelPartition {
  std::vector<uint32_t> segment_of;  // per global vertex the level uses: partition segment
  std::vector<uint32_t> compact;     // partition segment -> region
  uint32_t regions = 0;
  std::vector<uint64_t> tets;        // per region
  std::vector<uint32_t> floor_region;  // binary hierarchy: per floor of the level, its region (whole floors, no vertex partition)
  uint32_t region(const uint32_t* tet) const {
    uint32_t r = kNone;
    for (int k = 0; k < 4; ++k) r = std::min(r, segment_of[tet[k]]);
    return compact[r];
  }
};

// Partitions the vertices of nodes [first, last) into about `parts` regions.
LevelPartition partition_level(const NodeTets& nodes, uint32_t first, uint32_t last, const VertexTable& table, uint32_t parts, bool rotate, int seed) {
  // two passes over the level's tets (each a read of the spill file when spilled)
  std::vector<uint32_t> buffer;
  LevelPartition out;
  // 1: the tets of every vertex, which also tells the vertices used (ascending)
  std::vector<uint32_t>& uses = out.segment_of;  // the segments overwrite the counts
  uses.assign(table.size(), 0);
  for (uint32_t n = first; n < last; ++n)
    for_each_chunk(nodes, n, buffer, [&](std::span<const uint32_t> ids) {
      for (uint32_t g : ids) ++uses[g];
    });
  std::vector<uint32_t> used;
  for (uint32_t g = 0; g < uses.size(); ++g)
    if (uses[g] > 0) used.push_back(g);
  std::vector<float> xyz(3 * used.size()), tets_per_vertex(used.size());
  for (size_t i = 0; i < used.size(); ++i) {
    for (int k = 0; k < 3; ++k) xyz[3 * i + size_t(k)] = table.xyz[3 * size_t{used[i]} + size_t(k)];
    tets_per_vertex[i] = 0.25f * float(uses[used[i]]);  // each vertex weighs a quarter of its tets
  }
  if (rotate && !used.empty()) rotate_45(xyz);
  const SegmentPartition partition = partition_segments(xyz, parts, 0, seed, tets_per_vertex);
  for (size_t i = 0; i < used.size(); ++i) out.segment_of[used[i]] = partition.segment_of_vertex[i];
  // 2: the tets of every partition segment; one may end up without tets (all its vertices'
  // tets went to lower segments): the regions are the others, renumbered
  out.compact.resize(partition.segments);
  std::iota(out.compact.begin(), out.compact.end(), 0u);
  std::vector<uint64_t> tets(partition.segments, 0);
  for (uint32_t n = first; n < last; ++n)
    for_each_chunk(nodes, n, buffer, [&](std::span<const uint32_t> ids) {
      for (size_t t = 0; t < ids.size() / 4; ++t) ++tets[out.region(&ids[4 * t])];
    });
  for (size_t r = 0; r < tets.size(); ++r) {
    out.compact[r] = tets[r] ? static_cast<uint32_t>(out.tets.size()) : kNone;
    if (tets[r]) out.tets.push_back(tets[r]);
  }
  out.regions = static_cast<uint32_t>(out.tets.size());
  return out;
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
      if (level > 0 && double(tets) > 0.9 * double(out_.level_tets(level - 1)) && !binary_merges(level)) break;  // locked borders stop the simplification
      build_level(level, tets);
      out_.level_first.push_back(static_cast<uint32_t>(out_.nodes.size()));
    }
    if (out_.nodes.size() > storage::store::kMaxSegments) throw std::runtime_error("too many segments");
    return std::move(out_);
  }

 private:
  // The binary hierarchy goes on while a level has segments left to merge, even where its
  // locked borders kept a level from simplifying much (its copies at level 1 most of all).
  bool binary_merges(uint32_t level) const {
    if (options_.model != MultiresModel::kBinary) return false;
    const uint32_t segments = out_.level_first[level + 1] - out_.level_first[level];
    return segments > 1 && (level < 2 || segments < out_.level_first[level] - out_.level_first[level - 1]);
  }

  // Level `level` + 1 of the binary hierarchy (§6.2.1): whole floors merged a pair at a time
  // (level 1: each floor copied alone), pairs matched by their boundary ratio merged further.
  LevelPartition binary_level(uint32_t level) {
    const uint32_t first = out_.level_first[level], last = out_.level_first[level + 1];
    const BinaryGrouping grouping = binary_grouping(out_.nodes, first, last, level == 0, options_.dependency_ratio);
    out_.dependencies += grouping.dependencies;
    LevelPartition out;
    out.regions = grouping.ceilings;
    out.tets.assign(grouping.ceilings, 0);
    out.floor_region.resize(last - first);
    for (uint32_t n = 0; n < last - first; ++n) {
      out.floor_region[n] = grouping.ceiling_of_pair[grouping.pair_of_floor[n]];
      out.tets[out.floor_region[n]] += out_.nodes.tet_count(first + n);
    }
    return out;
  }

  uint32_t channel_values() const { return static_cast<uint32_t>(mesh_.channels.size()) * options_.histogram_bins; }

  // Level 0: the input mesh, partitioned as `tetrascope segment` partitions it, its tets
  // streamed from the input's node into one node per region (input order kept in each).
  void partition_level0() {
    const uint32_t n0 = mesh_.input_vertices;
    located_node_.assign(n0, kNone);
    located_tet_.assign(n0, kNone);
    vertex_region_.assign(n0, kNone);
    const NodeTets& input = mesh_.tets;
    const uint64_t input_tets = input.tet_count(0);
    const uint64_t parts = std::max<uint64_t>(1, (input_tets + options_.segment_tets / 2) / options_.segment_tets);
    const LevelPartition partition =
        partition_level(input, 0, 1, mesh_.table, static_cast<uint32_t>(std::min<uint64_t>(parts, storage::store::kMaxSegments)), false, options_.seed);
    const uint32_t count = partition.regions;
    std::vector<uint32_t> buffer;
    out_.nodes = NodeTets(mesh_.spill_directory);
    const bool spill = spill_level(input_tets, options_);
    for (uint32_t r = 0; r < count; ++r) out_.nodes.add(0, partition.tets[r], spill);
    // every node filled through a small buffer (4 KB a node)
    constexpr size_t kBuffered = 256;
    std::vector<std::vector<uint32_t>> pending(count);
    std::vector<uint64_t> filled(count, 0), written(count, 0);
    auto flush = [&](uint32_t r) {
      out_.nodes.write(r, written[r], pending[r]);
      written[r] += pending[r].size() / 4;
      pending[r].clear();
    };
    for_each_chunk(input, 0, buffer, [&](std::span<const uint32_t> ids) {
      for (size_t t = 0; t < ids.size() / 4; ++t) {
        const uint32_t r = partition.region(&ids[4 * t]);
        for (size_t k = 0; k < 4; ++k) {
          const uint32_t g = ids[4 * t + k];
          if (located_node_[g] == kNone) {
            located_node_[g] = r;
            located_tet_[g] = static_cast<uint32_t>(filled[r]);
          }
        }
        pending[r].insert(pending[r].end(), ids.begin() + static_cast<std::ptrdiff_t>(4 * t), ids.begin() + static_cast<std::ptrdiff_t>(4 * t + 4));
        ++filled[r];
        if (pending[r].size() >= 4 * kBuffered) flush(r);
      }
    });
    for (uint32_t r = 0; r < count; ++r) {
      flush(r);
      std::vector<uint32_t>().swap(pending[r]);
    }
    mesh_.tets = NodeTets();  // the input's copy (and its spill file) goes
    // owners: the segment of the vertex's first tet; unused vertices go to segment 0
    out_.level0_owner = located_node_;
    for (uint32_t& o : out_.level0_owner)
      if (o == kNone) o = 0;
    out_.field.assign(size_t{count} * channel_values(), 0.0f);
    out_.spatial.assign(size_t{count} * channel_values(), 0.0f);
    out_.mass.assign(size_t{count} * channel_values() * 4, 0.0f);
    // original vertices that lie in the mesh (isolated ones are not followed)
    for (uint32_t v = 0; v < n0; ++v)
      if (located_node_[v] != kNone) followed_.push_back(v);
  }

  // Level `level` + 1 from the mesh of `level` (`tets` tets).
  void build_level(uint32_t level, uint64_t tets) {
    const uint32_t first = out_.level_first[level], last = out_.level_first[level + 1];
    // partition M(level) into the ceiling segments of level + 1: of about segment_tets once
    // simplified, the mesh turned on odd levels (§6.3.2)
    const double simplified = double(tets) * options_.level_ratio;
    const uint64_t parts = std::max<uint64_t>({1, static_cast<uint64_t>(std::llround(simplified / options_.segment_tets)),
                                               std::min<uint64_t>(options_.min_segments, static_cast<uint64_t>(simplified / std::max(1u, options_.min_segment_tets)))});
    const LevelPartition partition = options_.model == MultiresModel::kBinary
        ? binary_level(level)
        : partition_level(out_.nodes, first, last, mesh_.table, static_cast<uint32_t>(parts), level % 2 == 1, options_.seed + static_cast<int>(level) + 1);
    const uint32_t regions = partition.regions;
    std::vector<std::vector<uint32_t>> ceiling_vertices(regions);
    const std::vector<std::vector<CeilingPatch>> ceiling_patches = cut_into_patches(first, last, partition, ceiling_vertices);
    const CeilingShare share = share_ceilings(ceiling_patches);
    const double work_before = work_done_, work = level_work(double(tets));
    // with common-error targets the traces take about half the level's time
    const double traced = traces_costs(ceiling_patches.size()) ? 0.5 : 0.0;
    std::mutex reporting;
    auto report = [&](double fraction) {
      std::unique_lock lock(reporting, std::try_to_lock);  // reported by one worker at a time
      if (lock) stage_("simplify", simplify_fraction(work_before + work * fraction));
    };
    double cap = 0;
    const std::vector<uint64_t> targets = ceiling_targets(ceiling_patches, tets, share, &cap, [&](double f) { report(traced * f); });
    std::vector<CeilingResult> results(regions);
    const size_t mine = share.mine.size();
    std::atomic<uint32_t> simplified_ceilings{0};
    parallel_for(mine, options_.threads, [&](size_t i, unsigned) {
      const uint32_t k = share.mine[i];
      results[k] = simplify_ceiling(ceiling_patches[k], ceiling_vertices[k], targets[k], cap);
      report(traced + (1 - traced) * ++simplified_ceilings / double(mine));
    });
    for (size_t i = 0; i < mine; ++i) {
      const std::string& failure = results[share.mine[i]].tetgen_failure;
      if (failure.empty()) continue;
      ++out_.tetgen_fallbacks;
      std::fprintf(stderr, "tetrascope preprocess: level %u, segment %zu of %zu: %s: simplified by quadric collapses instead\n", level + 1,
                   static_cast<size_t>(share.mine[i]) + 1, results.size(), failure.c_str());
    }
    if (shared()) share_results(*options_.ranks, share.owner, results, mesh_.attributes);
    work_done_ = work_before + work;
    add_ceilings(level + 1, results, ceiling_vertices);
    std::fill(vertex_region_.begin(), vertex_region_.end(), kNone);  // reset the border marks
  }

  // Groups every floor segment's tets by ceiling, one floor at a time (the patches, appended
  // to out_.patches), and returns each ceiling's patches. On the way every followed original
  // vertex moves to its tet's new index and is listed under that tet's ceiling
  // (`ceiling_vertices`, ascending), and the vertices on a border between ceilings are marked
  // locked (vertex_region_).
  std::vector<std::vector<CeilingPatch>> cut_into_patches(uint32_t first, uint32_t last, const LevelPartition& partition,
                                                          std::vector<std::vector<uint32_t>>& ceiling_vertices) {
    const uint32_t ceiling_base = last;
    std::vector<std::vector<CeilingPatch>> ceiling_patches(partition.regions);
    if (vertex_region_.size() < mesh_.table.size()) vertex_region_.resize(mesh_.table.size(), kNone);
    std::vector<std::vector<uint32_t>> followed_in(last - first);  // per floor, ascending
    for (uint32_t v : followed_) followed_in[located_node_[v] - first].push_back(v);
    std::vector<uint32_t> buffer, sorted, order, position, region, sorted_region;
    for (uint32_t n = first; n < last; ++n) {
      const std::span<const uint32_t> ids = out_.nodes.read(n, buffer);
      const uint32_t count = static_cast<uint32_t>(ids.size() / 4);
      region.resize(count);
      for (uint32_t t = 0; t < count; ++t) region[t] = partition.floor_region.empty() ? partition.region(&ids[4 * size_t{t}]) : partition.floor_region[n - first];
      order.resize(count);
      std::iota(order.begin(), order.end(), 0u);
      std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return region[a] < region[b]; });
      sorted.resize(ids.size());
      position.resize(count);
      sorted_region.resize(count);
      for (uint32_t i = 0; i < count; ++i) {
        std::copy_n(ids.begin() + 4 * std::ptrdiff_t{order[i]}, 4, sorted.begin() + 4 * std::ptrdiff_t{i});
        position[order[i]] = i;
        sorted_region[i] = region[order[i]];
      }
      out_.nodes.write(n, 0, sorted);
      for (uint32_t i = 0; i < count;) {
        uint32_t j = i;
        while (j < count && sorted_region[j] == sorted_region[i]) ++j;
        ceiling_patches[sorted_region[i]].push_back({n, i, j - i});
        out_.patches.push_back({ceiling_base + sorted_region[i], n, i, j - i});
        i = j;
      }
      for (uint32_t v : followed_in[n - first]) {
        located_tet_[v] = position[located_tet_[v]];
        ceiling_vertices[sorted_region[located_tet_[v]]].push_back(v);
      }
      std::vector<uint32_t>().swap(followed_in[n - first]);
      for (uint32_t i = 0; i < count; ++i)
        for (size_t k = 0; k < 4; ++k) {
          uint32_t& vr = vertex_region_[sorted[4 * size_t{i} + k]];
          vr = vr == kNone || vr == sorted_region[i] ? sorted_region[i] : kMany;
        }
    }
    for (auto& list : ceiling_vertices) std::sort(list.begin(), list.end());
    return ceiling_patches;
  }

  // The tets each ceiling is simplified to (0: the level ratio of its own tets), and in *cap
  // the largest collapse cost a ceiling may take (0: none). With common_error, every ceiling is
  // first simplified far with its collapse costs traced, and the level's tets (level_ratio of
  // `tets`) go where the costs are highest (level_targets.h). The traces leave the border
  // free, as a whole-level decimation would: their common error is what the level would cost
  // without locked borders, and it caps the real (locked) runs. Without the cap a ceiling made
  // up for its locked border tets with collapses costing 15-1200 times more, eating the
  // domain (the oxygen post's disc became a polygon with a wedge cut out at level 2); with it
  // a level keeps its border tets and holds more than level_ratio of the one below.
  // `progress(f)` is told the share f of this rank's traces done, from the workers.
  template <class Progress>
  std::vector<uint64_t> ceiling_targets(const std::vector<std::vector<CeilingPatch>>& ceiling_patches, uint64_t tets, const CeilingShare& share, double* cap,
                                        Progress&& progress) const {
    std::vector<uint64_t> targets(ceiling_patches.size(), 0);
    *cap = 0;
    if (!traces_costs(ceiling_patches.size())) return targets;
    std::vector<CeilingTrace> traces(ceiling_patches.size());
    std::atomic<uint32_t> traced{0};
    parallel_for(share.mine.size(), options_.threads, [&](size_t i, unsigned) {
      const uint32_t k = share.mine[i];
      CeilingMesh c = gather_ceiling(ceiling_patches[k]);
      traces[k].tets = c.mesh.tet_count();
      // traced down to level_ratio² of its tets: a smooth ceiling may give up a whole level more
      SimplifyOptions so = ceiling_options(std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(options_.level_ratio * options_.level_ratio * double(traces[k].tets)))));
      so.trace_costs = true;
      traces[k].goal = so.target_tets;
      traces[k].steps = simplify(c.mesh, so).cost_trace;  // the border free
      progress(++traced / double(share.mine.size()));
    });
    if (shared()) share_traces(*options_.ranks, share.owner, traces);
    // no share is forced on any ceiling (max_ratio 1): the cap decides where a locked one stops
    return common_error_targets(traces, static_cast<uint64_t>(std::llround(options_.level_ratio * double(tets))), 1.0, cap);
  }

  // Whether a level of `ceilings` ceilings gets common-error targets: the common error is that
  // of QEM's collapse costs, so the sampler's levels keep the ratio.
  bool traces_costs(size_t ceilings) const { return options_.common_error && options_.simplifier != SimplifyMethod::kSample && ceilings >= 2; }

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
    std::vector<uint32_t> buffer;
    for (const auto& [n, begin, count] : patches) {
      const std::span<const uint32_t> ids = out_.nodes.read(n, begin, count, buffer);
      global.insert(global.end(), ids.begin(), ids.end());
    }
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

  // Per vertex of `simplified`: the global id of the `before` vertex it continues (source),
  // while its position and values are bit-identical to that vertex's; kNone for one moved,
  // changed or added (by the sampling simplifier).
  static std::vector<uint32_t> kept_global_ids(const storage::TetMesh& simplified, const storage::TetMesh& before, const std::vector<uint32_t>& source,
                                               const std::vector<uint32_t>& global) {
    std::vector<uint32_t> out(simplified.vertex_count(), kNone);
    for (size_t l = 0; l < out.size(); ++l) {
      const uint32_t src = source[l];
      if (src == kNone) continue;
      bool same = simplified.x[l] == before.x[src] && simplified.y[l] == before.y[src] && simplified.z[l] == before.z[src];
      for (size_t a = 0; a < simplified.attributes.size() && same; ++a) {
        const uint32_t c = simplified.attributes[a].info.components;
        same = std::memcmp(&simplified.attributes[a].values[l * c], &before.attributes[a].values[size_t{src} * c], 4 * c) == 0;
      }
      if (same) out[l] = global[src];
    }
    return out;
  }

  // One ceiling simplified with its border locked to `target` tets (0: level_ratio of its
  // tets), or until a collapse would cost more than `cap` (0: no cap), its error measured at
  // the original vertices it covers. Runs on worker threads:
  // reads shared state only.
  CeilingResult simplify_ceiling(const std::vector<CeilingPatch>& patches, const std::vector<uint32_t>& original_vertices, uint64_t target, double cap) const {
    CeilingResult out;
    CeilingMesh gathered = gather_ceiling(patches);
    storage::TetMesh& m = gathered.mesh;
    const std::vector<uint8_t>& locked = gathered.locked;
    const std::vector<uint32_t>& global = gathered.global;
    SimplifyOptions so = ceiling_options(target ? target : std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(options_.level_ratio * double(m.tet_count())))));
    so.max_error = cap;
    const storage::TetMesh before = m;
    SimplifyReport sr = simplify(m, so, locked);
    if (m.tet_count() == 0 && before.tet_count() > 0) {
      // copies of one tet (a duplicated cell in the input) go together in one collapse: the
      // ceiling is kept as it was rather than left with no tets
      m = before;
      so = ceiling_options(before.tet_count());
      sr = simplify(m, so, locked);
    }
    out.global = kept_global_ids(m, before, sr.source_vertex, global);
    out.tetgen_failure = sr.tetgen_failure;
    out.variants = ceiling_variants(before, locked, global, m.tet_count(), cap);
    out.error = measure_ceiling_error(m, original_vertices, mesh_, options_.histogram_bins);
    out.mesh = std::move(m);
    return out;
  }

  // The tets of the options_.variants = K versions of a ceiling between its fine mesh (F tets)
  // and its simplified one (c tets): F^(1-j/(K+1)) c^(j/(K+1)), j = K..1 (fewest first). None
  // where F < 1.2 c.
  std::vector<uint64_t> variant_targets(uint64_t fine, uint64_t coarse) const {
    std::vector<uint64_t> out;
    const int count = static_cast<int>(options_.variants);
    const double f_tets = double(fine), c_tets = double(std::max<uint64_t>(1, coarse));
    if (count <= 0 || f_tets < 1.2 * c_tets) return out;
    for (int j = count; j >= 1; --j) {
      const double f = double(j) / (count + 1);
      out.push_back(static_cast<uint64_t>(std::llround(std::pow(f_tets, 1 - f) * std::pow(c_tets, f))));
    }
    return out;
  }

  // The K versions (variant_targets) of the ceiling, each as a run from the fine mesh with the
  // same border locked, the same cap and that target would leave it (variants.h): one run to
  // the fewest, with snapshots at the others (the simplifier is deterministic, and a run to
  // more tets is a run to fewer stopped earlier). Fewest tets first. One that comes out above
  // 97% of F, or under 105% of c or of the next smaller one, is left out. The ceiling's own
  // run cannot give them: its count c, which sets the targets, is known only at its end (most
  // ceilings stop at the level's common error, short of their target).
  std::vector<VariantMesh> ceiling_variants(const storage::TetMesh& fine, const std::vector<uint8_t>& locked, const std::vector<uint32_t>& global, uint64_t coarse,
                                            double cap) const {
    std::vector<VariantMesh> out;
    const std::vector<uint64_t> targets = variant_targets(fine.tet_count(), coarse);
    if (targets.empty()) return out;
    const double f_tets = double(fine.tet_count()), c_tets = double(std::max<uint64_t>(1, coarse));
    storage::TetMesh run = fine;
    SimplifyOptions so = ceiling_options(*std::min_element(targets.begin(), targets.end()));
    so.max_error = cap;
    so.snapshot_tets = targets;
    SimplifyReport sr = simplify(run, so, locked);
    run = storage::TetMesh{};  // the first snapshot (fewest tets) holds it too
    std::vector<SimplifySnapshot>& meshes = sr.snapshots;
    for (size_t k = 0; k < targets.size(); ++k) {
      const storage::TetMesh m = std::move(meshes[k].mesh);  // each snapshot given back as its variant is made
      const double t = double(m.tet_count());
      if (t > 0.97 * f_tets || t < 1.05 * c_tets || (!out.empty() && t < 1.05 * double(out.back().tet_count()))) continue;
      VariantMesh v;
      const size_t nv = m.vertex_count();
      v.xyz.resize(3 * nv);
      v.global = kept_global_ids(m, fine, meshes[k].source_vertex, global);
      for (size_t l = 0; l < nv; ++l) {
        v.xyz[3 * l] = m.x[l];
        v.xyz[3 * l + 1] = m.y[l];
        v.xyz[3 * l + 2] = m.z[l];
        for (const auto& a : m.attributes)
          for (uint32_t c = 0; c < a.info.components; ++c) v.values.push_back(a.values[l * a.info.components + c]);
      }
      v.tets = m.tets;
      const std::pair<uint32_t, uint32_t> all{0, static_cast<uint32_t>(m.tet_count())};
      PatchOrderer().order(v.tets, {&all, 1});  // depth first, for the connectivity coding
      out.push_back(std::move(v));
    }
    // fewest tets first
    std::sort(out.begin(), out.end(), [](const VariantMesh& a, const VariantMesh& b) { return a.tet_count() < b.tet_count(); });
    return out;
  }

  // The simplified ceilings become the nodes of `level`; new vertices get ids in ceiling
  // order (deterministic).
  void add_ceilings(uint32_t level, std::vector<CeilingResult>& results, const std::vector<std::vector<uint32_t>>& ceiling_vertices) {
    VertexTable& table = mesh_.table;
    const size_t values = channel_values();
    uint64_t level_tets = 0;
    for (const CeilingResult& res : results) level_tets += res.mesh.tet_count();
    const bool spill = spill_level(level_tets, options_);
    out_.field.resize(out_.field.size() + results.size() * values, 0.0f);
    out_.spatial.resize(out_.spatial.size() + results.size() * values, 0.0f);
    out_.mass.resize(out_.mass.size() + results.size() * values * 4, 0.0f);
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
      std::vector<uint32_t> tets(m.tets.size());
      for (size_t i = 0; i < m.tets.size(); ++i) tets[i] = res.global[m.tets[i]];
      const uint32_t id = out_.nodes.add(level, std::move(tets), spill);
      if (!res.variants.empty() && (!shared() || options_.ranks->rank() == 0)) {  // under MPI rank 0 alone writes the store
        if (!out_.variants) out_.variants = std::make_unique<VariantSpill>(mesh_.spill_directory, table.floats);
        out_.variants->add(id, res.variants);
      }
      std::copy(res.error.field.begin(), res.error.field.end(), out_.field.begin() + size_t{id} * values);
      std::copy(res.error.spatial.begin(), res.error.spatial.end(), out_.spatial.begin() + size_t{id} * values);
      std::copy(res.error.mass.begin(), res.error.mass.end(), out_.mass.begin() + size_t{id} * values * 4);
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
  std::vector<uint32_t> located_node_, located_tet_;        // where every original vertex is: node, tet in it
  std::vector<uint32_t> followed_;                          // original vertices that lie in the mesh
  std::vector<uint32_t> vertex_region_;                     // ceiling of a vertex, kMany on a border
};

}  // namespace

Hierarchy build_levels(IngestedMesh& mesh, const PreprocessOptions& options, const StageProgress& stage) {
  return LevelBuilder(mesh, options, stage).run();
}

}  // namespace tetrascope::lod::mt
