// GET and POST /api/v1/jobs, GET and DELETE /api/v1/jobs/ID: preprocessing jobs (jobs.h).
#include "rest.h"

namespace tetrascope::server {
namespace {

Response job_or_404(const RestRequest& r, const std::optional<nlohmann::json>& job) {
  if (!job) return error_response(r.request, http::status::not_found, "not_found", "no job '" + r.tail + "'");
  return json_response(r.request, http::status::ok, *job);
}

}  // namespace

Response list_jobs(const RestRequest& r) {
  return json_response(r.request, http::status::ok, {{"jobs", r.server.jobs ? r.server.jobs->list() : nlohmann::json::array()}});
}

Response submit_job(const RestRequest& r) {
  const nlohmann::json body = nlohmann::json::parse(r.request.body(), nullptr, false);
  if (body.is_discarded()) return error_response(r.request, http::status::bad_request, "bad_request", "the body is not JSON");
  return json_response(r.request, http::status::accepted, r.server.jobs->submit(body));
}

Response get_job(const RestRequest& r) { return job_or_404(r, r.server.jobs ? r.server.jobs->get(r.tail) : std::nullopt); }

Response cancel_job(const RestRequest& r) { return job_or_404(r, r.server.jobs->cancel(r.tail)); }

}  // namespace tetrascope::server
