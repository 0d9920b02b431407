#include "same_origin.h"

#include <algorithm>
#include <cctype>

namespace tetrascope::server {
namespace {

std::string lower(std::string_view text) {
  std::string s(text);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// "host[:port]" or "[v6]:port" without the port.
std::string_view strip_port(std::string_view host) {
  if (!host.empty() && host.front() == '[') {
    const size_t close = host.find(']');
    if (close == std::string_view::npos) return {};
    std::string_view rest = host.substr(close + 1);
    if (!rest.empty() && (rest.front() != ':' || rest.size() == 1 || rest.find_first_not_of("0123456789", 1) != std::string_view::npos)) return {};
    return host.substr(0, close + 1);
  }
  const size_t colon = host.find(':');
  if (colon == std::string_view::npos) return host;
  std::string_view port = host.substr(colon + 1);
  if (port.empty() || port.find_first_not_of("0123456789") != std::string_view::npos) return {};
  return host.substr(0, colon);
}

bool is_ipv4_loopback(std::string_view name) {
  // 127.a.b.c, four decimal parts 0-255
  if (name.rfind("127.", 0) != 0) return false;
  int parts = 0;
  size_t at = 0;
  while (at <= name.size()) {
    size_t dot = name.find('.', at);
    if (dot == std::string_view::npos) dot = name.size();
    std::string_view part = name.substr(at, dot - at);
    if (part.empty() || part.size() > 3 || part.find_first_not_of("0123456789") != std::string_view::npos || std::stoi(std::string(part)) > 255) return false;
    ++parts;
    at = dot + 1;
  }
  return parts == 4;
}

}  // namespace

bool is_loopback_host(std::string_view host) {
  const std::string name = lower(strip_port(host));
  return name == "localhost" || name == "[::1]" || is_ipv4_loopback(name);
}

std::optional<Refusal> check_same_origin(const RequestHeader& request, bool api) {
  const std::string_view host = request[http::field::host];
  if (!is_loopback_host(host)) {
    return Refusal{http::status::forbidden, "forbidden_host",
                   "Host '" + std::string(host.substr(0, 100)) +
                       "' is not this machine: without a --token the server answers only requests for localhost, 127.x.x.x or [::1]"};
  }
  const std::string_view origin = request[http::field::origin];
  if (!origin.empty()) {
    const std::string want = lower(host), got = lower(origin);
    if (got != "http://" + want && got != "https://" + want) {
      return Refusal{http::status::forbidden, "cross_origin",
                     "Origin '" + std::string(origin.substr(0, 100)) + "' is not this server (" + std::string(host) +
                         "): without a --token only the server's own pages may call it"};
    }
  }
  const http::verb method = request.method();
  if (api && method != http::verb::get && method != http::verb::head) {
    const std::string type = lower(request[http::field::content_type]);
    const bool json = type.rfind("application/json", 0) == 0;
    if (!json && request.find(kIntentHeader) == request.end()) {
      return Refusal{http::status::forbidden, "missing_intent",
                     "a request that changes something needs Content-Type: application/json or the header X-Tetrascope: 1"};
    }
  }
  return std::nullopt;
}

}  // namespace tetrascope::server
