// Tetrahedral simplification by full-edge collapses driven by quadric error metrics over
// position and normalised attributes (dissertation §3.1.4, §4.1). Works on one mesh in memory
// (a whole small mesh, or one segment of the multi-triangulation with its border locked).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::lod {

// kQem: full-edge collapses with quadrics (§3.1.4, §4.1). kSample: the global simplifier of
// §4.2 (intersection-free border collapses, octree point sampling, TetGen), simplify_sample.cpp.
enum class SimplifyMethod { kQem, kSample };

struct SimplifyOptions {
  SimplifyMethod method = SimplifyMethod::kQem;
  // Stop criteria: the first one reached ends the run. 0 disables a criterion; at least one
  // of target_tets / max_error must be set.
  uint64_t target_tets = 0;
  double max_error = 0;                    // largest quadric error (normalised units) a collapse may have
  std::vector<std::string> attributes;     // attributes in the quadrics; empty = all
  bool gradient_weighting = true;          // weigh tet quadrics by volume x (1 + |gradient|^2)
  double attribute_weight = 1.0;           // scale of the normalised attributes against positions (unit cube)
  double boundary_weight = 1000.0;         // face quadrics on the mesh boundary (keeps the domain and the field on it)
  double feature_weight = 1.0;             // edge quadrics along sharp boundary edges (§4.1.2)
  double feature_angle_degrees = 40.0;     // a boundary edge is sharp above this bend
  double vertex_weight = 1e-3;             // vertex distribution quadrics (conditioning)
  double min_quality = 0.02;               // a collapse may not push a tet's quality below this unless it keeps half its old quality
  bool independent = false;                // independent edge collapses in runs (§4.1.1) instead of one global queue
  // with independent: a collapse also freezes every vertex of its star for the rest of the run,
  // so that no two collapses of a run share a tet (the independent edges of §5.2.1)
  bool independent_stars = false;
  uint32_t threads = 1;                    // global queue only: up to this many regions simplified at once
  uint64_t min_tets_per_thread = 100000;   // ... each holding at least this many tets (fewer: fewer threads)
  uint32_t seed = 1;
  bool trace_costs = false;                // fill SimplifyReport::cost_trace (one global queue on one thread only)
  bool record_collapses = false;           // fill SimplifyReport::collapse_log (kQem; the binary vertex hierarchy of §5.2.1 is built from it)
  // Meshes kept on the way: for each of these tet counts, the mesh as a one-thread run with
  // target_tets = that count (and the same other options) would leave it, in
  // SimplifyReport::snapshots. Counts at or under target_tets give the final mesh. With
  // snapshots the run takes one global queue on one thread (threads is not used);
  // independent runs and the sampling simplifier refuse them.
  std::vector<uint64_t> snapshot_tets;
  // Normalisation frame. By default positions are normalised by the mesh's own box and
  // attributes by their own ranges; the multi-triangulation passes the whole mesh's, so that
  // every segment weighs errors alike. attribute_ranges: per mesh attribute, [lo, hi] of the
  // value (scalars) or [0, longest] (vectors); empty = the mesh's own.
  std::optional<storage::Bounds> frame;
  std::vector<std::array<double, 2>> attribute_ranges;
  // kSample only (§4.2.2). An octree leaf of interior points is split while its field error
  // e_f = |a_max - a_min| (normalised attributes) passes field_error or its space error
  // e_s = D |a_max - a_min| (D: the leaf's extent over the mesh's) passes space_error; 0 = not
  // used. With target_tets the leaves are split worst first until the sample count the target
  // needs. border_error: the farthest (relative to the mesh's diagonal) a border collapse may
  // move the border (its quadric distance); the border keeps its share of the target too.
  double field_error = 0;
  double space_error = 0;
  double border_error = 0.002;
  // kSample: the free vertices' attribute values fitted by least squares to the input's vertex
  // values (the output's linear interpolant against each input vertex) instead of kept as
  // sampled; locked vertices and tensors keep theirs.
  bool fit_values = true;
};

constexpr uint32_t kMaxSimplifyAttributeChannels = 16;

// One edge collapse as the simplifier made it (SimplifyOptions::record_collapses), in input
// vertex indices: `gone` merged into `keep`, which moved to `position` and took `values`
// (SimplifyReport::collapse_values, one row of every attribute's components a collapse).
struct SimplifyCollapse {
  uint32_t keep = 0, gone = 0;
  float cost = 0;  // its quadric error (normalised units)
  std::array<float, 3> position{};
};

// A mesh kept on the way (SimplifyOptions::snapshot_tets), with its source_vertex.
struct SimplifySnapshot {
  uint64_t target = 0;
  storage::TetMesh mesh;
  std::vector<uint32_t> source_vertex;
};

struct SimplifyReport {
  uint64_t tets_before = 0, tets_after = 0, vertices_before = 0, vertices_after = 0;
  uint64_t collapses = 0, refused_topology = 0, refused_geometry = 0, runs = 0;
  uint64_t max_queue = 0;
  int threads = 1;  // threads used
  std::vector<uint32_t> source_vertex;  // per output vertex: the input vertex it continues (it may have moved); kSample: 0xFFFFFFFF for a Steiner point
  // kSample: border triangles before/after, interior samples, Steiner points TetGen added,
  // border collapses refused because they would make the border intersect itself
  uint64_t border_before = 0, border_after = 0, samples = 0, steiner_points = 0, refused_intersection = 0;
  uint64_t tetrahedralizations = 0;
  // kSample: the border encloses a cavity (TetGen would fill it) or crosses itself, or TetGen
  // failed (tetgen_failure says how), so the quadric simplifier did the work (simplify_sampled)
  bool fell_back_to_qem = false;
  std::string tetgen_failure;
  double border_seconds = 0, sample_seconds = 0, tetrahedralize_seconds = 0, output_seconds = 0, fit_seconds = 0;  // kSample: the phases  // TetGen runs (a second one when the first missed the target by far)
  double seconds = 0;
  // With trace_costs: per collapse, in order, the tets alive after it and its quadric cost.
  // Re-running with target_tets = one of these counts stops at the same mesh (deterministic).
  std::vector<std::pair<uint64_t, double>> cost_trace;
  std::vector<SimplifySnapshot> snapshots;  // one per SimplifyOptions::snapshot_tets, in its order
  // With record_collapses: every collapse in an order that replays it (collapses of the two
  // regions touch disjoint tets, so each region's come whole), and their vertices' values.
  std::vector<SimplifyCollapse> collapse_log;
  std::vector<float> collapse_values;
};

// Simplifies `mesh` in place (vertices compacted, tets positively oriented). Vertices with
// locked[v] != 0 are never moved or removed, and their attributes stay bit-identical: an edge
// from a locked vertex p to a free vertex q may collapse only onto p; an edge between two
// locked vertices never collapses. `locked` may be empty. Throws std::invalid_argument for
// bad options (unknown attribute, negative weights, no stop criterion).
// With options.method == kSample the work is simplify_sampled's.
SimplifyReport simplify(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked = {});

// The global simplifier of §4.2 on one mesh in memory: the border (faces of one tet) is
// simplified by half-edge collapses on quadrics that never make it intersect itself (border
// faces whose three vertices are locked are never touched, nor is any locked vertex), the
// interior vertices are sampled by an octree (one representative a leaf), and TetGen builds a
// constrained Delaunay tetrahedralization of the samples inside the simplified border,
// adding no point on it; Steiner points get values by barycentric location in the input.
// Every kept vertex keeps its position; with options.fit_values (the default) the free
// vertices' values are then fitted by least squares to the input's, locked ones keep theirs
// bit-identical (without it every kept vertex does). Where the border encloses a
// cavity (TetGen fills it: it gets no hole points) the mesh goes to the quadric simplifier
// instead and the report says fell_back_to_qem; so does one where TetGen fails or crashes
// (it runs in a child process; tetgen_failure says what happened). The input must be
// conforming with an intersection-free border; throws std::invalid_argument for bad options.
SimplifyReport simplify_sampled(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked = {});

// The simplifier `tetrascope simplify --method auto` (its default) takes for this mesh, by the
// rule measured on the shared data and the blades (bench/README.md, "The sampling
// simplifier"): the sampler where the run stops at a tet count below the mesh's, the mesh has
// at least kAutoSampleMinTets tets, at most kAutoSampleMaxBorderShare of its vertices lie on
// its border (where more do, the border phase costs more than QEM saves: the FEM bracket) and
// its border does not cross itself (TetGen could not mesh it: the sampler would fall back
// anyway); the quadric simplifier otherwise. `why` gets the reason in words.
constexpr uint64_t kAutoSampleMinTets = 30000;
constexpr double kAutoSampleMaxBorderShare = 0.6;
SimplifyMethod choose_simplify_method(const storage::TetMesh& mesh, const SimplifyOptions& options, std::string* why = nullptr);

}  // namespace tetrascope::lod
