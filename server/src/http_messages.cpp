#include "http_messages.h"

#include <cctype>

namespace tetrascope::server {
namespace {

int hex_digit(char c) { return std::isdigit(static_cast<unsigned char>(c)) ? c - '0' : std::tolower(static_cast<unsigned char>(c)) - 'a' + 10; }

std::string percent_decode(std::string_view in) {
  std::string out;
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '%' && i + 2 < in.size() && std::isxdigit(static_cast<unsigned char>(in[i + 1])) && std::isxdigit(static_cast<unsigned char>(in[i + 2]))) {
      out += static_cast<char>(hex_digit(in[i + 1]) * 16 + hex_digit(in[i + 2]));
      i += 2;
    } else {
      out += in[i] == '+' ? ' ' : in[i];
    }
  }
  return out;
}

}  // namespace

Target parse_target(std::string_view target) {
  Target t;
  const size_t q = target.find('?');
  t.path = percent_decode(target.substr(0, q));
  if (q == std::string_view::npos) return t;
  std::string_view rest = target.substr(q + 1);
  while (!rest.empty()) {
    const size_t amp = rest.find('&');
    std::string_view item = rest.substr(0, amp);
    const size_t eq = item.find('=');
    t.query[percent_decode(item.substr(0, eq))] = eq == std::string_view::npos ? "" : percent_decode(item.substr(eq + 1));
    if (amp == std::string_view::npos) break;
    rest = rest.substr(amp + 1);
  }
  return t;
}

Response make_response(ReplyTo to, http::status status, std::string body, const std::string& content_type) {
  Response r{status, to.version};
  r.set(http::field::server, "tetrascope");
  r.set(http::field::content_type, content_type);
  r.set(http::field::cache_control, "no-store");
  r.keep_alive(to.keep_alive);
  r.body() = std::move(body);
  r.prepare_payload();
  return r;
}

Response json_response(ReplyTo to, http::status status, const nlohmann::json& body) {
  return make_response(to, status, body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "application/json");
}

Response error_response(ReplyTo to, http::status status, const std::string& code, const std::string& message) {
  return json_response(to, status, {{"error", {{"code", code}, {"message", message}}}});
}

}  // namespace tetrascope::server
