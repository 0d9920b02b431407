// probe.result: the scene of the session's still view under one pixel (renderer/probe.h), with
// every point attribute there.
#include "frame_maker.h"
#include "tetrascope/protocol/planes.h"
#include "tetrascope/renderer/probe.h"

namespace tetrascope::server {

std::string FrameMaker::probe(const ViewState& state, double x, double y, uint32_t id) {
  open(state.dataset);
  const renderer::RenderSettings settings = pipeline_->update(state.view);
  const renderer::SceneMesh& scene = pipeline_->scene();
  const renderer::ProbeHit hit = renderer::probe(scene, settings, x, y);
  protocol::ProbeResult r;
  r.hit = !hit.surface.empty();
  if (r.hit) {
    r.surface = hit.surface;
    r.position = hit.position;
    r.attribute = scene.attribute;
    if (scene.component != view::kMagnitude) r.component = std::string(view::kComponentNames[size_t(scene.component)]);
    r.value = hit.value;
    if (hit.iso_color_value) r.iso_color = {{scene.iso_color_attribute, *hit.iso_color_value}};
    // the unclipped scene's tets hold every point of the clipped one, with all attributes
    for (renderer::PointValue& v : renderer::values_at(pipeline_->unclipped_scene(), hit.position)) r.values.emplace_back(std::move(v.name), std::move(v.components));
  }
  return r.to_json(id).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace tetrascope::server
