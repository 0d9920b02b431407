// The vertex front through a binary vertex hierarchy (§5.2.2–5.2.3, §5.3.3): the set of
// collapses applied, kept closed so that its mesh conforms, split and collapsed one vertex at
// a time, and adapted to a view under a tet budget.
//
// A front is a set of applied collapses closed downwards in the hierarchy (a collapse applied
// has its children's collapses applied): its vertices are those whose collapse is applied and
// whose parent's is not, and its mesh is the input's tets with every vertex replaced by its
// vertex on the front, less the tets that degenerate.
//
// split() and collapse() keep the front a state of the simplification: splitting a collapse
// first splits every applied collapse that consumed a tet it made (forced splits); collapsing
// one needs every collapse that made a tet it consumes applied.
//
// update() builds two fronts from the base mesh under the budget and keeps the one that
// leaves less of the view's estimate:
// - splits valid at run time, as FastTetraMesh checks them (§5.3.3): a split needs its
//   vertex on the front and every tet it changes or brings back positively oriented, whatever
//   the refinement around it; when a tet would invert, the later collapses whose vertices it
//   holds split first (Predictive Tetra Mesh's forced splits, §5.2.3), or the earlier ones
//   split around it collapse again for it. The collapses in view split first in the
//   simplification's reverse order up to a quarter of the budget, then the front's vertices
//   in the order of the image error a split removes per tet it adds (or a higher one below);
// - the simplification's order: packages (a split and the splits it forces on the current
//   front) in the order of their summed estimate per tet.
// The first needs far fewer forced tets; the second refines where the first finds no valid
// split (far-field cells around refined neighbours). A front update() leaves conforms;
// split() and collapse() after it need collapse_all() first.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/view/camera.h"
#include "tetrascope/view/planes.h"
#include "tetrascope/view/transfer_function.h"

namespace tetrascope::lod {

// What the front adapts to. The image error a split removes is estimated as
//   E = V · S · T · C · e
// e the collapse's quadric error (monotone up the hierarchy); S = (D / z)², D the mesh's
// diagonal and z the distance from the eye to the collapse's sphere (at least D / 100): the
// share of the view a unit of error covers; V = 1 when the sphere meets the frustum, else 0
// (split only when a split in view forces it); T the transmittance from the eye to the sphere's nearest point through the
// base mesh classified by the transfer function (isosurfaces: opaque where the base mesh
// crosses an isovalue), at least kOccludedWeight; C the opacity of a slab as thick as the sphere's radius at the largest
// opacity the transfer function gives over the values below the collapse (with isovalues: 1
// where one lies in them), plus kTransparentWeight, so that what no opacity shows is refined
// last; a sphere wholly clipped away has E = 0 and one a
// slice crosses E · kSliceWeight.
struct FrontCriteria {
  int attribute = -1;            // the hierarchy's attribute the transfer function reads; -1: C = 1
  double lo = 0, hi = 1;         // the opacity table's range
  std::vector<float> opacity;    // the transfer function's opacity in equal bins over [lo, hi]; empty: C = 1
  std::vector<double> isovalues; // attribute units
  std::optional<view::Camera> camera;
  std::vector<view::Plane> clip;    // kept half-spaces n.x <= d
  std::vector<view::Plane> slices;
  double unit_distance = 0;  // the transfer function's opacity is that of a slab this thick (0: D / 100)
};
constexpr double kOccludedWeight = 1e-3;
constexpr double kTransparentWeight = 1e-3;
constexpr double kFrontSliceWeight = 1e6;
constexpr uint32_t kOpacityBins = 256;

// The criteria of a transfer function (isovalues: isosurfaces) over the hierarchy's attribute.
// Throws std::invalid_argument for an attribute the hierarchy lacks.
FrontCriteria front_criteria(const VertexHierarchy& hierarchy, const view::TransferFunction& tf, std::span<const double> isovalues = {});

struct FrontChanges {
  uint64_t tets = 0;
  uint64_t budget = 0;
  uint32_t splits = 0;
  bool changed = false;         // the front differs from the one before the update
  bool budget_limited = false;  // a wanted split did not fit
  bool over_budget = false;     // the base mesh alone has more tets than the budget
  bool complete = false;        // no split was dropped for the budget or refused: the splits left are out of view or clipped away
  uint32_t refused = 0;         // splits left out because a tet would invert even with its later neighbours split
  bool run_time_valid = false;  // the front of splits valid at run time was kept, not the one in the simplification's order
  double estimated_error = 0;   // Σ E over the collapses left applied
  // Of the tets the splits added: those of splits made only because a split in view needed
  // them (the other members of its package), and of all splits those whose own E is 0 (out
  // of view or clipped away).
  uint64_t forced_tets = 0, unseen_tets = 0;
};

enum class FrontSearch { best, run_time };

class VertexFront {
 public:
  explicit VertexFront(const VertexHierarchy& hierarchy);  // the base mesh: every collapse applied

  // The better of the two fronts above under `budget` (the one with the lower Σ E left), or
  // with FrontSearch::run_time the first alone (about half the time; what a moving view takes).
  FrontChanges update(const FrontCriteria& criteria, uint64_t budget, FrontSearch search = FrontSearch::best);

  // Single steps. split() splits the collapse and every one it forces; collapse() refuses
  // (false) while a collapse that made a tet it consumes is split.
  bool split(uint32_t collapse);
  bool collapse(uint32_t collapse);
  bool applied(uint32_t collapse) const { return applied_[collapse] != 0; }
  bool can_collapse(uint32_t collapse) const { return !applied_[collapse] && split_before_[collapse] == 0; }
  void split_all();     // the input mesh
  void collapse_all();  // the base mesh
  uint64_t tet_count() const { return tets_; }

  // The front's mesh: its vertices (those its tets use, in vertex-id order) with their
  // attributes, and per vertex its id in the hierarchy. `values` (optional): the values of
  // another time step, laid out as VertexHierarchy::values.
  storage::TetMesh mesh(std::vector<uint32_t>* vertex_ids = nullptr, const float* values = nullptr) const;
  // Per-collapse E for `criteria` (tests, tools).
  std::vector<double> errors(const FrontCriteria& criteria) const;

  const VertexHierarchy& hierarchy() const { return h_; }

 private:
  void apply_split(uint32_t i);
  void apply_collapse(uint32_t i);
  struct Package {
    std::vector<uint32_t> members;
    double error = 0;
    uint64_t tets = 0;
  };
  bool package(uint32_t i, std::span<const double> own, uint64_t limit, Package& out);
  FrontChanges update_packages(uint64_t budget);  // the simplification's order (vertex_front.cpp)
  FrontChanges update_run_time(uint64_t budget);  // splits valid at run time (front_update.cpp)
  // update()'s splits (front_update.cpp). Per hierarchy, shared by its fronts: per vertex the
  // input leaves below it as an interval of a preorder, per vertex its root; per input tet the
  // collapses at which two of its vertices meet (it lives while none of them is applied); the
  // base mesh's stars. Per front: per leaf its vertex on the front, kept lazily; per vertex of
  // the front the living tets that use it, as linked lists of (tet, corner) entries.
  struct RunTimeIndex {
    std::vector<uint32_t> leaf_pos, leaf_lo, leaf_hi, root;
    std::vector<uint32_t> meet_offsets, meet_tets;  // per collapse: the tets two of whose vertices meet there
    std::vector<uint8_t> meets;                     // per tet: its meeting collapses
    std::vector<uint32_t> base_head, base_next;     // the base mesh's star lists; entry 4 t + k
  };
  static std::shared_ptr<const RunTimeIndex> run_time_index(const VertexHierarchy& hierarchy, const std::vector<uint32_t>& parent);
  std::shared_ptr<const RunTimeIndex> index_;
  void reset_relaxed();
  uint32_t front_vertex(uint32_t leaf);
  bool below(uint32_t vertex, uint32_t leaf) const {
    return index_->leaf_pos[leaf] >= index_->leaf_lo[vertex] && index_->leaf_pos[leaf] < index_->leaf_hi[vertex];
  }
  double image_volume(const std::array<uint32_t, 4>& image) const;
  enum class Trial { ok, inverted, over_budget };
  Trial try_split(uint32_t i, uint64_t budget);
  bool split_relaxed(uint32_t i, uint64_t budget, int depth, bool& over_budget, bool may_collapse);
  void commit_split(uint32_t i);
  bool collapse_relaxed(uint32_t j);
  bool collapse_again(uint32_t j, std::vector<uint32_t>& again, int depth, uint64_t budget);
  std::vector<uint8_t> meets_left_;                   // per tet: its meeting collapses still applied
  std::vector<uint32_t> rep_;                         // per leaf: its vertex on the front (or an ancestor of it)
  std::vector<uint32_t> head_, next_;                 // star lists; entry 4 t + k
  std::vector<uint32_t> revived_;                     // try_split(): the tets the split brings back
  std::array<uint32_t, 4> inverted_{};                // try_split(), collapse_relaxed(): the image of a tet it would invert
  std::vector<double> own_;                           // update(): per collapse its E
  std::vector<uint8_t> recollapsed_;                  // update(): per collapse the times it was applied again
  std::vector<uint32_t> pending_;                     // update(): the splits of one step, whose children join the front
  uint64_t last_added_ = 0, unseen_added_ = 0;        // update(): the tets of the last split, of splits with E = 0
  std::vector<uint32_t> seen_, stack_;  // package(): visited marks by epoch, the walk's stack
  uint32_t epoch_ = 0;
  // Occlusion: the base mesh's values sampled on a grid over the mesh's box (NaN outside it),
  // and per update the transmittance from the eye to each grid point.
  void sample_base_grid();
  std::vector<float> transmittance(const FrontCriteria& criteria) const;
  float grid_at(const std::vector<float>& grid, const double* p, float outside = 1) const;
  static constexpr int kGrid = 40;
  std::array<double, 3> grid_lo_{}, grid_step_{};
  std::vector<float> grid_values_;  // kGrid³ per attribute
  const VertexHierarchy& h_;
  double diagonal_ = 1;
  std::vector<uint8_t> applied_;
  std::vector<uint32_t> applied_after_;  // per collapse: applied collapses among its `after`
  std::vector<uint32_t> split_before_;   // per collapse: split collapses among its `before`
  std::vector<uint32_t> parent_;         // per vertex: the collapse that consumes it, or kNoCollapse
  uint64_t tets_ = 0;
  bool updated_ = false;
};

}  // namespace tetrascope::lod
