// What one viewing session asked for (ViewState) and how its frames are made (FrameMaker:
// the session's own ViewPipeline over the dataset's store, drawn by whichever pool worker
// runs the session's turn, encoded and prefixed with the frame header).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "datasets.h"
#include "tetrascope/server/frame_cost.h"
#include "tetrascope/server/server.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/renderer/view_frame.h"

namespace tetrascope::server {

struct ViewState {
  std::shared_ptr<Dataset> dataset;
  view::ViewRequest view;   // budget: of still frames; no camera: the dataset's default view
  uint64_t interaction_budget = 0;
  double max_error = 0;         // > 0: refinement ends once the cut's estimated error is at most this
  int interaction_quality = 60, still_quality = 90;
  bool png_stills = false;
  double interaction_scale = 1;  // of the view size, for interaction frames
  std::optional<std::array<float, 3>> background;  // mode.set's; none: the renderer's
  uint32_t message_id = 0;       // the last control message applied
  uint32_t time_step = 0;        // time.set's (0 for a dataset of one step)
  std::optional<uint32_t> prefetch_step;  // time.set's: the step shown next (play)
};

// One render context of the pool, and which scene it holds (by generation, so a scene is
// uploaded again only when it changed or another session's scene was drawn in between).
struct Worker {
  std::unique_ptr<renderer::Renderer> renderer;
  uint64_t scene_generation = 0;
  bool cpu = false;  // volumes by the CPU ray caster (RenderPool's backend), the rest by renderer
};

// Warms a render worker's new renderer up: one tet drawn into an 8x8 view, so that Mesa
// compiles the volume pass's shader variants now rather than in a client's first frame
// (measured: about 75 ms of CPU off that frame on llvmpipe). Leaves no scene set.
void warm_up(renderer::Renderer& renderer);

struct RenderedFrame {
  std::vector<uint8_t> bytes;  // header + image; empty when the frame was interrupted
  protocol::FrameHeader header;
  renderer::ViewTimings timings;
  bool interrupted = false;    // should_stop stopped it: nothing to send
  double predicted_ms = 0;     // the cost model's forecast for it (0: none)
  double covered_pixels = 0;   // of the dataset's box on screen, at the frame's size
  uint64_t budget = 0;         // the tets it was planned with
};

// What a frame should be: an interaction frame (tets and size from the cost model, within
// the interaction budget and scale) or refinement step `step` (full size, still quality;
// the last one is the still).
struct FramePlan {
  bool refinement = false;
  uint32_t step = 0;
  uint64_t previous_budget = 0;        // of the step before (refinement): this one's is at least twice it
  std::function<bool()> should_stop;   // empty: never
  double frame_ms = 0;                 // interaction: the time to aim at (0: options.frame_ms)
};

class FrameMaker {
 public:
  // Renders the newest state as `plan` says and encodes it. Throws std::invalid_argument for
  // requests the dataset cannot satisfy.
  RenderedFrame render(const ViewState& state, const FramePlan& plan, const FrameCostModel& cost, const ServerOptions& options, Worker& worker,
                       uint32_t frame_number);
  // The probe.result reply (JSON) for pixel (x, y) of the still view of `state` (frame_probe.cpp).
  std::string probe(const ViewState& state, double x, double y, uint32_t id);

 private:
  // render() without the memory return of large frames (a new renderer after 2048^2 pixels and up)
  RenderedFrame render_frame(const ViewState& state, const FramePlan& plan, const FrameCostModel& cost, const ServerOptions& options, Worker& worker,
                             uint32_t frame_number);
  void open(const std::shared_ptr<Dataset>& dataset);
  std::shared_ptr<Dataset> dataset_;  // the pipeline's
  std::unique_ptr<renderer::ViewPipeline> pipeline_;
  uint64_t coarsest_tets_ = 0;        // of the dataset's coarsest cut
  uint64_t finest_tets_ = 0;          // of the whole dataset
};

}  // namespace tetrascope::server
