// What one viewing session asked for (ViewState) and how its frames are made (FrameMaker:
// the session's own ViewPipeline over the dataset's store, drawn by whichever pool worker
// runs the session's turn, encoded and prefixed with the frame header).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "datasets.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/renderer/view_frame.h"

namespace tetrascope::server {

struct ViewState {
  std::shared_ptr<Dataset> dataset;
  renderer::ViewRequest view;   // budget: of still frames; no camera: the dataset's default view
  uint64_t interaction_budget = 0;
  int interaction_quality = 60, still_quality = 90;
  bool png_stills = false;
  double interaction_scale = 1;  // of the view size, for interaction frames
  uint32_t message_id = 0;       // the last control message applied
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
  renderer::ViewTimings timings;
};

class FrameMaker {
 public:
  // Renders the newest state (still: the full budget, quality and size, else the interaction
  // ones) and encodes it. Throws std::invalid_argument for requests the dataset cannot satisfy.
  RenderedFrame render(const ViewState& state, bool still, Worker& worker, uint32_t frame_number);
  // The probe.result reply (JSON) for pixel (x, y) of the still view of `state` (frame_probe.cpp).
  std::string probe(const ViewState& state, double x, double y, uint32_t id);

 private:
  // render() without the memory return of large frames (malloc_trim after 2048^2 pixels and up)
  RenderedFrame render_frame(const ViewState& state, bool still, Worker& worker, uint32_t frame_number);
  std::shared_ptr<Dataset> dataset_;  // the pipeline's
  std::unique_ptr<renderer::ViewPipeline> pipeline_;
};

}  // namespace tetrascope::server
