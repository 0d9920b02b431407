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

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tetrascope/lod/cut.h"
#include "tetrascope/lod/view.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::renderer {

struct ViewRequest {
  std::optional<lod::Camera> camera;  // none: lod::default_camera of the dataset's bounds
  lod::TransferFunction tf;           // no attribute: the dataset's first; no range: the attribute's over the whole dataset
  bool dvr = true, iso = false, surface = false, wireframe = false, box = false;
  std::vector<double> isovalues;      // attribute units; none (with iso): mid-range
  double iso_opacity = 1;
  std::string iso_color_attribute;               // a second attribute colouring the isosurfaces; empty: by value
  double unit_distance = 0;           // RenderSettings::unit_distance
  VolumeMethod volume = VolumeMethod::exact;  // RenderSettings::volume
  uint64_t budget = 0;                // tets of the cut (stores only)
  uint32_t width = 1024, height = 768;
};

// Where a frame's time went (ms): cut update, assembly of the cut's mesh and scene (0 when
// nothing changed), scene upload to the renderer (0 when it held the scene), drawing and
// readback.
struct ViewTimings {
  double cut_ms = 0, assemble_ms = 0, upload_ms = 0, draw_ms = 0;
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
  // A multiresolution store: each view draws a cut of at most `request.budget` tets.
  ViewPipeline(const storage::Store& store, const lod::Dag& dag, storage::SegmentCache& cache);
  // A whole mesh (a mesh file): no cut, no budget.
  explicit ViewPipeline(storage::TetMesh mesh);
  ~ViewPipeline();
  ViewPipeline(const ViewPipeline&) = delete;
  ViewPipeline& operator=(const ViewPipeline&) = delete;

  // Resolves the request, updates the cut and reassembles the scene when the cut or the
  // attributes changed; returns the settings to draw with. Throws std::invalid_argument for
  // an attribute the dataset lacks.
  RenderSettings update(const ViewRequest& request, ViewTimings* timings = nullptr);
  // Draws `settings` (from update; the camera may differ) with `renderer`, uploading the scene
  // first unless `renderer` holds it already: `held_generation` says which scene it holds
  // (0: none) and is updated.
  Image draw(const RenderSettings& settings, Renderer& renderer, uint64_t& held_generation, ViewTimings* timings = nullptr);
  // update, then draw.
  ViewFrame render(const ViewRequest& request, Renderer& renderer, uint64_t& held_generation);

  // The cut's estimated error after the last update (stores only; see lod::CutChanges).
  std::optional<double> cut_estimated_error() const { return cut_estimated_error_; }
  const storage::Bounds& bounds() const { return bounds_; }  // of the whole dataset (cameras are placed by it)
  const SceneMesh& scene() const { return *scene_; }  // after update
  const lod::Cut* cut() const { return cut_.get(); }   // null for a whole mesh

 private:
  void resolve_attribute(lod::TransferFunction& tf) const;
  void rebuild_scene(const storage::TetMesh& mesh, const std::string& attribute, const std::string& iso_color_attribute);

  const storage::Store* store_ = nullptr;
  const lod::Dag* dag_ = nullptr;
  storage::SegmentCache* cache_ = nullptr;
  std::unique_ptr<lod::Cut> cut_;
  std::optional<storage::TetMesh> mesh_;  // the whole mesh, without a store
  storage::Bounds bounds_;
  std::optional<double> cut_estimated_error_;
  std::unique_ptr<const SceneMesh> scene_;
  std::string attribute_, iso_color_attribute_;      // the scene's
  uint64_t scene_generation_ = 0;         // unique over all pipelines of the process
};

}  // namespace tetrascope::renderer
