// One HTTP connection (keep-alive): reads a request header, checks the token on the API,
// hands WebSocket upgrades to a viewing session, streams uploads to disk and passes every
// other request, its small body read in full, to handle_request (http_router.cpp).
#include <unistd.h>

#include <cstdio>

#include <boost/beast/version.hpp>
#include <boost/beast/websocket.hpp>

#include "rest.h"
#include "same_origin.h"

namespace tetrascope::server {
namespace {

namespace beast = boost::beast;
namespace fs = std::filesystem;
using tcp = net::ip::tcp;

constexpr auto kHeaderTimeout = std::chrono::seconds(30);
constexpr auto kUploadTimeout = std::chrono::hours(2);
constexpr size_t kMaxHeaderBytes = 16 * 1024;
constexpr std::string_view kSessionPath = "/api/v1/session";
constexpr std::string_view kUploadsPath = "/api/v1/uploads";

std::string bytes_text(uint64_t bytes) { return std::to_string(bytes); }

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  // `address`: the client's, already counted in connections_by_ip by accept()
  HttpSession(Server::Impl& server, tcp::socket socket, net::ip::address address)
      : server_(server), stream_(std::move(socket)), upload_timer_(stream_.get_executor()), address_(std::move(address)) {
    ++server_.http_connections;
  }
  ~HttpSession() {
    server_.release(address_);
    {
      std::lock_guard lock(server_.connections_mutex);
      if (waiting_) server_.waiting_headers.erase(*waiting_);
    }
    --server_.http_connections;
    if (upload_.temp_fd >= 0) ::close(upload_.temp_fd);
    if (!upload_.temp_path.empty()) {
      std::error_code ec;
      fs::remove(upload_.temp_path, ec);  // a body cut off midway; after success it was renamed
    }
  }
  void start() { do_read_header(); }

 private:
  void do_read_header() {
    parser_.emplace();
    parser_->header_limit(kMaxHeaderBytes);
    parser_->body_limit(boost::none);  // bodies are limited by the parser that reads them (upload or REST)
    // near the connection cap a header has little time: slow clients cannot hold the slots
    stream_.expires_after(server_.near_connection_cap() ? std::chrono::duration_cast<std::chrono::seconds>(Server::Impl::kBusyHeaderTimeout) : kHeaderTimeout);
    {
      std::lock_guard lock(server_.connections_mutex);
      waiting_ = server_.next_waiting++;
      // (the strand taken now: the closure runs on the accepting thread)
      server_.waiting_headers[*waiting_] = {std::chrono::steady_clock::now(), [weak = weak_from_this(), strand = stream_.get_executor()] {
                                              if (auto self = weak.lock()) net::post(strand, [self] { self->evict(); });
                                            }};
    }
    http::async_read_header(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::on_header, shared_from_this()));
  }

  void stop_waiting() {
    std::lock_guard lock(server_.connections_mutex);
    if (waiting_) server_.waiting_headers.erase(*waiting_);
    waiting_.reset();
  }

  // Strand. Closed at the connection cap while waiting on its header (evict_one_waiting).
  void evict() {
    if (parser_ && parser_->is_header_done()) return;  // its header came meanwhile
    ++server_.metrics.connections_evicted;
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.cancel();
  }

  void on_header(beast::error_code ec, size_t) {
    stop_waiting();
    if (ec) return refuse_malformed(ec);
    ++server_.metrics.http_requests;
    const auto& request = parser_->get();
    const Target target = parse_target(request.target());
    route_ = route_class(target.path);
    const bool api = target.path.rfind("/api/", 0) == 0 || target.path == "/metrics";
    if (server_.options.token.empty()) {
      if (auto refusal = check_same_origin(request, api)) return reply_then_close(error_response(request, refusal->status, refusal->code, refusal->message));
    }
    if (api && !authorised(request, target))
      return reply_then_close(error_response(request, http::status::unauthorized, "unauthorized",
                                             "this server needs a token: Authorization: Bearer TOKEN (or ?token= on the WebSocket URL)"));
    if (target.path == kSessionPath) return upgrade();
    if (is_upload(target)) {  // refused before the client sends the body
      const auto length = parser_->content_length();
      if (length && *length > server_.options.max_upload_bytes)
        return reply_then_close(error_response(request, http::status::payload_too_large, "too_large",
                                               "upload of " + bytes_text(*length) + " bytes; the limit is " + bytes_text(server_.options.max_upload_bytes)));
    }
    if (request[http::field::expect] == "100-continue") {  // curl and others wait for this before sending a body
      auto interim = std::make_shared<http::response<http::empty_body>>(http::status::continue_, request.version());
      http::async_write(stream_, *interim, [self = shared_from_this(), interim, target](beast::error_code write_ec, size_t) {
        if (write_ec) return self->shutdown();
        self->read_body(target);
      });
      return;
    }
    read_body(target);
  }

  // A request Beast cannot parse gets a status that says why (RFC 9110/6585), then the
  // connection closes: the rest of the stream cannot be trusted to start a new request.
  void refuse_malformed(beast::error_code ec) {
    http::status status = http::status::bad_request;
    std::string message = "malformed HTTP request: " + ec.message();
    if (ec == http::error::header_limit) {
      status = http::status::request_header_fields_too_large;
      message = "request header over " + std::to_string(kMaxHeaderBytes) + " bytes";
    } else if (ec == http::error::body_limit) {
      status = http::status::payload_too_large;
    } else if (ec == http::error::bad_version) {
      status = http::status::http_version_not_supported;
      message = "HTTP/1.0 and HTTP/1.1 only";
    } else if (ec == http::error::bad_content_length || ec == http::error::multiple_content_length) {
      message = "invalid or repeated Content-Length";
    } else if (ec == http::error::bad_transfer_encoding) {
      message = "invalid Transfer-Encoding (or with a Content-Length)";
    } else if (ec == http::error::end_of_stream || ec == http::error::partial_message ||
               ec.category() != http::make_error_code(http::error::bad_method).category()) {
      return shutdown();  // a connection closed or timed out: nobody to answer
    }
    Response response = error_response(ReplyTo{11, false}, status, "bad_http", message);
    route_ = "malformed";
    reply_then_close(std::move(response));
  }

  bool is_upload(const Target& target) const { return target.path == kUploadsPath && parser_->get().method() == http::verb::post; }

  void upgrade() {
    const auto& request = parser_->get();
    if (!beast::websocket::is_upgrade(request))
      return reply(error_response(request, http::status::upgrade_required, "upgrade_required", "/api/v1/session is a WebSocket endpoint"));
    const uint32_t max_sessions = server_.options.limits.max_sessions;
    if (server_.metrics.sessions_active >= static_cast<int64_t>(max_sessions)) {
      ++server_.metrics.sessions_refused;
      return reply_then_close(error_response(request, http::status::service_unavailable, "too_many_sessions",
                                             "the server has its maximum of " + std::to_string(max_sessions) + " sessions; try again later"));
    }
    stream_.expires_never();
    start_ws_session(server_, std::move(stream_), parser_->release());
  }

  void read_body(const Target& target) {
    if (is_upload(target)) return start_upload(target);
    // every other request has a small body (or none)
    const uint64_t limit = server_.options.max_request_body_bytes;
    const auto length = parser_->content_length();
    if (length && *length > limit)
      return reply_then_close(error_response(parser_->get(), http::status::payload_too_large, "too_large",
                                             "request body of " + bytes_text(*length) + " bytes; the limit is " + bytes_text(limit)));
    body_parser_.emplace(std::move(*parser_));
    body_parser_->body_limit(limit);
    http::async_read(stream_, buffer_, *body_parser_, [self = shared_from_this(), target, limit](beast::error_code read_ec, size_t) {
      if (read_ec == http::error::body_limit)
        return self->reply_then_close(error_response(self->body_parser_->get(), http::status::payload_too_large, "too_large", "request body over " + bytes_text(limit) + " bytes"));
      if (read_ec) return self->shutdown();
      self->reply(handle_request(self->server_, target, self->body_parser_->get()));
    });
  }

  bool authorised(const RequestHeader& request, const Target& target) const {
    if (server_.options.token.empty()) return true;
    const auto header = request[http::field::authorization];
    if (header.size() > 7 && header.substr(0, 7) == "Bearer ") return server_.token_matches(std::string_view(header.data() + 7, header.size() - 7));
    auto it = target.query.find("token");
    return it != target.query.end() && server_.token_matches(it->second);
  }

  // POST /api/v1/uploads?name=FILE (rest_uploads.cpp says where the body goes).
  void start_upload(const Target& target) {
    if (server_.options.read_only) return reply_then_close(read_only_refusal(reply_to(parser_->get())));
    try {
      upload_ = upload_paths(server_, target);
    } catch (const BadRequest& e) {
      return reply_then_close(error_response(parser_->get(), static_cast<http::status>(e.status()), e.code(), e.what()));
    }
    upload_parser_.emplace(std::move(*parser_));
    upload_parser_->body_limit(server_.options.max_upload_bytes);
    beast::error_code open_ec;
    beast::file file;  // the request's own temporary file, created O_EXCL by upload_paths
    file.native_handle(upload_.temp_fd);
    upload_.temp_fd = -1;
    upload_parser_->get().body().reset(std::move(file), open_ec);
    if (open_ec) return reply_then_close(error_response(upload_parser_->get(), http::status::internal_server_error, "internal", "cannot write the upload: " + open_ec.message()));
    stream_.expires_after(kUploadTimeout);
    upload_checked_bytes_ = 0;
    upload_too_slow_ = false;
    check_upload_rate();
    http::async_read(stream_, buffer_, *upload_parser_, beast::bind_front_handler(&HttpSession::on_upload, shared_from_this()));
  }

  // Every window, the body must have grown by the minimum rate; a trickle (1 byte every few
  // seconds) would otherwise hold a connection and a file for the whole upload timeout.
  void check_upload_rate() {
    if (server_.options.min_upload_bytes_per_second == 0) return;
    upload_timer_.expires_after(server_.options.upload_rate_window);
    upload_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (ec || !self->upload_parser_ || self->upload_parser_->is_done()) return;
      beast::error_code size_ec;
      const uint64_t received = self->upload_parser_->get().body().file().size(size_ec);
      const double window_s = std::chrono::duration<double>(self->server_.options.upload_rate_window).count();
      if (static_cast<double>(received - self->upload_checked_bytes_) < window_s * static_cast<double>(self->server_.options.min_upload_bytes_per_second)) {
        self->upload_too_slow_ = true;
        self->stream_.cancel();  // on_upload answers 408 and removes the file
        return;
      }
      self->upload_checked_bytes_ = received;
      self->check_upload_rate();
    });
  }

  void on_upload(beast::error_code ec, size_t) {
    const auto& request = upload_parser_->get();
    upload_parser_->get().body().close();
    upload_timer_.cancel();
    if (ec) {
      std::error_code rm;
      fs::remove(upload_.temp_path, rm);
      upload_ = {};  // releases the name
      if (upload_too_slow_)
        return reply_then_close(error_response(request, http::status::request_timeout, "too_slow",
                                               "upload slower than " + bytes_text(server_.options.min_upload_bytes_per_second) + " bytes a second"));
      if (ec == http::error::body_limit)
        return reply_then_close(error_response(request, http::status::payload_too_large, "too_large", "upload over the limit of " + bytes_text(server_.options.max_upload_bytes) + " bytes"));
      return shutdown();
    }
    Response response = finish_upload(server_, reply_to(request), upload_);
    upload_ = {};
    reply(std::move(response));
  }

  void reply(Response response) {
    const unsigned status = response.result_int();
    if (status >= 400) {
      server_.metrics.count_http_error(route_, status);
      // error messages may quote a library's exception: none may name a path on the server
      const std::string body = without_server_paths(response.body(), server_.options.data_dir);
      if (body.size() != response.body().size() || body != response.body()) {
        response.body() = body;
        response.prepare_payload();
      }
    }
    auto shared = std::make_shared<Response>(std::move(response));
    stream_.expires_after(kHeaderTimeout);
    http::async_write(stream_, *shared, [self = shared_from_this(), shared](beast::error_code ec, size_t) {
      if (ec || !shared->keep_alive()) return self->shutdown();
      self->body_parser_.reset();
      self->upload_parser_.reset();
      self->do_read_header();
    });
  }
  void reply_then_close(Response response) {
    response.keep_alive(false);
    reply(std::move(response));
  }

  void shutdown() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  Server::Impl& server_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> parser_;
  std::optional<http::request_parser<http::string_body>> body_parser_;
  std::optional<http::request_parser<http::file_body>> upload_parser_;
  UploadPaths upload_;
  std::string route_ = "static";  // route_class of the request being answered
  net::steady_timer upload_timer_;
  uint64_t upload_checked_bytes_ = 0;
  bool upload_too_slow_ = false;
  net::ip::address address_;
  std::optional<uint64_t> waiting_;  // its entry in waiting_headers while it waits on a header
};

}  // namespace

void Server::Impl::accept() {
  acceptor->async_accept(net::make_strand(io), [this](beast::error_code ec, tcp::socket socket) {
    if (stopped) return;
    if (ec) return on_accept_failed(ec);
    try {
      accepted(std::move(socket));
    } catch (const std::exception& e) {  // (out of memory): this connection is lost, the next is accepted
      ++metrics.handler_exceptions;
      std::fprintf(stderr, "tetrascope serve: a connection was dropped: %s\n", e.what());
    }
    accept();
  });
}

bool Server::Impl::admit(const net::ip::address& address) {
  {
    std::lock_guard lock(connections_mutex);
    auto it = connections_by_ip.find(address);
    if (options.max_connections_per_ip > 0 && it != connections_by_ip.end() && it->second >= options.max_connections_per_ip) return false;
  }
  // at the cap, a connection that has waited on its header longest makes room
  if (http_connections >= static_cast<int64_t>(options.max_connections) && !evict_one_waiting()) return false;
  std::lock_guard lock(connections_mutex);
  ++connections_by_ip[address];
  return true;
}

void Server::Impl::accepted(tcp::socket socket) {
  beast::error_code address_ec;
  const net::ip::address address = socket.remote_endpoint(address_ec).address();
  if (!admit(address)) {
    // over a cap: a short answer instead of a connection that holds a descriptor
    static constexpr std::string_view kBusy =
        "HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain\r\nContent-Length: 40\r\nConnection: close\r\n\r\n"
        "too many connections; try again shortly\n";
    beast::error_code ignored;
    socket.non_blocking(true, ignored);
    socket.write_some(net::buffer(kBusy), ignored);
    socket.close(ignored);
    ++metrics.http_requests;
    metrics.count_http_error("connection", 503);
    return;
  }
  std::shared_ptr<HttpSession> session;
  try {
    session = std::make_shared<HttpSession>(*this, std::move(socket), address);
  } catch (...) {
    release(address);  // admitted, but no session came to count it down
    throw;
  }
  session->start();
}

void Server::Impl::release(const net::ip::address& address) {
  std::lock_guard lock(connections_mutex);
  if (auto it = connections_by_ip.find(address); it != connections_by_ip.end() && --it->second == 0) connections_by_ip.erase(it);
}

bool Server::Impl::evict_one_waiting() {
  std::function<void()> close;
  {
    std::lock_guard lock(connections_mutex);
    const auto now = std::chrono::steady_clock::now();
    for (auto it = waiting_headers.begin(); it != waiting_headers.end(); ++it)  // oldest first
      if (now - it->second.since >= kEvictAfter) {
        close = std::move(it->second.close);
        waiting_headers.erase(it);
        break;
      }
  }
  if (!close) return false;
  close();  // outside the lock: the connection's last reference may go here
  return true;
}

void Server::Impl::on_accept_failed(const boost::system::error_code& ec) {
  // Out of descriptors (EMFILE/ENFILE) or memory: the pending connection stays in the backlog,
  // so accepting again at once would fail again at once, at 100% of a core. Wait a little.
  const bool resources = ec == net::error::no_descriptors || ec == boost::system::errc::too_many_files_open_in_system ||
                         ec == net::error::no_buffer_space || ec == net::error::no_memory;
  if (!resources) return accept();  // e.g. a connection reset before it was accepted
  accept_pause->expires_after(kAcceptPause);
  accept_pause->async_wait([this](const boost::system::error_code& wait_ec) {
    if (!wait_ec && !stopped) accept();
  });
}

bool Server::Impl::token_matches(std::string_view offered) const {
  const std::string& token = options.token;
  unsigned char diff = static_cast<unsigned char>(offered.size() != token.size());
  for (size_t i = 0; i < token.size(); ++i) diff |= static_cast<unsigned char>(token[i] ^ (i < offered.size() ? offered[i] : 0));
  return diff == 0;
}

}  // namespace tetrascope::server
