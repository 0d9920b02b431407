// probe.result: the scene of the session's still view under one pixel (renderer/probe.h).
#include <nlohmann/json.hpp>

#include "frame_maker.h"
#include "tetrascope/renderer/probe.h"

namespace tetrascope::server {

std::string FrameMaker::probe(const ViewState& state, double x, double y, uint32_t id) {
  if (dataset_ != state.dataset) {
    dataset_ = state.dataset;
    pipeline_ = std::make_unique<renderer::ViewPipeline>(*dataset_->store, *dataset_->dag, *dataset_->cache);
  }
  const renderer::RenderSettings settings = pipeline_->update(state.view);
  const renderer::SceneMesh& scene = pipeline_->scene();
  const renderer::ProbeHit hit = renderer::probe(scene, settings, x, y);
  nlohmann::json j = {{"type", "probe.result"}, {"id", id}, {"hit", !hit.surface.empty()}};
  if (!hit.surface.empty()) {
    j["surface"] = hit.surface;
    j["position"] = hit.position;
    j["attribute"] = scene.attribute;
    j["value"] = hit.value;
    if (hit.iso_color_value) {
      j["iso_color_attribute"] = scene.iso_color_attribute;
      j["iso_color_value"] = *hit.iso_color_value;
    }
  }
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace tetrascope::server
