// The vertex front through a binary vertex hierarchy (§5.2.2–5.2.3, §5.3.3): the set of
// collapses applied, kept closed so that its mesh conforms, split and collapsed one vertex at
// a time, and adapted to a view under a tet budget.
//
// A split undoes one collapse: it brings back the collapse's two vertices and its fan tets.
// Splitting a collapse first splits every applied collapse that consumed a tet it made
// (forced splits); collapsing one needs every collapse that made a tet it consumes applied.
// update() starts from the base mesh and splits in the order of the image error a split and
// the splits it forces remove per tet they add, until the budget holds no further package.
#pragma once

#include <array>
#include <cstdint>
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
  bool budget_limited = false;  // a wanted split's package did not fit
  bool over_budget = false;     // the base mesh alone has more tets than the budget
  bool complete = false;        // no package was dropped: the splits left are out of view or clipped away
  double estimated_error = 0;   // Σ E over the collapses left applied
  // Of the tets the splits added: those of splits made only because a split in view needed
  // them (the other members of its package), and of all splits those whose own E is 0 (out
  // of view or clipped away).
  uint64_t forced_tets = 0, unseen_tets = 0;
};

class VertexFront {
 public:
  explicit VertexFront(const VertexHierarchy& hierarchy);  // the base mesh: every collapse applied

  // From the base mesh, packages (a split and the splits it forces) in the order of their
  // summed E per tet, each taken when it fits `budget`.
  FrontChanges update(const FrontCriteria& criteria, uint64_t budget);

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
  // attributes, and per vertex its id in the hierarchy.
  storage::TetMesh mesh(std::vector<uint32_t>* vertex_ids = nullptr) const;
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
  std::vector<uint32_t> seen_, stack_;  // package(): visited marks by epoch, the walk's stack
  uint32_t epoch_ = 0;
};

}  // namespace tetrascope::lod
