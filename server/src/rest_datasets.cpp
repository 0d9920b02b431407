// GET /api/v1/datasets, GET and DELETE /api/v1/datasets/NAME (with its source upload).
#include "rest.h"

namespace tetrascope::server {

Response list_datasets(const RestRequest& r) { return json_response(r.request, http::status::ok, {{"datasets", r.server.datasets->list()}}); }

Response get_dataset(const RestRequest& r) {
  try {
    return json_response(r.request, http::status::ok, r.server.datasets->open(r.tail)->info);
  } catch (const NotFound& e) {
    return error_response(r.request, http::status::not_found, "not_found", e.what());
  } catch (const DatasetDamaged& e) {
    return error_response(r.request, http::status::conflict, "dataset_damaged", e.what());
  } catch (const std::exception& e) {
    return error_response(r.request, http::status::conflict, "not_viewable", e.what());
  }
}

Response delete_dataset(const RestRequest& r) {
  try {
    const auto source = source_upload_of(r.server, r.tail);  // before the remove: the store's existence names the job
    const size_t sessions = r.server.datasets->remove(r.tail);
    const auto upload = source ? remove_source_upload(r.server, *source) : std::nullopt;
    return json_response(r.request, http::status::ok,
                         {{"deleted", r.tail}, {"sessions_closed", sessions}, {"upload_deleted", upload ? nlohmann::json(*upload) : nlohmann::json(nullptr)}});
  } catch (const NotFound& e) {
    return error_response(r.request, http::status::not_found, "not_found", e.what());
  }
}

}  // namespace tetrascope::server
