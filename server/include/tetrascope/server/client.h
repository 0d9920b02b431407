// A WebSocket client of the viewing protocol (Beast), for `tetrascope loadtest` and the
// integration tests. Not thread-safe: one thread per client.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace tetrascope::server {

struct ParsedUrl {
  std::string host, port, target;  // target: path and query
};
// ws://HOST:PORT/PATH?QUERY or http://...; throws std::invalid_argument.
ParsedUrl parse_url(const std::string& url);

class SessionClient {
 public:
  struct Message {
    bool binary = false;
    std::string data;
    std::chrono::steady_clock::time_point received;
  };
  // Connects and upgrades; `token` goes in an Authorization header. Throws std::runtime_error
  // with the HTTP status when the upgrade is refused.
  SessionClient(const std::string& url, const std::string& token = "", std::chrono::milliseconds timeout = std::chrono::seconds(10));
  ~SessionClient();
  void send_text(const std::string& text);
  void send_binary(const std::string& bytes);
  uint32_t send(const std::string& type, nlohmann::json body = nlohmann::json::object());  // adds type and a fresh id; returns the id
  // The next message, or nullopt when none came within `timeout`. Throws std::runtime_error
  // once the connection is closed (closed() then says so, close_code() why).
  std::optional<Message> read(std::chrono::milliseconds timeout);
  // Reads until a text message of `type` (others kept in order for later reads).
  nlohmann::json expect(const std::string& type, std::chrono::milliseconds timeout = std::chrono::seconds(10));
  bool closed() const;
  int close_code() const;
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  uint32_t next_id_ = 1;
};

// One HTTP request (tests, loadtest): returns status and body.
struct HttpResult {
  int status = 0;
  std::string body;
  std::string content_type;
};
HttpResult http_request(const std::string& url, const std::string& method, const std::string& body = "", const std::string& token = "",
                        const std::string& content_type = "application/json");

}  // namespace tetrascope::server
