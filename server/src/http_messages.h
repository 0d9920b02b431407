// What every HTTP handler speaks: the parsed request target and the response builders. Error
// replies are JSON {"error": {"code", "message"}} (protocol/openapi.yaml).
#pragma once

#include <map>
#include <string>
#include <string_view>

#include <boost/beast/http.hpp>
#include <nlohmann/json.hpp>

namespace tetrascope::server {

namespace http = boost::beast::http;

using Response = http::response<http::string_body>;
using StringRequest = http::request<http::string_body>;
// The header part of any request (the parsers' bodies differ: empty, string, file).
using RequestHeader = http::request_header<>;

// A request target split into its percent-decoded path and query. The target is untrusted:
// malformed escapes are kept as they are.
struct Target {
  std::string path;
  std::map<std::string, std::string> query;
};
Target parse_target(std::string_view target);

// Whom a response answers: the request's HTTP version and keep-alive.
struct ReplyTo {
  unsigned version = 11;
  bool keep_alive = false;
};
template <class Body>
ReplyTo reply_to(const http::request<Body>& request) {
  return {request.version(), request.keep_alive()};
}

// Responses are never cached.
Response make_response(ReplyTo to, http::status status, std::string body, const std::string& content_type);
Response json_response(ReplyTo to, http::status status, const nlohmann::json& body);
Response error_response(ReplyTo to, http::status status, const std::string& code, const std::string& message);

template <class Body>
Response make_response(const http::request<Body>& request, http::status status, std::string body, const std::string& content_type) {
  return make_response(reply_to(request), status, std::move(body), content_type);
}
template <class Body>
Response json_response(const http::request<Body>& request, http::status status, const nlohmann::json& body) {
  return json_response(reply_to(request), status, body);
}
template <class Body>
Response error_response(const http::request<Body>& request, http::status status, const std::string& code, const std::string& message) {
  return error_response(reply_to(request), status, code, message);
}

}  // namespace tetrascope::server
