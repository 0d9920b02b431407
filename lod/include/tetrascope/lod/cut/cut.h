// The runtime cut through the multi-triangulation (dissertation §6.3.4).
//
// A cut is kept as the set of refined segments, closed upwards (a refined segment's parents
// are refined; the root always is). The active patches are the arcs from a refined ceiling
// to an unrefined floor: every root-to-leaf path holds exactly one, so the patches tile the
// domain and form one conforming mesh. Refining a segment whose parents are not all refined
// first refines them (forced refinements); a segment coarsens when none of its children is
// refined (all its outgoing patches are active).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/cut/variants.h"
#include "tetrascope/view/camera.h"
#include "tetrascope/view/transfer_function.h"
#include "tetrascope/view/planes.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::lod {

// What a cut adapts to is view's: the camera and its frustum, the transfer function, planes.
using view::Camera;
using view::Frustum;
using view::TransferFunction;
using view::view_frustum;

// What the cut optimises for: the error each segment leaves on screen. On a store with error
// masses (dag format 2) and a volume view, E = V · Σ_n C(n) M(n) S(c_n): M the segment's error
// mass in value slot n of `channel` (|error|·volume at the input vertices it covers), C the
// transfer function's opacity per slot (empty: 1 everywhere), S the share of the view a unit
// of mass covers at the depth of the slot's centroid c_n (1/z², fading to 0 beyond the view,
// 0 behind the eye), V = 0 outside the frustum. Otherwise (stores of format 1, isosurfaces)
// E = V · A · Σ_n H(n) C(n) (§6.3.4): H the field-error histogram, A the share of the view
// the segment's box covers (1 without a camera or with the box reaching the eye's plane);
// with isovalues (normalised, [0, 1]) the spatial-error histogram around each isovalue
// instead. Segments are refined in the order of E per tet the refinement adds (forced
// refinements included), so a budget buys the most image error removed.
//
// Clip planes and slices (view/planes.h): a segment whose box lies wholly outside a kept
// half-space has E = 0 (coarsened first, never refined; assemble_cut with the same planes does
// not read it). A slice plane is an isosurface of the signed distance: a segment whose box it
// crosses has E = kSliceWeight · V · A · Σ_n H(n) (the field error with every value visible,
// as the opaque slice shows them all), so those segments are refined before any other.
struct CutCriteria {
  uint32_t channel = 0;
  std::vector<float> opacity;    // per histogram bin
  std::vector<double> isovalues;
  std::optional<Frustum> frustum;
  std::optional<Camera> camera;  // the eye and the field of view, for A
  std::vector<view::Plane> clip;    // kept half-spaces n.x <= d (ClipSpec::half_spaces)
  std::vector<view::Plane> slices;
  // The transfer function's opacity is that of a slab this thick (0: 1/100 of the diagonal,
  // as the renderers take it): a thinner slab makes the same value error show more. Scales
  // the error masses' E, so the estimates of different views compare; the order is the same.
  double unit_distance = 0;
};
constexpr double kSliceWeight = 1e6;
// Whether the box (min xyz, max xyz) lies wholly outside one of the kept half-spaces.
bool clipped_away(std::span<const view::Plane> clip, const float box[6]);
bool crosses(const view::Plane& plane, const float box[6]);
// Both view parts of the criteria from one camera (the frustum reaches `far_plane`).
void set_view(CutCriteria& criteria, const Camera& camera, double far_plane = 1e30);

struct CutChanges {
  std::vector<uint32_t> added, removed;  // patches
  uint64_t tets = 0;                     // after the update
  uint32_t refinements = 0, forced_refinements = 0, coarsenings = 0;
  bool budget_limited = false;  // a wanted refinement did not fit the budget
  bool over_budget = false;     // even the coarsest cut has more tets than the budget
  // Σ E over the segments the cut shows unrefined (those with an active patch): the image
  // error the cut is estimated to leave, in the units of E (field error × opacity × view share)
  double estimated_error = 0;
  bool variants_changed = false;  // a segment's variant shown changed (its patches may not have)
};

class Cut {
 public:
  explicit Cut(const Dag& dag);  // the coarsest cut: the root patches

  // Coarsens invisible and cheapest segments until the budget holds, then refines the
  // segments of largest error while the refinement (forced ones included) fits; then trades
  // the cheapest refined segment for a dearer unrefined one while that lowers the error; with
  // variants attached, spends what is left on them.
  CutChanges update(const CutCriteria& criteria, uint64_t budget);

  // Single steps (tests, tools). refine() refines the node and the parents it needs, if the
  // result stays within `budget` (0: no limit); returns false and changes nothing otherwise.
  bool refine(uint32_t node, uint64_t budget = 0, CutChanges* changes = nullptr);
  bool coarsen(uint32_t node, CutChanges* changes = nullptr);
  bool can_coarsen(uint32_t node) const { return refined_[node] && refined_children_[node] == 0; }
  bool refined(uint32_t node) const { return refined_[node] != 0; }
  // tets the refinement of `node` would add, forced refinements included
  int64_t refinement_cost(uint32_t node) const;
  void refine_all();  // the finest cut: the input mesh

  bool active(uint32_t patch) const;
  std::vector<uint32_t> active_patches() const;
  uint64_t tet_count() const { return tets_ + variant_tets_; }  // shown: variants' tets included
  // Segments a viewer should keep loaded: those with an active patch and their neighbours in
  // the DAG (parents and children), which the next refinements or coarsenings will need.
  std::vector<uint32_t> resident_segments() const;
  const Dag& dag() const { return dag_; }

  // With the store's variants attached (variants.h; null: none), update() ends by spending
  // what the budget has left, too little for any refinement, on variants of segments shown
  // whole (variant_of: 0 the segment itself, j its variant j-1); assemble_cut shows them.
  void attach_variants(const Variants* variants) {
    variants_ = variants;
    variant_.assign(variants ? dag_.node_count() : 0, 0);
    variant_tets_ = 0;
  }
  const Variants* variants() const { return variants_; }
  uint32_t variant_of(uint32_t node) const { return node < variant_.size() ? variant_[node] : 0; }
  uint64_t variant_extra_tets() const { return variant_tets_; }  // what the variants shown add

 private:
  // update's steps, in order (e: each segment's error in the view)
  void update_weights(const CutCriteria& criteria);
  std::vector<double> segment_errors(const CutCriteria& criteria);
  double refine_priority(const std::vector<double>& e, uint32_t node) const;
  double coarsen_priority(const std::vector<double>& e, uint32_t node) const;
  void coarsen_to_budget(const std::vector<double>& e, uint64_t budget, CutChanges& changes);
  void refine_within_budget(const std::vector<double>& e, uint64_t budget, CutChanges& changes);
  void trade_refinements(const std::vector<double>& e, uint64_t budget, CutChanges& changes);
  void collect_changes(const std::vector<double>& e, uint64_t budget, CutChanges& changes);
  void fill_variants(const std::vector<double>& e, uint64_t budget);
  double variant_share(uint32_t node) const;  // of the segment's error a variant leaves
  uint32_t variant_count(uint32_t node) const;
  uint64_t variant_tets(uint32_t node, uint32_t j) const;  // j = 0: the segment's own
  int64_t variant_extra(uint32_t node) const;              // tets its variant adds
  void drop_variant(uint32_t node);
  double variant_priority(double e, uint32_t node, uint32_t j) const;
  const Variants* variants_ = nullptr;
  std::vector<uint8_t> variant_;
  uint64_t variant_tets_ = 0;  // tets the variants add over their segments'

  void apply_refine(uint32_t node, CutChanges* changes);
  void apply_coarsen(uint32_t node, CutChanges* changes);
  void note(uint32_t patch);
  bool displayed(uint32_t node) const;  // every parent refined: all its tets are shown
  bool shown(uint32_t node) const;      // unrefined, with a patch active: some of its tets are shown
  double slice_weight(uint32_t node, uint32_t channel);  // Σ_n H(n) of the field histogram, cached
  const Dag& dag_;
  std::vector<uint8_t> refined_;
  std::vector<uint32_t> refined_children_, unrefined_parents_;
  std::vector<int64_t> gain_;  // tets added by refining the node: children's patches - its own
  uint64_t tets_ = 0;
  double scene_diagonal_ = 1;             // of the coarsest segments' boxes: the mesh's size
  std::vector<uint32_t> flips_;           // patches whose state changed during an update
  std::vector<uint8_t> flipped_, was_active_;
  // cached Σ H·C per node for the last criteria
  std::vector<double> weight_;
  std::vector<float> weight_opacity_;
  std::vector<double> weight_isovalues_;
  uint32_t weight_channel_ = 0xFFFFFFFFu;
  std::vector<double> slice_weight_;
  uint32_t slice_weight_channel_ = 0xFFFFFFFFu;
};

// Keeps the segments a cut needs mapped (Cut::resident_segments) and lets the others go
// back to the cache's LRU: a segment is released only when none of its patches is active or
// next to the cut (§6.3.4 caching).
class ResidentSegments {
 public:
  // Maps what the cut needs now (through the cache), unpins the rest; returns how many
  // segments were newly pinned.
  size_t update(const Cut& cut, storage::SegmentCache& cache);
  size_t size() const { return pinned_.size(); }
  bool holds(uint32_t segment) const { return pinned_.count(segment) != 0; }

 private:
  std::unordered_map<uint32_t, std::shared_ptr<const storage::MappedSegment>> pinned_;
};

// The mesh of a cut, assembled from the active patches' segments (through the cache):
// vertices deduplicated by global id, tets in patch order, and face adjacency across
// patches (the role of the 0-segment of §6.2.3): opposites[4 t + f] = 4 t' + f' or
// storage::store::kMeshBoundary.
struct CutMesh {
  storage::TetMesh mesh;
  std::vector<uint32_t> global_ids;  // per vertex
  std::vector<uint32_t> opposites;
  std::vector<uint32_t> patch_first_tet;  // per active patch (in active_patches() order)
  std::vector<uint32_t> patches;          // active, less those of segments shown as a variant
  std::vector<uint32_t> variant_segments; // segments shown as a variant, their tets after the patches'
  bool interrupted = false;  // should_stop said so between two patches: the mesh is partial
};
// With `clip`, the patches of segments wholly clipped away (clipped_away) are not read.
// `should_stop` (may be empty) is asked before each patch; when it says so the assembly ends
// there, `interrupted` set (a refinement step given up for input).
CutMesh assemble_cut(const storage::Store& store, storage::SegmentCache& cache, const Cut& cut, bool adjacency = true,
                     std::span<const view::Plane> clip = {}, const std::function<bool()>& should_stop = {});

// The criteria of a transfer function over a store's attribute (the manifest's range maps
// the function's values onto the histogram bins), and of isosurfaces at `isovalues`
// (attribute units; normalised here over the same range).
CutCriteria criteria_for(const storage::Store& store, const Dag& dag, const TransferFunction& tf, std::span<const double> isovalues = {});

}  // namespace tetrascope::lod
