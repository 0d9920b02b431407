// The stages of `tetrascope preprocess`, in the order mt_build.cpp runs them:
//   ingest_mesh         (mt_ingest.cpp)        mesh file -> vertex table, level-0 tets, channels
//   build_levels        (mt_levels.cpp)        level 0 partitioned as `tetrascope segment` does,
//                                              then coarser levels: partition, patches, simplify
//   measure_ceiling_error, dag_arcs            error histograms at the original vertices, made
//                       (mt_histograms.cpp)    monotone along the DAG's arcs
//   order_patches_depth_first (mt_tet_order.cpp) with --compress-segments cutborder only
//   write_mt_store      (mt_store_writer.cpp)  segments.bin, dag.bin and manifest.json
// Under MPI (ranks.h) every rank runs every stage but the last; the segments of a level are
// shared among them (mt_share.cpp), and rank 0 writes the store.
// Private to lod/.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/lod/cut/variants.h"

#include "tetrascope/lod/mt/level_targets.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/lod/mt/ranks.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/progress.h"

namespace tetrascope::lod::mt {

constexpr uint32_t kNone = 0xFFFFFFFFu;

// Every vertex the build knows: the input's, then the ones simplification moved.
struct VertexTable {
  std::vector<float> xyz;     // interleaved
  std::vector<float> values;  // vertex-major, `floats` per vertex
  uint32_t floats = 0;
  size_t size() const { return xyz.size() / 3; }
};

// Normalised value of every histogram channel (an attribute; vectors by magnitude): the
// input's range maps to [0, 1].
struct Channels {
  std::vector<uint32_t> offset, components;  // into a vertex's values
  std::vector<double> lo, scale;
  size_t size() const { return offset.size(); }
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

// Progress of the build: begin(name) at fraction 0, update(fraction) after.
// Reports (stage, fraction done): a stage named for the first time begins, even when its first
// report is past 0 (simplify's first is 0.01: it used to be counted as partition's, so a job
// sat at 10 % through the whole simplification). Called from one thread.
struct StageProgress {
  storage::Progress* progress = nullptr;
  mutable std::string current;
  void operator()(const char* name, double fraction) const {
    if (!progress) return;
    if (fraction == 0 || current != name) {
      current = name;
      progress->begin(name);
    }
    if (fraction > 0) progress->update(fraction);
  }
};

// ---- where the tets live ----

// The tets (4 vertex ids each) of every node the build makes, in memory, or for a level too
// large for the memory budget (spill_level) in a spill file with no name in `directory`
// (mt_node_tets.cpp). Reads of any nodes and writes of different nodes may run at once; add
// and append may not run beside anything.
class NodeTets {
 public:
  NodeTets() = default;
  explicit NodeTets(std::filesystem::path directory);
  NodeTets(NodeTets&& other) noexcept;
  NodeTets& operator=(NodeTets&& other) noexcept;
  NodeTets(const NodeTets&) = delete;
  NodeTets& operator=(const NodeTets&) = delete;
  ~NodeTets();

  uint32_t size() const { return static_cast<uint32_t>(nodes_.size()); }
  uint32_t level(uint32_t n) const { return nodes_[n].level; }
  uint64_t tet_count(uint32_t n) const { return nodes_[n].tets; }
  bool spilled(uint32_t n) const { return nodes_[n].spilled; }
  // The bytes the spill file reached.
  uint64_t spilled_bytes() const { return spilled_peak_; }

  // A new node of `tets` tets whose ids are then written; or of these ids.
  uint32_t add(uint32_t level, uint64_t tets, bool spill);
  uint32_t add(uint32_t level, std::vector<uint32_t> ids, bool spill);
  // More tets for the last node.
  void append(std::span<const uint32_t> ids);
  // Tets [begin, begin + count) of node n: a view of memory, or read into `buffer`.
  std::span<const uint32_t> read(uint32_t n, uint64_t begin, uint64_t count, std::vector<uint32_t>& buffer) const;
  std::span<const uint32_t> read(uint32_t n, std::vector<uint32_t>& buffer) const { return read(n, 0, tet_count(n), buffer); }
  // Overwrites the node's tets from tet `begin` on.
  void write(uint32_t n, uint64_t begin, std::span<const uint32_t> ids);

 private:
  struct Node {
    uint32_t level = 0;
    uint64_t tets = 0;
    bool spilled = false;
    uint64_t offset = 0;        // in the spill file
    std::vector<uint32_t> ids;  // in memory
  };
  void open_spill();
  std::vector<Node> nodes_;
  std::filesystem::path directory_;
  int fd_ = -1;
  uint64_t end_ = 0, spilled_peak_ = 0;
};

// Whether a level of `tets` tets is kept on disk: its ids would take more than a quarter of
// the memory budget (the build holds up to about four times a level's ids at once); never
// with a budget of 0.
inline bool spill_level(uint64_t tets, const PreprocessOptions& options) { return options.memory_mb > 0 && 16 * tets > (options.memory_mb << 20) / 4; }

// ---- ingest ----

struct IngestedMesh {
  VertexTable table;
  NodeTets tets;  // level 0 as read, node 0; input vertex ids
  std::filesystem::path spill_directory;  // where spilled levels go
  std::vector<storage::AttributeInfo> attributes;
  Channels channels;
  std::vector<std::array<double, 2>> ranges;  // for the simplifier: value range (scalars), [0, longest] (vectors)
  std::vector<std::vector<std::array<double, 2>>> component_ranges;  // per attribute, each component's range (vectors; none for scalars)
  storage::Bounds bounds;
  double diagonal = 1;
  storage::ReadStats read_stats;
  uint64_t dropped_unused_vertices = 0;  // points no tet uses (dropped, not stored)
  storage::FaceTags face_tags;           // the input's tagged boundary faces, over the table's ids
  uint32_t input_vertices = 0;
  uint64_t input_tets = 0;
  // per input vertex: a quarter of the volume of the input tets around it (the volume it
  // stands for in the error mass, mt_histograms.cpp)
  std::vector<float> vertex_volume;
  // How graded the mesh is: the 90th over the 10th percentile of its tets' size (the cube root
  // of their volume), from a histogram of log2 volume at eighth steps. 1 for a uniform mesh;
  // ONERA's far field 26, the oxygen post 27, the bracket 2 (auto_segment_tets and
  // auto_level_ratio, mt_build.h).
  double grading = 1;
};

// Reads the mesh: the vertices into the table, the tets as they come into `tets` (spilled
// under `spill_directory` when the file's cells exceed the memory budget). Throws
// storage::MeshError for a bad mesh, std::runtime_error for one without tets or with too many
// vertices for a store.
IngestedMesh ingest_mesh(const std::filesystem::path& mesh, const PreprocessOptions& options, const std::filesystem::path& spill_directory);

// ---- levels ----

// An arc of the DAG: tets [begin, begin + count) of segment `floor`, covered by `ceiling`.
struct PatchRange {
  uint32_t ceiling, floor, begin, count;
};

struct Hierarchy {
  // every level's segments, finest level first: global vertex ids; after the next level is
  // cut, grouped by patch
  NodeTets nodes;
  std::vector<uint32_t> level_first;      // nodes of level L: [level_first[L], level_first[L+1])
  std::vector<PatchRange> patches;        // between levels, in build order
  std::vector<float> field, spatial;      // per node: [channel][bin], not yet monotone
  std::vector<float> mass;                // per node: [channel][4][bin], as CeilingError::mass
  std::vector<uint32_t> level0_owner;     // the level-0 segment that owns each input vertex
  double partition_seconds = 0;           // of level 0
  uint32_t tetgen_fallbacks = 0;          // ceilings this rank simplified by collapses after TetGen failed
  uint32_t dependencies = 0;              // binary hierarchy: pairs of new segments merged over a simplified boundary
  std::unique_ptr<VariantSpill> variants;  // --variants: the segments' variants, null when none
  uint32_t level_count() const { return static_cast<uint32_t>(level_first.size() - 1); }
  uint64_t level_tets(uint32_t level) const {
    uint64_t sum = 0;
    for (uint32_t n = level_first[level]; n < level_first[level + 1]; ++n) sum += nodes.tet_count(n);
    return sum;
  }
};

// The error of a simplified ceiling at the original vertices it covers (mt_histograms.cpp).
struct CeilingError {
  std::vector<float> field, spatial;   // [channel][bin]
  // [channel][4][bin]: the error mass Σ err·volume over the original vertices of the bin
  // (volume in units of the diagonal cubed), then the centroid of that mass (x, y, z); as
  // dag.bin's histogram kinds 2-5
  std::vector<float> mass;
  std::vector<uint32_t> located_tet;   // per original vertex given: the ceiling's tet holding it
};

// What simplifying one ceiling segment produced.
struct CeilingResult {
  storage::TetMesh mesh;         // simplified, local vertex ids
  std::vector<uint32_t> global;  // per output vertex: kept global id, or kNone (new)
  CeilingError error;
  std::string tetgen_failure;    // --simplifier sample: TetGen failed, quadric collapses did it
  std::vector<VariantMesh> variants;  // --variants: fewest tets first
};

// Level 0 and every coarser level, until the base budget, one segment or max_levels. Grows
// mesh.table with the vertices simplification moves; consumes mesh.tets. Options are checked.
Hierarchy build_levels(IngestedMesh& mesh, const PreprocessOptions& options, const StageProgress& stage);

// ---- the binary segment hierarchy's pairs (binary_pairs.cpp, §6.2.1) ----

// Two segments of a level that share `faces` tet faces (a < b, level-local indices).
struct NodeEdge {
  uint32_t a, b;
  uint64_t faces;
};

// The face-adjacency graph of nodes [first, last): the faces each pair shares.
std::vector<NodeEdge> node_adjacency(const NodeTets& nodes, uint32_t first, uint32_t last);

// Greedy matching of `count` nodes over `edges` (heaviest `weight` first, ties to the smaller
// `size` sum, then the lower edge) among edges of weight at least `min_weight`. Returns each
// node's group (a matched pair, or a node alone); with `attach_single` a node left single
// joins the group of the neighbour it shares its heaviest edge with. *groups: their count.
std::vector<uint32_t> match_pairs(uint32_t count, std::span<const NodeEdge> edges, std::span<const double> weight, std::span<const uint64_t> size,
                                  double min_weight, bool attach_single, uint32_t* groups);

// How the floors of one binary level are merged: each floor into a pair (its new segment),
// and pairs whose boundary ratio R is at least `dependency_ratio` (none when negative) into one
// ceiling, the boundary between them simplified (a dependency). `copies`: the lowest level,
// every floor its own ceiling.
struct BinaryGrouping {
  std::vector<uint32_t> pair_of_floor, ceiling_of_pair;
  uint32_t pairs = 0, ceilings = 0, dependencies = 0;
};
BinaryGrouping binary_grouping(const NodeTets& nodes, uint32_t first, uint32_t last, bool copies, double dependency_ratio);

// ---- sharing a level among the ranks of an MPI launch (mt_share.cpp) ----

// The rank that works on each ceiling, given its work (its tets): the largest first, each to
// the rank with the least work so far, ties to the lower rank. Every rank computes the same.
std::vector<uint32_t> ceiling_owners(std::span<const uint64_t> work, uint32_t ranks);

// After each rank has filled results[k] for the ceilings it owns, every rank holds them all.
// `attributes` are the mesh's (the results' attribute values travel without their names).
// Collective: every rank calls it with the same `owner`.
void share_results(Ranks& ranks, std::span<const uint32_t> owner, std::vector<CeilingResult>& results, const std::vector<storage::AttributeInfo>& attributes);

// The same for the cost traces of the common-error targets (level_targets.h).
void share_traces(Ranks& ranks, std::span<const uint32_t> owner, std::vector<CeilingTrace>& traces);

// ---- histograms ----

// The field and spatial error of a simplified ceiling segment (local vertex ids) at the
// original vertices it covers, binned by their normalised value.
CeilingError measure_ceiling_error(const storage::TetMesh& ceiling, std::span<const uint32_t> original_vertices, const IngestedMesh& mesh,
                                   uint32_t bins);

// The DAG's arcs: the coarsest segments hung from the root, then the patches grouped by
// ceiling. Empties hierarchy.patches and makes the histograms monotone along the arcs (a
// segment's error at least its children's).
std::vector<PatchRange> dag_arcs(Hierarchy& hierarchy, uint32_t values_per_node);

// ---- store ----

// Reorders the tets of `ranges` (patches of one node, as (begin, count)) depth first over their
// shared faces, for the cut-border coding of segments.bin (mt_tet_order.cpp); the ranges stay
// valid.
struct OrderScratch;
class PatchOrderer {
 public:
  PatchOrderer();
  ~PatchOrderer();
  void order(std::vector<uint32_t>& tets, std::span<const std::pair<uint32_t, uint32_t>> ranges);
 private:
  std::unique_ptr<OrderScratch> scratch_;
};

struct StoreInput {
  const IngestedMesh& mesh;
  Hierarchy& hierarchy;  // with --compress-segments cutborder, each patch's tets reordered for it
  std::span<const PatchRange> arcs;
  const PreprocessOptions& options;
  std::filesystem::path mesh_path, store_path;
  std::function<std::string()> source_sha256;  // waited for only when the manifest is written
  const VertexHierarchy* vertices = nullptr;   // written as vertices.bin when set
};

struct StoreOutput {
  uint64_t store_bytes = 0, dag_bytes = 0, variants_bytes = 0, vertices_bytes = 0, boundary_tags_bytes = 0;
  std::vector<LevelReport> levels;
};

// Writes the store atomically (NAME.tmp/ renamed to NAME/ when complete).
StoreOutput write_mt_store(const StoreInput& input, const StageProgress& stage);

}  // namespace tetrascope::lod::mt
