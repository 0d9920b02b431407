#include "frame_maker.h"

#include <chrono>
#include <cmath>

namespace tetrascope::server {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

uint32_t scaled(uint32_t side, double scale) { return std::max<uint32_t>(protocol::kMinImageSide, static_cast<uint32_t>(std::lround(side * scale))); }

}  // namespace

RenderedFrame FrameMaker::render(const ViewState& state, bool still, Worker& worker, uint32_t frame_number) {
  const auto start = Clock::now();
  if (dataset_ != state.dataset) {
    dataset_ = state.dataset;
    pipeline_ = std::make_unique<renderer::ViewPipeline>(*dataset_->store, *dataset_->dag, *dataset_->cache);
  }
  renderer::ViewRequest request = state.view;
  const double scale = still ? 1.0 : state.interaction_scale;
  request.width = scaled(state.view.width, scale);
  request.height = scaled(state.view.height, scale);
  if (!still) request.budget = state.interaction_budget;
  RenderedFrame frame;
  const renderer::ViewFrame view = pipeline_->render(request, *worker.renderer, worker.scene_generation);
  frame.timings = view.timings;
  const double render_ms = ms_since(start);

  const auto encode_start = Clock::now();
  const bool png = still && state.png_stills;
  const std::vector<uint8_t> payload = png ? renderer::encode_png(view.image) : renderer::encode_jpeg(view.image, still ? state.still_quality : state.interaction_quality);
  protocol::FrameHeader& h = frame.header;
  h.frame_number = frame_number;
  h.message_id = state.message_id;
  h.width = view.image.width;
  h.height = view.image.height;
  h.codec = png ? protocol::Codec::kPng : protocol::Codec::kJpeg;
  h.still = still;
  h.tets = view.tets;
  h.render_ms = static_cast<float>(render_ms);
  h.encode_ms = static_cast<float>(ms_since(encode_start));
  h.payload_bytes = static_cast<uint32_t>(payload.size());
  const auto header = protocol::encode_frame_header(h);
  frame.bytes.reserve(header.size() + payload.size());
  frame.bytes.insert(frame.bytes.end(), header.begin(), header.end());
  frame.bytes.insert(frame.bytes.end(), payload.begin(), payload.end());
  return frame;
}

}  // namespace tetrascope::server
