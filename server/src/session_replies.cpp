#include "session_replies.h"

#include <cmath>

#include "tetrascope/renderer/render.h"

namespace tetrascope::server {
namespace {

constexpr int kColormapSamples = 32;

double three_decimals(double v) { return std::round(v * 1000) / 1000; }

nlohmann::json colormap_samples() {
  nlohmann::json colormaps = nlohmann::json::object();
  for (const std::string_view known : protocol::kColormapNames) {
    const std::string name(known);
    nlohmann::json samples = nlohmann::json::array();
    for (int i = 0; i < kColormapSamples; ++i) {
      const auto rgb = renderer::colormap(name, i / double(kColormapSamples - 1));
      samples.push_back({three_decimals(rgb[0]), three_decimals(rgb[1]), three_decimals(rgb[2])});
    }
    colormaps[name] = samples;
  }
  return colormaps;
}

}  // namespace

std::string hello_ok_reply(const ServerOptions& o, const std::string& renderer, uint32_t id) {
  const auto& l = o.limits;
  return nlohmann::json({{"type", "hello.ok"},
                         {"id", id},
                         {"version", protocol::kVersion},
                         {"server", "tetrascope"},
                         {"renderer", renderer},
                         {"limits",
                          {{"max_message_bytes", l.max_message_bytes},
                           {"max_messages_per_second", l.max_messages_per_second},
                           {"max_image_side", l.max_image_side},
                           {"max_isovalues", l.max_isovalues},
                           {"max_tf_points", l.max_tf_points}}},
                         {"colormaps", colormap_samples()},
                         {"defaults",
                          {{"budget", o.still_budget},
                           {"interaction_budget", o.interaction_budget},
                           {"interaction_quality", o.interaction_quality},
                           {"still_quality", o.still_quality},
                           {"max_fps", o.max_fps},
                           {"still_delay_ms", o.still_delay.count()},
                           {"frame_ms", o.frame_ms}}}})
      .dump();
}

std::string dataset_info_reply(const Dataset& dataset, const view::Camera& camera, uint32_t id) {
  nlohmann::json info = dataset.info;
  info["type"] = "dataset.info";
  info["id"] = id;
  info["camera"] = {{"eye", camera.eye}, {"target", camera.target}, {"up", camera.up}, {"fov", camera.fov_degrees}};
  return info.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace tetrascope::server
