// Static files: the web client at /, the protocol codec, schemas and OpenAPI spec at
// /protocol/ (and the spec at /api/v1/openapi.yaml). Paths are untrusted and resolved inside
// their root (resolve_inside).
#include <fstream>
#include <sstream>

#include "rest.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;

std::string mime_type(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json") return "application/json";
  if (ext == ".yaml") return "application/yaml";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  return "application/octet-stream";
}

Response file_response(ReplyTo request, const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return error_response(request, http::status::not_found, "not_found", "no file " + file.filename().string());
  std::ifstream in(file, std::ios::binary);
  std::ostringstream content;
  content << in.rdbuf();
  return make_response(request, http::status::ok, content.str(), mime_type(file));
}

Response file_inside(ReplyTo request, const fs::path& root, const std::string& relative) {
  auto file = resolve_inside(root, relative);
  if (!file) return error_response(request, http::status::not_found, "not_found", "no file /" + relative);
  return file_response(request, *file);
}

}  // namespace

Response get_openapi(const RestRequest& r) { return file_response(reply_to(r.request), r.server.options.protocol_root / "openapi.yaml"); }

Response get_protocol_file(const RestRequest& r) {
  // only what the browser needs of protocol/
  const std::string& rest = r.tail;
  if (rest.rfind("js/", 0) != 0 && rest.rfind("schema/", 0) != 0 && rest != "openapi.yaml")
    return error_response(r.request, http::status::not_found, "not_found", "no file " + r.target.path);
  return file_inside(reply_to(r.request), r.server.options.protocol_root, rest);
}

Response get_web_file(const RestRequest& r) { return file_inside(reply_to(r.request), r.server.options.web_root, r.tail); }

}  // namespace tetrascope::server
