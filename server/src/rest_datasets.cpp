// GET /api/v1/datasets and GET /api/v1/datasets/NAME.
#include "rest.h"

namespace tetrascope::server {

Response list_datasets(const RestRequest& r) { return json_response(r.request, http::status::ok, {{"datasets", r.server.datasets->list()}}); }

Response get_dataset(const RestRequest& r) {
  try {
    return json_response(r.request, http::status::ok, r.server.datasets->open(r.tail)->info);
  } catch (const NotFound& e) {
    return error_response(r.request, http::status::not_found, "not_found", e.what());
  } catch (const std::exception& e) {
    return error_response(r.request, http::status::conflict, "not_viewable", e.what());
  }
}

}  // namespace tetrascope::server
