// What one viewing session asked for (ViewState) and how a frame of it is made
// (ViewRenderer: the session's own cut through the dataset's DAG, the scene assembled from
// it, rendered by whichever pool worker runs the session's turn).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "datasets.h"
#include "tetrascope/lod/cut.h"
#include "tetrascope/lod/view.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::server {

struct ViewState {
  std::shared_ptr<Dataset> dataset;
  lod::Camera camera;
  bool camera_set = false;  // else the default view of the dataset
  lod::TransferFunction tf;
  bool dvr = true, iso = false, surface = false, wireframe = false, box = false;
  std::vector<double> isovalues;  // attribute units; empty: mid-range
  double iso_opacity = 1;
  std::string color_by;
  uint64_t budget = 0, interaction_budget = 0;
  uint32_t width = 1024, height = 768;
  int interaction_quality = 60, still_quality = 90;
  bool png_stills = false;
  double interaction_scale = 1;
  uint32_t message_id = 0;  // the last control message applied
};

// One render context of the pool, and which scene it holds (by generation, so a scene is
// uploaded again only when it changed or another session's scene was drawn in between).
struct Worker {
  std::unique_ptr<renderer::Renderer> renderer;
  uint64_t scene_generation = 0;
};

struct RenderedFrame {
  std::vector<uint8_t> bytes;  // header + image
  protocol::FrameHeader header;
  // where the render time went: cut update, assembly of the cut's mesh and scene (0 when the
  // cut did not change), upload to the worker's context (0 when it held the scene), drawing
  // and readback
  double cut_ms = 0, assemble_ms = 0, upload_ms = 0, draw_ms = 0;
};

// The view a dataset opens with: from azimuth 30°, elevation 20°, far enough (1.95 box
// diagonals) for the whole bounding sphere to fit the 30° field of view.
lod::Camera opening_camera(const storage::Bounds& bounds);

class ViewRenderer {
 public:
  // Updates the cut for the view (still: the full budget, else the interaction budget),
  // reassembles the scene when the cut changed and renders. Throws std::invalid_argument
  // for requests the dataset cannot satisfy (unknown attribute, colormap).
  RenderedFrame render(const ViewState& state, bool still, Worker& worker, uint32_t frame_number);

 private:
  std::shared_ptr<Dataset> dataset_;
  std::unique_ptr<lod::Cut> cut_;
  std::string attribute_, second_;
  std::shared_ptr<const renderer::SceneMesh> scene_;
  uint64_t scene_generation_ = 0;
};

}  // namespace tetrascope::server
