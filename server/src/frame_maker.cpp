#include "frame_maker.h"

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "tetrascope/renderer/ray_caster.h"

namespace tetrascope::server {
namespace {

// After a frame this large (2048^2 and up: a big PNG still) the worker's renderer is made
// anew and its image buffers, tens of MB, are given back to the system. Mesa (llvmpipe) keeps
// the storage of a context's deleted framebuffers (~36 bytes a pixel: 150 MB after a 2600^2
// still) until the context goes; destroying it gives them back. The new context compiles its
// shaders again and the next frame uploads the scene again, once after such a still.
constexpr uint64_t kRenewAfterPixels = uint64_t{2048} * 2048;

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

// The smallest share of the view an interaction frame shrinks to when even the coarsest cut
// is over the frame time (a store built with a large coarsest level).
constexpr double kMinFrameScale = 0.125;
// Nor, when it shrinks, below this many pixels on its shorter side (or the interaction scale's
// size, when smaller): a phone's view is small in pixels already, and an eighth of it is a smear.
constexpr uint32_t kMinMovingSide = 200;
// A refinement step whose cut holds less than this share of its budget may hold all the view
// wants: the next step asks for the still budget (and is the last).
constexpr double kFullCutShare = 0.5;

// The smallest scale a moving frame of a width x height view is drawn at.
double min_moving_scale(uint32_t width, uint32_t height) { return std::min(1.0, double(kMinMovingSide) / std::max<uint32_t>(1, std::min(width, height))); }

uint32_t scaled(uint32_t side, double scale) { return std::max<uint32_t>(protocol::kMinImageSide, static_cast<uint32_t>(std::lround(side * scale))); }

}  // namespace

void warm_up(renderer::Renderer& r) {
  storage::TetMesh one;
  one.x = {0, 1, 0, 0};
  one.y = {0, 0, 1, 0};
  one.z = {0, 0, 0, 1};
  one.tets = {0, 1, 2, 3};
  storage::Attribute f;
  f.info.name = "f";
  f.values = {0, 1, 2, 3};
  one.attributes.push_back(std::move(f));
  const renderer::SceneMesh scene = renderer::SceneMesh::from(one, "f");
  r.set_mesh(scene);
  renderer::RenderSettings s;
  s.width = s.height = 8;
  r.render(s);
  r.release_memory();  // forgets the scene (render needs a set_mesh again)
}

RenderedFrame FrameMaker::render(const ViewState& state, const FramePlan& plan, const FrameCostModel& cost, const ServerOptions& options, Worker& worker,
                                 uint32_t frame_number) {
  RenderedFrame frame = render_frame(state, plan, cost, options, worker, frame_number);
  if (uint64_t{frame.header.width} * frame.header.height >= kRenewAfterPixels) {
    worker.renderer.reset();  // the old context goes first: its GL objects are deleted while it is current
    worker.scene_generation = 0;
    ::malloc_trim(0);  // the image is freed by now
    try {
      worker.renderer = renderer::Renderer::create();
      warm_up(*worker.renderer);
    } catch (const std::exception&) {
      // made at start already, so this should not fail; if it does, the next frame tries again
      // and reports what is missing
    }
  }
  return frame;
}

void FrameMaker::open(const std::shared_ptr<Dataset>& dataset) {
  if (!dataset) throw std::logic_error("a frame of no dataset");  // the session checks first; never a null dereference
  if (dataset_ == dataset && pipeline_) return;
  // the pipeline first: when it cannot be made (a damaged variants.bin) nothing is half set,
  // and the next frame of this dataset tries again rather than drawing with no pipeline
  dataset_.reset();
  pipeline_.reset();
  auto pipeline = std::make_unique<renderer::ViewPipeline>(*dataset->store, *dataset->dag, *dataset->cache, dataset->vertices);
  pipeline->set_regions(dataset->regions);
  coarsest_tets_ = lod::Cut(*dataset->dag).tet_count();
  finest_tets_ = dataset->info.value("tets", uint64_t{0});
  pipeline_ = std::move(pipeline);
  dataset_ = dataset;
}

RenderedFrame FrameMaker::render_frame(const ViewState& state, const FramePlan& plan, const FrameCostModel& cost, const ServerOptions& options, Worker& worker,
                                       uint32_t frame_number) {
  const auto start = Clock::now();
  if (!worker.renderer) worker.renderer = renderer::Renderer::create();
  open(state.dataset);
  if (state.dataset->steps) {  // the step's segments and values (checked as they are read: damage closes the dataset)
    pipeline_->set_step(state.time_step, state.dataset->step_cache(state.time_step), state.dataset->steps->values(state.time_step));
  }
  view::ViewRequest request = state.view;
  const view::Camera camera = request.camera ? *request.camera : view::default_camera(pipeline_->bounds());
  const uint64_t still_budget = std::max<uint64_t>(state.view.budget, 1);
  RenderedFrame frame;
  bool final_step = false;
  if (!plan.refinement) {
    // the most tets within frame_ms at this size; where even the coarsest cut is over, fewer pixels
    // (the frame's size from the configured frame time; a share of it, with many sessions
    // waiting, lowers the tets only)
    const double target_ms = plan.frame_ms > 0 ? plan.frame_ms : options.frame_ms;
    double scale = state.interaction_scale;
    request.width = scaled(state.view.width, scale);
    request.height = scaled(state.view.height, scale);
    frame.covered_pixels = covered_pixels(camera, pipeline_->bounds(), request.width, request.height);
    if (frame.covered_pixels > 0 && cost.predict(double(coarsest_tets_), frame.covered_pixels) > options.frame_ms) {
      const double fits = cost.pixels_for(options.frame_ms, double(coarsest_tets_));
      const double floor_scale = std::min(scale, min_moving_scale(state.view.width, state.view.height));
      scale = std::max({kMinFrameScale, floor_scale, scale * std::sqrt(std::max(fits, 1.0) / frame.covered_pixels)});
      request.width = scaled(state.view.width, scale);
      request.height = scaled(state.view.height, scale);
      frame.covered_pixels = covered_pixels(camera, pipeline_->bounds(), request.width, request.height);
    }
    request.budget = cost.tets_for(target_ms, frame.covered_pixels, coarsest_tets_, state.interaction_budget);
    request.moving = true;
  } else {
    // step k aims at frame_ms * growth^(k+1), at least twice the step before, up to the still budget
    frame.covered_pixels = covered_pixels(camera, pipeline_->bounds(), request.width, request.height);
    const double target_ms = options.frame_ms * std::pow(options.refine_growth, plan.step + 1);
    uint64_t tets = cost.tets_for(target_ms, frame.covered_pixels, coarsest_tets_, still_budget);
    tets = std::min(still_budget, std::max(tets, 2 * plan.previous_budget));
    request.budget = tets;
    final_step = tets >= still_budget;
  }
  frame.budget = request.budget;
  renderer::RenderSettings settings = pipeline_->update(request, &frame.timings, plan.refinement ? plan.should_stop : std::function<bool()>());
  if (frame.timings.interrupted) {  // input came during the reassembly: no scene, no draw
    frame.interrupted = true;
    return frame;
  }
  const uint64_t tets = pipeline_->scene().tets.size() / 4;
  // the model's forecast for the cut it got (a view-adaptive cut may hold fewer tets than its
  // budget: that is the cut's doing, not a cost the model failed to predict)
  frame.predicted_ms = cost.predict(double(tets), frame.covered_pixels);
  const double estimated_error = pipeline_->cut_estimated_error().value_or(0);
  if (plan.refinement && !final_step) {
    // the last step: the error bound is met, or the cut holds the whole dataset
    final_step = (state.max_error > 0 && estimated_error <= state.max_error) || !pipeline_->cut() || tets >= finest_tets_;
    // A cut that did not use its budget may hold all the view wants, or its next refinement
    // did not fit: the next step asks for the still budget. So the still is the cut at the
    // still budget whatever steps led to it (RefinementTest.TheStillIsTheSameWhateverTheStepsBefore);
    // taking this step for the still made it depend on the step sizes, and so on the load.
    if (!final_step && double(tets) < kFullCutShare * double(request.budget)) frame.budget = still_budget;
  }
  settings.should_stop = plan.should_stop;
  if (state.background) settings.background = *state.background;
  if (plan.should_stop && plan.should_stop()) {  // input came during the cut update and assembly: no upload, no draw
    frame.interrupted = true;
    return frame;
  }
  const bool cast = worker.cpu && renderer::RayCaster::unsupported(settings).empty();
  const renderer::Image image = cast ? pipeline_->cast(settings, &frame.timings) : pipeline_->draw(settings, *worker.renderer, worker.scene_generation, &frame.timings);
  if (frame.timings.draw.interrupted) {
    frame.interrupted = true;
    return frame;
  }
  const double render_ms = ms_since(start);

  const auto encode_start = Clock::now();
  const bool still = plan.refinement && final_step;
  const bool png = still && state.png_stills;
  const std::vector<uint8_t> payload = png ? renderer::encode_png(image) : renderer::encode_jpeg(image, plan.refinement ? state.still_quality : state.interaction_quality);
  protocol::FrameHeader& h = frame.header;
  h.frame_number = frame_number;
  h.message_id = state.message_id;
  h.width = image.width;
  h.height = image.height;
  h.codec = png ? protocol::Codec::kPng : protocol::Codec::kJpeg;
  h.still = still;
  h.refining = plan.refinement && !final_step;
  h.tets = tets;
  h.estimated_error = static_cast<float>(estimated_error);
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
