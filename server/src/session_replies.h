// The JSON replies of a viewing session that carry more than an id: hello.ok (limits,
// colormaps, defaults) and dataset.info.
#pragma once

#include <cstdint>
#include <string>

#include "datasets.h"
#include "tetrascope/view/camera.h"
#include "tetrascope/view/transfer_function.h"
#include "tetrascope/server/server.h"

namespace tetrascope::server {

// hello.ok: what this server accepts (limits), the colormaps sampled for the client's legend
// and editor, and the session defaults.
std::string hello_ok_reply(const ServerOptions& options, const std::string& renderer, uint32_t id);

// dataset.info: the dataset's info (datasets.h) and the camera it opens with.
std::string dataset_info_reply(const Dataset& dataset, const view::Camera& opening, uint32_t id);

}  // namespace tetrascope::server
