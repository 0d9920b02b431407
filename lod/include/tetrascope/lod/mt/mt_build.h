// The offline build of the multi-triangulation of dissertation §6.3: `tetrascope preprocess`
// turns a mesh file into a store (segments.bin holds every level's segments, dag.bin the DAG
// and the error histograms). The runtime side, reading the DAG back, is dag.h.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/mt/ranks.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/progress.h"
#include "tetrascope/storage/store_format.h"

namespace tetrascope::lod {

// The multiresolution model a store holds: the multi-triangulation of §6.3 (segments of a level
// cut into patches by the next level's partition), or the binary segment hierarchy of §6.2
// (every segment copied and simplified with its border locked, then merged a pair at a time).
// Both are written as dag.bin, so the cut, the renderer and the server take either.
enum class MultiresModel { kMultiTriangulation, kBinary };
const char* model_name(MultiresModel model);

struct PreprocessOptions {
  MultiresModel model = MultiresModel::kMultiTriangulation;
  // The binary hierarchy only: two new segments whose boundary ratio R = |B| / min(|S1|, |S2|)
  // (faces between them over the smaller one's tets, §6.2.1) is at least this are matched, and
  // the boundary between them is simplified with them (they are refined together from then
  // on). 0 (the default): every matched pair, as §6.2.1 places them without a threshold (on
  // the oxygen post higher than 1, which matched no pair, in 6 of 10 fidelity cells, with 16%
  // fewer stored tets). Negative: boundaries between new segments stay locked.
  double dependency_ratio = 0.0;
  // Target tets a segment, at every level; 0 (the default): chosen from the input's grading,
  // auto_segment_tets().
  uint32_t segment_tets = 0;
  // stop when a level has at most this many tets (or simplification stalls): small enough for
  // an interaction budget on every store
  uint64_t base_tets = 10000;
  // Each level holds about this share of the tets of the one below; 0 (the default): chosen
  // from the input's grading, auto_level_ratio().
  double level_ratio = 0;
  // true: the segments of a level are simplified to one error threshold (the level's tets go
  // where the field varies, level_targets.h); false: each segment to level_ratio of its tets
  bool common_error = true;
  // A coarse level keeps at least this many segments (of at least min_segment_tets each once
  // simplified), so that the cut can refine the top of the DAG a little at a time rather than
  // a whole level at once. Every border between them stays at the finer level's resolution, and
  // small segments are mostly border: with 8 the 1M blade's coarsest level lost the blade
  // (24 dB against a decimation's 43), with 2 it is within 0.6 dB.
  uint32_t min_segments = 2;
  uint32_t min_segment_tets = 1024;
  // Finer versions of every segment above level 0 that keep its border (variants.h): the cut
  // shows one where the budget has room left but not for a refinement. 0: none.
  uint32_t variants = 0;
  uint32_t histogram_bins = 256;  // N
  uint32_t threads = 2;           // segments simplified at once
  uint32_t max_levels = 24;
  int seed = 1;
  // how each segment is simplified: quadric collapses, or the sampling simplifier of §4.2 (the
  // segment's locked border faces kept exactly, only its free interior and border resampled)
  SimplifyMethod simplifier = SimplifyMethod::kQem;
  bool replace = false;
  // how segments.bin keeps each segment's tets (store_format.h, segment_codec.h): the
  // cut-border stream by default, measured at under half the store and a cheaper segment swap
  // (bench/results/segment_compression.json)
  storage::store::Compression compression = storage::store::Compression::kCutBorder;
  storage::ReadLimits read_limits;  // what one input may cost (--max-inflate-ratio)
  // The memory the build aims to stay within (--memory-mb), beyond its per-vertex arrays: a
  // level whose tets would take more than a quarter of it, the input's first of all, is kept in
  // a spill file beside the store and read a segment at a time. 0: nothing spilled.
  uint64_t memory_mb = 2048;
  // The ranks of an MPI launch that share the build (launched_ranks(), ranks.h); null: this
  // process alone. Every rank calls preprocess with the same options; each simplifies its
  // share of every level's segments, and rank 0 alone writes the store, the same bytes as a
  // build on one rank.
  Ranks* ranks = nullptr;
  // The binary vertex hierarchy of §5.2.1 (vertices.bin, lod/vertex/): the cut then refines by
  // single vertex splits. Built in memory from the whole mesh, so only for inputs of at most
  // this many tets whose build fits memory_mb (about 256 bytes a tet); 0: never.
  uint64_t vertex_hierarchy_max_tets = 8000000;
  bool vertex_hierarchy_independent = false;  // independent edges (§5.2.1): shallower, but its collapses out of cost order
};

// The segment size --segment-tets auto picks for a mesh of this grading (the 90th over the 10th
// percentile of its tets' size). Measured on the fidelity cases
// (bench/results/fidelity.json, tag seg8k): on the graded CFD meshes (ONERA's far field, grading
// 26, the oxygen post 27) segments of 8192 tets gave the cut more and better places to refine,
// higher PSNR than 16384 in 19 of their 25 cells; on the nearly uniform blades (grading 1.4-2.7)
// lower in 14 of 20, so they keep 16384 (bench/results/segment_auto.json: the gradings).
constexpr double kGradedMesh = 8;
inline bool graded_mesh(double grading) { return grading >= kGradedMesh; }
constexpr uint32_t kGradedSegmentTets = 8192, kUniformSegmentTets = 16384;
inline uint32_t auto_segment_tets(double grading) { return graded_mesh(grading) ? kGradedSegmentTets : kUniformSegmentTets; }

// The level ratio --level-ratio auto picks. On a nearly uniform mesh every part of the view
// needs about the same detail, so a cut between two levels 4:1 apart leaves half the picture at
// a quarter of the detail where a uniform decimation spreads it evenly: with a level every 2:1
// the 1M blade and the bracket lose to decimation in 3 of 16 cells at 5-50% (worst -2.4 dB)
// instead of 6 (worst -7.4); on the graded meshes (ONERA, the oxygen post) 2:1 steps won
// nothing overall and lost up to 13.9 dB at 50% (bench/results/fidelity.json, tags auto and
// r0.5). Its levels hold 1.9-2.1 times the input's tets in all where 4:1 holds 1.3-1.4, and
// the store grows 40-46% (bench/results/level_ratio_auto.json).
constexpr double kGradedLevelRatio = 0.25, kUniformLevelRatio = 0.5;
inline double auto_level_ratio(double grading) { return graded_mesh(grading) ? kGradedLevelRatio : kUniformLevelRatio; }

struct LevelReport {
  uint32_t level = 0, segments = 0, patches = 0;
  uint64_t tets = 0, vertices = 0;
};

struct PreprocessReport {
  uint64_t input_vertices = 0, input_tets = 0;
  std::vector<LevelReport> levels;
  uint32_t segments = 0, patches = 0;
  uint64_t store_bytes = 0, dag_bytes = 0;
  uint64_t variants_bytes = 0, variant_tets = 0;  // variants.bin (--variants)
  uint64_t vertices_bytes = 0, vertex_collapses = 0, vertex_base_tets = 0;  // vertices.bin (0: not built)
  uint32_t vertex_depth = 0;
  double vertex_seconds = 0;
  std::string vertex_hierarchy_skipped;  // why vertices.bin was not built, when it was not
  uint64_t spilled_bytes = 0;  // the largest the spill files grew (--memory-mb), input and levels
  // --simplifier sample: segments TetGen failed or crashed on (it runs in a child process),
  // simplified by quadric collapses instead; this rank's under MPI
  uint32_t tetgen_fallbacks = 0;
  uint32_t segment_tets = 0;  // the segment size built with (auto_segment_tets unless given)
  double grading = 1;         // the input's, as auto_segment_tets and auto_level_ratio read it
  double level_ratio = 0;     // the level ratio built with (auto_level_ratio unless given)
  MultiresModel model = MultiresModel::kMultiTriangulation;
  uint32_t dependencies = 0;  // binary hierarchy: pairs of new segments merged over a simplified boundary
  double seconds = 0, read_seconds = 0, segment_seconds = 0, simplify_seconds = 0, write_seconds = 0;
  nlohmann::json to_json() const;
};

// ingest -> partition (octree + METIS, §6.1) -> per level: partition again (rotated 45° every
// other level, §6.3.2), patches, simplify every new segment with its border locked, error
// histograms -> store, written atomically (NAME.tmp/ renamed to NAME/ when complete).
// Throws storage::MeshError for a bad mesh, std::invalid_argument for bad options,
// std::runtime_error otherwise; on failure no store directory is left behind. With
// options.ranks, every rank must call it; on ranks other than 0 it writes nothing and
// returns a report of the input only.
PreprocessReport preprocess(const std::filesystem::path& mesh, const std::filesystem::path& store, const PreprocessOptions& options,
                            storage::Progress* progress = nullptr);

}  // namespace tetrascope::lod
