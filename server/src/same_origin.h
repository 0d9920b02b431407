// Without a token the server trusts its machine, so it must not be driven by a web page from
// somewhere else that the user happens to open (cross-site request forgery, DNS rebinding).
// As Jupyter does, it then serves only same-origin requests for a loopback name:
//   - Host is localhost, 127.x.x.x or [::1] (with or without a port): a rebound DNS name is not;
//   - Origin, when present (browsers send it on cross-origin requests and WebSocket
//     upgrades), names that same host and port;
//   - a state-changing API call (anything but GET/HEAD) carries Content-Type: application/json
//     or X-Tetrascope: 1, which a cross-site form or simple request cannot send without a
//     CORS preflight this server never grants.
// With a token none of this applies: the token is the authority (Authorization: Bearer).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "http_messages.h"

namespace tetrascope::server {

constexpr std::string_view kIntentHeader = "X-Tetrascope";  // any value; "1" by convention

struct Refusal {
  http::status status;
  std::string code, message;
};

// Whether the Host header names this machine's loopback interface.
bool is_loopback_host(std::string_view host);
// The refusal for a request that fails the rules above (token-less mode), or nothing.
std::optional<Refusal> check_same_origin(const RequestHeader& request, bool api);

}  // namespace tetrascope::server
