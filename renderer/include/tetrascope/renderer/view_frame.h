// The one frame pipeline, shared by `tetrascope render` and the server's viewing sessions:
// the view's request resolved against the dataset (attribute, colour range, isovalues,
// camera), the cut through the store's DAG updated for its camera, transfer function and
// budget (§6.3.4), the cut's mesh and scene assembled when the cut changed, drawn by a
// Renderer. Encoding (JPEG, PNG) is the caller's: a file for the CLI, a frame message for
// the server.
//
// A ViewPipeline holds one view's state (its cut and scene) across frames; it is not thread
// safe, and its store, DAG and cache must outlive it. Requests are trusted: their fields were
// checked where they arrived (protocol::parse_message, the CLI's options), except the
// attribute names, which only the dataset can check (std::invalid_argument).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/vertex/vertex_front.h"
#include "tetrascope/view/view_request.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::renderer {

class RayCaster;
class RegionMap;

// The request a view draws (view/view_request.h).
using view::LineRequest;
using view::ViewRequest;

// Where a frame's time went (ms): cut update, assembly of the cut's mesh and scene (0 when
// nothing changed), scene upload to the renderer (0 when it held the scene), drawing and
// readback.
struct ViewTimings {
  double cut_ms = 0, assemble_ms = 0, upload_ms = 0, draw_ms = 0;
  double clip_ms = 0;  // clipping the scene (0 when neither the scene nor the planes changed)
  double regions_ms = 0;  // the scene's boundary faces classified into regions (0 unless regions are hidden)
  bool interrupted = false;  // update's should_stop stopped the reassembly: do not draw
  FrameTimings draw;  // the renderer's own split
};

struct ViewFrame {
  Image image;
  RenderSettings settings;  // as drawn (resolved attribute, range, isovalues, camera)
  uint64_t tets = 0;        // in the scene drawn
  ViewTimings timings;
};

class ViewPipeline {
 public:
  // A multiresolution store: each view draws a cut of at most `request.budget` tets. With the
  // store's vertex hierarchy (vertices.bin, shared between pipelines; null: none) the cut
  // refines by single vertex splits (lod/vertex/vertex_front.h), else through the DAG.
  ViewPipeline(const storage::Store& store, const lod::Dag& dag, storage::SegmentCache& cache,
               std::shared_ptr<const lod::VertexHierarchy> vertices = nullptr);
  // A whole mesh (a mesh file): no cut, no budget.
  explicit ViewPipeline(storage::TetMesh mesh);
  ~ViewPipeline();
  ViewPipeline(const ViewPipeline&) = delete;
  ViewPipeline& operator=(const ViewPipeline&) = delete;

  // The dataset's boundary regions (boundary_regions.h), shared between its views: a scene's
  // boundary faces are classified by them when a request first hides regions in surface mode,
  // so DrawOptions::hidden_regions can leave regions out. Set before the first update; none:
  // every face is shown.
  void set_regions(std::shared_ptr<const RegionMap> regions) { regions_ = std::move(regions); }

  // A time series' step (storage/time_steps.h): `cache` gives the step's segments (outliving
  // the pipeline, or until the next set_step) and `values` its values (null for step 0: the
  // store's own, with the constructor's cache). The scene is rebuilt at the next update when
  // the step changed; the cut is kept (it is chosen by step 0's errors).
  void set_step(uint32_t step, storage::SegmentCache& cache, std::shared_ptr<const std::vector<float>> values);
  uint32_t step() const { return step_; }

  // Resolves the request, updates the cut and reassembles the scene when the cut or the
  // attributes changed; returns the settings to draw with. Throws std::invalid_argument for
  // an attribute the dataset lacks. `should_stop` (may be empty) is asked between the
  // patches of a reassembly: when it says so the scene stays the one before (reassembled at
  // the next update) and the frame should not be drawn (ViewTimings::interrupted).
  RenderSettings update(const ViewRequest& request, ViewTimings* timings = nullptr, const std::function<bool()>& should_stop = {});
  // Draws `settings` (from update; the camera may differ) with `renderer`, uploading the scene
  // first unless `renderer` holds it already: `held_generation` says which scene it holds
  // (0: none) and is updated.
  Image draw(const RenderSettings& settings, Renderer& renderer, uint64_t& held_generation, ViewTimings* timings = nullptr);
  // Draws `settings` with the CPU ray caster (ray_caster.h) of scene(), made anew when the
  // scene changed (its cost in upload_ms). Throws std::invalid_argument for what the caster
  // does not draw (RayCaster::unsupported).
  Image cast(const RenderSettings& settings, ViewTimings* timings = nullptr, unsigned threads = 0);
  // update, then draw.
  ViewFrame render(const ViewRequest& request, Renderer& renderer, uint64_t& held_generation);

  // The cut's estimated error after the last update (stores only; see lod::CutChanges).
  std::optional<double> cut_estimated_error() const { return cut_estimated_error_; }
  // How the last update's cut met its budget (stores only): its tets, whether a wanted
  // refinement did not fit (budget_limited) and whether even the coarsest cut is above it
  // (over_budget: the store's coarsest level holds more tets than asked for).
  struct CutBudget {
    uint64_t budget = 0, tets = 0;
    bool budget_limited = false, over_budget = false;
    bool complete = false;  // vertex front: all the view shows is at full resolution under the budget
    uint64_t forced_tets = 0, unseen_tets = 0;  // vertex front: see lod::FrontChanges
    uint32_t refused_splits = 0;                // vertex front: lod::FrontChanges::refused
    bool run_time_valid = false;                // vertex front: lod::FrontChanges::run_time_valid
  };
  std::optional<CutBudget> cut_budget() const { return cut_budget_; }
  const storage::Bounds& bounds() const { return bounds_; }  // of the whole dataset (cameras are placed by it)
  // The scene drawn after update: clipped when the request has a clip.
  const SceneMesh& scene() const { return clipped_ ? *clipped_ : *scene_; }
  // The scene before the clip, with every point attribute (the probe's values_at).
  const SceneMesh& unclipped_scene() const { return *scene_; }
  const lod::Cut* cut() const { return cut_.get(); }   // null for a whole mesh
  const lod::VertexFront* front() const { return front_.get(); }  // null without a vertex hierarchy
  // The lines traced for the last request with lines (null: none yet), and the error of the
  // cut they were traced on (stores only).
  std::shared_ptr<const LineSet> lines() const { return lines_; }
  std::optional<double> lines_cut_error() const { return lines_cut_error_; }
  // The tensor points of the last request with tensors (null: none yet).
  std::shared_ptr<const TensorPoints> tensor_points() const { return tensor_points_; }

 private:
  void resolve_attribute(view::TransferFunction& tf) const;
  void rebuild_scene(const storage::TetMesh& mesh, const view::TransferFunction& tf, const std::string& iso_color_attribute);
  void trace_lines(const storage::TetMesh& mesh, const LineRequest& request);
  void apply_lines(const LineRequest& request, RenderSettings& s);
  // The tensor points traced again when the request's tensor part changed (the point size
  // alone draws the same points), then into the settings.
  void update_tensors(const storage::TetMesh& mesh, const ViewRequest& request, RenderSettings& s);
  bool tensors_stale(const ViewRequest& request) const;
  // update() on the vertex front (stores with vertices.bin)
  void update_front(const ViewRequest& request, RenderSettings& s, ViewTimings& t, bool trace);

  const storage::Store* store_ = nullptr;
  const lod::Dag* dag_ = nullptr;
  storage::SegmentCache* cache_ = nullptr;
  uint32_t step_ = 0;
  std::shared_ptr<const std::vector<float>> step_values_;  // null: step 0
  bool step_changed_ = false;                              // the scene is of another step
  std::unique_ptr<lod::Variants> variants_;  // the store's, null when none (declared before cut_, which points to it)
  std::unique_ptr<lod::Cut> cut_;
  std::shared_ptr<const lod::VertexHierarchy> vertices_;
  std::unique_ptr<lod::VertexFront> front_;
  bool scene_from_front_ = false;  // the scene is the front's mesh (not the DAG cut's)
  std::optional<storage::TetMesh> mesh_;  // the whole mesh, without a store
  storage::Bounds bounds_;
  std::optional<double> cut_estimated_error_;
  std::optional<CutBudget> cut_budget_;
  std::unique_ptr<SceneMesh> scene_;  // its boundary faces' regions filled when first needed (classify_regions)
  std::string attribute_, iso_color_attribute_;      // the scene's
  int component_ = view::kMagnitude;                 // the scene's attribute's component
  uint64_t scene_generation_ = 0;         // unique over all pipelines of the process
  std::shared_ptr<const LineSet> lines_;
  std::optional<LineRequest> traced_;      // the request lines_ answers (field, seeds, steps)
  std::optional<LineRequest> selected_for_;  // the request selection_ answers
  std::vector<uint32_t> selection_;
  std::optional<double> lines_cut_error_;
  std::shared_ptr<const TensorPoints> tensor_points_;
  std::optional<view::TensorRequest> tensors_traced_;  // the request tensor_points_ answers
  // the clipped scene, rebuilt when the scene or the clip changes
  void update_clip(const view::ClipSpec& clip, ViewTimings& timings);
  void classify_regions(const ViewRequest& request, ViewTimings& timings);
  std::unique_ptr<SceneMesh> clipped_;
  view::ClipSpec clip_;
  std::vector<view::Plane> assembled_clip_;  // the half-spaces the scene was assembled with
  bool scene_stale_ = false;              // a reassembly was stopped: scene_ is not the cut's
  uint64_t clipped_from_ = 0;             // the scene generation clipped_ was cut from
  uint64_t drawn_generation_ = 0;         // of scene(): clipped_'s own or scene_generation_
  std::shared_ptr<const RegionMap> regions_;  // null: none
  std::unique_ptr<RayCaster> caster_;     // of the scene of caster_generation_
  uint64_t caster_generation_ = 0;
};

}  // namespace tetrascope::renderer
