#include "tetrascope/server/client.h"

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace tetrascope::server {
namespace {
namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
}  // namespace

ParsedUrl parse_url(const std::string& url) {
  const size_t scheme = url.find("://");
  if (scheme == std::string::npos) throw std::invalid_argument("url " + url + ": expected ws://HOST:PORT/PATH");
  const std::string rest = url.substr(scheme + 3);
  const size_t slash = rest.find('/');
  const std::string authority = rest.substr(0, slash);
  ParsedUrl p;
  p.target = slash == std::string::npos ? "/" : rest.substr(slash);
  const size_t colon = authority.rfind(':');
  if (colon == std::string::npos) {
    p.host = authority;
    p.port = "80";
  } else {
    p.host = authority.substr(0, colon);
    p.port = authority.substr(colon + 1);
  }
  if (p.host.empty() || p.port.empty()) throw std::invalid_argument("url " + url + ": no host or port");
  return p;
}

struct SessionClient::Impl {
  net::io_context io;
  websocket::stream<beast::tcp_stream> ws{io};
  beast::flat_buffer buffer;
  std::deque<Message> inbox;
  bool reading = false, is_closed = false;
  int code = 0;

  void start_read() {
    reading = true;
    ws.async_read(buffer, [this](beast::error_code ec, size_t) {
      reading = false;
      if (ec) {
        is_closed = true;
        code = ws.reason().code;
        return;
      }
      Message m;
      m.binary = ws.got_binary();
      m.data = beast::buffers_to_string(buffer.data());
      m.received = std::chrono::steady_clock::now();
      buffer.consume(buffer.size());
      inbox.push_back(std::move(m));
      start_read();
    });
  }
};

SessionClient::SessionClient(const std::string& url, const std::string& token, std::chrono::milliseconds timeout) : impl_(std::make_unique<Impl>()) {
  const ParsedUrl p = parse_url(url);
  tcp::resolver resolver(impl_->io);
  auto& stream = beast::get_lowest_layer(impl_->ws);
  stream.expires_after(timeout);
  stream.connect(resolver.resolve(p.host, p.port));
  impl_->ws.set_option(websocket::stream_base::decorator([token](websocket::request_type& r) {
    if (!token.empty()) r.set(http::field::authorization, "Bearer " + token);
  }));
  impl_->ws.read_message_max(64ull << 20);
  websocket::response_type response;
  beast::error_code ec;
  impl_->ws.handshake(response, p.host + ":" + p.port, p.target, ec);
  if (ec) throw std::runtime_error("WebSocket upgrade refused: HTTP " + std::to_string(response.result_int()) + " " + response.body());
  stream.expires_never();
  impl_->start_read();
}

SessionClient::~SessionClient() = default;

void SessionClient::send_text(const std::string& text) {
  impl_->ws.text(true);
  beast::error_code ec;
  impl_->ws.write(net::buffer(text), ec);
  if (ec) throw std::runtime_error("send: " + ec.message());
}

void SessionClient::send_binary(const std::string& bytes) {
  impl_->ws.binary(true);
  beast::error_code ec;
  impl_->ws.write(net::buffer(bytes), ec);
  if (ec) throw std::runtime_error("send: " + ec.message());
}

uint32_t SessionClient::send(const std::string& type, nlohmann::json body) {
  const uint32_t id = next_id_++;
  body["type"] = type;
  body["id"] = id;
  send_text(body.dump());
  return id;
}

std::optional<SessionClient::Message> SessionClient::read(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (impl_->inbox.empty() && !impl_->is_closed) {
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) break;
    impl_->io.restart();
    impl_->io.run_one_for(left);
  }
  if (!impl_->inbox.empty()) {
    Message m = std::move(impl_->inbox.front());
    impl_->inbox.pop_front();
    return m;
  }
  if (impl_->is_closed) throw std::runtime_error("the server closed the session (code " + std::to_string(impl_->code) + ")");
  return std::nullopt;
}

nlohmann::json SessionClient::expect(const std::string& type, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::deque<Message> skipped;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    std::optional<Message> m = left.count() > 0 ? read(left) : std::nullopt;
    if (!m) {
      for (auto it = skipped.rbegin(); it != skipped.rend(); ++it) impl_->inbox.push_front(std::move(*it));
      throw std::runtime_error("no '" + type + "' message within the timeout");
    }
    if (!m->binary) {
      nlohmann::json j = nlohmann::json::parse(m->data, nullptr, false);
      if (j.is_object() && j.value("type", "") == type) {
        for (auto it = skipped.rbegin(); it != skipped.rend(); ++it) impl_->inbox.push_front(std::move(*it));
        return j;
      }
    }
    skipped.push_back(std::move(*m));
  }
}

bool SessionClient::closed() const { return impl_->is_closed; }
int SessionClient::close_code() const { return impl_->code; }

void SessionClient::close() {
  if (impl_->is_closed) return;
  beast::get_lowest_layer(impl_->ws).expires_after(std::chrono::seconds(2));
  impl_->ws.async_close(websocket::close_code::normal, [](beast::error_code) {});
  impl_->io.restart();
  impl_->io.run_for(std::chrono::seconds(2));
  impl_->is_closed = true;
}

HttpResult http_request(const std::string& url, const std::string& method, const std::string& body, const std::string& token, const std::string& content_type) {
  const ParsedUrl p = parse_url(url);
  net::io_context io;
  beast::tcp_stream stream(io);
  tcp::resolver resolver(io);
  stream.expires_after(std::chrono::minutes(10));
  stream.connect(resolver.resolve(p.host, p.port));
  http::request<http::string_body> request{http::string_to_verb(method), p.target, 11};
  request.set(http::field::host, p.host);
  request.set("X-Tetrascope", "1");  // a same-origin client's intent (server/src/same_origin.h)
  if (!token.empty()) request.set(http::field::authorization, "Bearer " + token);
  if (!body.empty() || method == "POST") {
    request.set(http::field::content_type, content_type);
    request.body() = body;
  }
  request.prepare_payload();
  http::write(stream, request);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(256ull << 20);
  http::read(stream, buffer, parser);
  HttpResult r;
  r.status = parser.get().result_int();
  r.body = parser.get().body();
  r.content_type = std::string(parser.get()[http::field::content_type]);
  beast::error_code ec;
  stream.socket().shutdown(tcp::socket::shutdown_both, ec);
  return r;
}

}  // namespace tetrascope::server
