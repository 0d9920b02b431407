// The routing table of the HTTP side: method and path (exact, or a prefix whose rest the
// handler reads) to one handler function.
#include <array>

#include "rest.h"

namespace tetrascope::server {
namespace {

struct Route {
  http::verb method;
  std::string_view path;
  bool prefix;  // the path is a prefix; the rest is RestRequest::tail
  Response (*handler)(const RestRequest&);
};

constexpr std::array kRoutes{
    Route{http::verb::get, "/api/v1/health", false, get_health},
    Route{http::verb::get, "/metrics", false, get_metrics},
    Route{http::verb::get, "/api/v1/openapi.yaml", false, get_openapi},
    Route{http::verb::get, "/api/v1/datasets", false, list_datasets},
    Route{http::verb::get, "/api/v1/datasets/", true, get_dataset},
    Route{http::verb::delete_, "/api/v1/datasets/", true, delete_dataset},
    Route{http::verb::get, "/api/v1/uploads", false, list_uploads},
    Route{http::verb::delete_, "/api/v1/uploads/", true, delete_upload},
    Route{http::verb::get, "/api/v1/jobs", false, list_jobs},
    Route{http::verb::post, "/api/v1/jobs", false, submit_job},
    Route{http::verb::get, "/api/v1/jobs/", true, get_job},
    Route{http::verb::delete_, "/api/v1/jobs/", true, cancel_job},
};

bool is_api(const std::string& path) { return path.rfind("/api/", 0) == 0; }

Response route(Server::Impl& server, const Target& target, const StringRequest& request) {
  const std::string& path = target.path;
  if (server.options.read_only && is_api(path) && request.method() != http::verb::get && request.method() != http::verb::head) return read_only_refusal(reply_to(request));
  for (const Route& r : kRoutes) {
    if (r.method != request.method()) continue;
    if (r.prefix ? path.rfind(r.path, 0) == 0 : path == r.path) return r.handler({server, target, request, path.substr(r.prefix ? r.path.size() : path.size())});
  }
  if (is_api(path)) return error_response(request, http::status::not_found, "not_found", "no endpoint " + std::string(request.method_string()) + " " + path);
  if (request.method() != http::verb::get && request.method() != http::verb::head)
    return error_response(request, http::status::method_not_allowed, "method_not_allowed", "static files are GET only");
  if (path.rfind("/protocol/", 0) == 0) return get_protocol_file({server, target, request, path.substr(10)});
  return get_web_file({server, target, request, path == "/" ? "index.html" : path.substr(1)});
}

}  // namespace

Response read_only_refusal(ReplyTo to) {
  return error_response(to, http::status::forbidden, "read_only",
                        "this server is a read-only replica: uploads, jobs and deletes go to the writer (docs/deploy.md)");
}

std::string route_class(const std::string& path) {
  for (const char* name : {"health", "openapi", "datasets", "uploads", "jobs", "session"}) {
    const std::string prefix = std::string("/api/v1/") + name;
    if (path.rfind(prefix, 0) == 0 && (path.size() == prefix.size() || path[prefix.size()] == '/' || path[prefix.size()] == '.')) return name;
  }
  if (path == "/metrics") return "metrics";
  return is_api(path) ? "api_other" : "static";
}

Response handle_request(Server::Impl& server, const Target& target, const StringRequest& request) {
  try {
    return route(server, target, request);
  } catch (const BadRequest& e) {
    return error_response(request, static_cast<http::status>(e.status()), e.code(), e.what());
  } catch (const std::exception& e) {  // a filesystem_error names paths: none reaches the client
    return error_response(request, http::status::internal_server_error, "internal", without_server_paths(e.what(), server.options.data_dir));
  }
}

}  // namespace tetrascope::server
