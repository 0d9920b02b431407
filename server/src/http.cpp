// HTTP side of the server: the listener, one session per connection (keep-alive), the REST
// API, uploads streamed to disk, static files, and the hand-over of WebSocket upgrades.
#include <fstream>
#include <sstream>

#include <boost/beast/version.hpp>
#include <boost/beast/websocket.hpp>

#include "server_impl.h"

namespace tetrascope::server {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace fs = std::filesystem;
using tcp = net::ip::tcp;

constexpr auto kHeaderTimeout = std::chrono::seconds(30);
constexpr auto kUploadTimeout = std::chrono::hours(2);
constexpr size_t kMaxHeaderBytes = 16 * 1024;

std::string percent_decode(std::string_view in) {
  std::string out;
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '%' && i + 2 < in.size() && std::isxdigit(static_cast<unsigned char>(in[i + 1])) && std::isxdigit(static_cast<unsigned char>(in[i + 2]))) {
      out += static_cast<char>(std::stoi(std::string(in.substr(i + 1, 2)), nullptr, 16));
      i += 2;
    } else {
      out += in[i] == '+' ? ' ' : in[i];
    }
  }
  return out;
}

struct Target {
  std::string path;
  std::map<std::string, std::string> query;
};

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

using Response = http::response<http::string_body>;

// This process's resident memory (VmRSS) or its peak (VmHWM), bytes.
double memory_bytes(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind(field, 0) == 0) return 1024.0 * std::strtod(line.c_str() + field.size(), nullptr);
  return 0;
}

Response make_response(unsigned version, bool keep_alive, http::status status, std::string body, const std::string& type) {
  Response r{status, version};
  r.set(http::field::server, "tetrascope");
  r.set(http::field::content_type, type);
  r.set(http::field::cache_control, "no-store");
  r.keep_alive(keep_alive);
  r.body() = std::move(body);
  r.prepare_payload();
  return r;
}

Response json_response(unsigned version, bool keep_alive, http::status status, const nlohmann::json& body) {
  return make_response(version, keep_alive, status, body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "application/json");
}

Response error_response(unsigned version, bool keep_alive, int status, const std::string& code, const std::string& message) {
  return json_response(version, keep_alive, static_cast<http::status>(status), {{"error", {{"code", code}, {"message", message}}}});
}

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(Server::Impl& server, tcp::socket socket) : server_(server), stream_(std::move(socket)) {}
  void start() { do_read_header(); }

 private:
  void do_read_header() {
    parser_.emplace();
    parser_->header_limit(kMaxHeaderBytes);
    parser_->body_limit(boost::none);  // bodies are limited by the parser that reads them (upload or REST)
    stream_.expires_after(kHeaderTimeout);
    http::async_read_header(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::on_header, shared_from_this()));
  }

  void on_header(beast::error_code ec, size_t) {
    if (ec) return shutdown();
    ++server_.metrics.http_requests;
    auto& request = parser_->get();
    const Target target = parse_target(request.target());
    const unsigned version = request.version();
    const bool keep_alive = request.keep_alive();

    const bool api = target.path.rfind("/api/", 0) == 0 || target.path == "/metrics";
    if (api && !authorised(request, target)) {
      return reply_then_close(error_response(version, false, 401, "unauthorized", "this server needs a token: Authorization: Bearer TOKEN (or ?token= on the WebSocket URL)"));
    }
    if (target.path == "/api/v1/session") {
      if (!boost::beast::websocket::is_upgrade(request)) return reply(error_response(version, keep_alive, 426, "upgrade_required", "/api/v1/session is a WebSocket endpoint"));
      if (server_.metrics.sessions_active >= static_cast<int64_t>(server_.options.limits.max_sessions)) {
        ++server_.metrics.sessions_refused;
        return reply_then_close(error_response(version, false, 503, "too_many_sessions",
                                               "the server has its maximum of " + std::to_string(server_.options.limits.max_sessions) + " sessions; try again later"));
      }
      stream_.expires_never();
      start_ws_session(server_, std::move(stream_), parser_->release());
      return;
    }
    if (target.path == "/api/v1/uploads" && request.method() == http::verb::post) {  // refused before the client sends the body
      const auto length = parser_->content_length();
      if (length && *length > server_.options.max_upload_bytes)
        return reply_then_close(error_response(version, false, 413, "too_large",
                                               "upload of " + std::to_string(*length) + " bytes; the limit is " + std::to_string(server_.options.max_upload_bytes)));
    }
    if (request[http::field::expect] == "100-continue") {  // curl and others wait for this before sending a body
      auto interim = std::make_shared<http::response<http::empty_body>>(http::status::continue_, version);
      http::async_write(stream_, *interim, [self = shared_from_this(), interim, target](beast::error_code write_ec, size_t) {
        if (write_ec) return self->shutdown();
        self->read_body(target);
      });
      return;
    }
    read_body(target);
  }

  void read_body(const Target& target) {
    if (target.path == "/api/v1/uploads" && parser_->get().method() == http::verb::post) return start_upload(target);
    // every other request has a small body (or none)
    const auto length = parser_->content_length();
    if (length && *length > server_.options.max_request_body_bytes)
      return reply_then_close(error_response(parser_->get().version(), false, 413, "too_large",
                                             "request body of " + std::to_string(*length) + " bytes; the limit is " + std::to_string(server_.options.max_request_body_bytes)));
    body_parser_.emplace(std::move(*parser_));
    body_parser_->body_limit(server_.options.max_request_body_bytes);
    http::async_read(stream_, buffer_, *body_parser_, [self = shared_from_this(), target](beast::error_code read_ec, size_t) {
      if (read_ec == http::error::body_limit) {
        return self->reply_then_close(error_response(11, false, 413, "too_large", "request body over " + std::to_string(self->server_.options.max_request_body_bytes) + " bytes"));
      }
      if (read_ec) return self->shutdown();
      self->route(target, self->body_parser_->release());
    });
  }

  template <class Request>
  bool authorised(const Request& request, const Target& target) const {
    if (server_.options.token.empty()) return true;
    const auto header = request[http::field::authorization];
    if (header.size() > 7 && header.substr(0, 7) == "Bearer ") return server_.token_matches(std::string_view(header.data() + 7, header.size() - 7));
    auto it = target.query.find("token");
    return it != target.query.end() && server_.token_matches(it->second);
  }

  void route(const Target& target, http::request<http::string_body> request) {
    const unsigned v = request.version();
    const bool ka = request.keep_alive();
    const auto method = request.method();
    const std::string& path = target.path;
    try {
      if (path == "/api/v1/health" && method == http::verb::get) {
        const double uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - server_.started).count();
        return reply(json_response(v, ka, http::status::ok,
                                   {{"status", "ok"}, {"version", "0.1.0"}, {"protocol", protocol::kVersion}, {"renderer", server_.pool->description()},
                                    {"uptime_s", uptime}, {"sessions", server_.metrics.sessions_active.load()}, {"render_workers", server_.options.render_workers},
                                    {"rss_bytes", memory_bytes("VmRSS:")}, {"peak_rss_bytes", memory_bytes("VmHWM:")}}));
      }
      if (path == "/metrics" && method == http::verb::get) return reply(make_response(v, ka, http::status::ok, metrics_text(), "text/plain; version=0.0.4"));
      if (path == "/api/v1/openapi.yaml" && method == http::verb::get) return serve_file(server_.options.protocol_root / "openapi.yaml", v, ka);
      if (path == "/api/v1/datasets" && method == http::verb::get) return reply(json_response(v, ka, http::status::ok, {{"datasets", server_.datasets->list()}}));
      if (path.rfind("/api/v1/datasets/", 0) == 0 && method == http::verb::get) {
        const std::string name = path.substr(17);
        try {
          return reply(json_response(v, ka, http::status::ok, server_.datasets->open(name)->info));
        } catch (const NotFound& e) {
          return reply(error_response(v, ka, 404, "not_found", e.what()));
        } catch (const std::exception& e) {
          return reply(error_response(v, ka, 409, "not_viewable", e.what()));
        }
      }
      if (path == "/api/v1/uploads" && method == http::verb::get) return reply(json_response(v, ka, http::status::ok, {{"uploads", uploads()}}));
      if (path == "/api/v1/jobs" && method == http::verb::get) return reply(json_response(v, ka, http::status::ok, {{"jobs", server_.jobs->list()}}));
      if (path == "/api/v1/jobs" && method == http::verb::post) {
        nlohmann::json body = nlohmann::json::parse(request.body(), nullptr, false);
        if (body.is_discarded()) return reply(error_response(v, ka, 400, "bad_request", "the body is not JSON"));
        return reply(json_response(v, ka, http::status::accepted, server_.jobs->submit(body)));
      }
      if (path.rfind("/api/v1/jobs/", 0) == 0 && (method == http::verb::get || method == http::verb::delete_)) {
        const std::string id = path.substr(13);
        auto job = method == http::verb::get ? server_.jobs->get(id) : server_.jobs->cancel(id);
        if (!job) return reply(error_response(v, ka, 404, "not_found", "no job '" + id + "'"));
        return reply(json_response(v, ka, http::status::ok, *job));
      }
      if (path.rfind("/api/", 0) == 0) return reply(error_response(v, ka, 404, "not_found", "no endpoint " + std::string(request.method_string()) + " " + path));
      if (method != http::verb::get && method != http::verb::head) return reply(error_response(v, ka, 405, "method_not_allowed", "static files are GET only"));
      // static files: the web client at /, the protocol codec and schemas at /protocol/
      if (path.rfind("/protocol/", 0) == 0) {
        const std::string rest = path.substr(10);
        if (rest.rfind("js/", 0) != 0 && rest.rfind("schema/", 0) != 0 && rest != "openapi.yaml") return reply(error_response(v, ka, 404, "not_found", "no file " + path));
        return serve_static(server_.options.protocol_root, rest, v, ka);
      }
      return serve_static(server_.options.web_root, path == "/" ? "index.html" : path.substr(1), v, ka);
    } catch (const BadRequest& e) {
      return reply(error_response(v, ka, e.status(), e.code(), e.what()));
    } catch (const std::exception& e) {
      return reply(error_response(v, ka, 500, "internal", e.what()));
    }
  }

  void serve_static(const fs::path& root, const std::string& relative, unsigned v, bool ka) {
    auto file = resolve_inside(root, relative);
    if (!file) return reply(error_response(v, ka, 404, "not_found", "no file /" + relative));
    serve_file(*file, v, ka);
  }

  void serve_file(const fs::path& file, unsigned v, bool ka) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) return reply(error_response(v, ka, 404, "not_found", "no file " + file.filename().string()));
    std::ifstream in(file, std::ios::binary);
    std::ostringstream content;
    content << in.rdbuf();
    reply(make_response(v, ka, http::status::ok, content.str(), mime_type(file)));
  }

  nlohmann::json uploads() const {
    nlohmann::json out = nlohmann::json::array();
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(server_.options.data_dir / "uploads", ec))
      if (entry.is_regular_file() && valid_name(entry.path().filename().string()))
        out.push_back({{"path", "uploads/" + entry.path().filename().string()}, {"bytes", entry.file_size()}});
    return out;
  }

  std::string metrics_text() const {
    const Metrics& m = server_.metrics;
    std::string out;
    auto gauge = [&](const char* name, const char* type, const char* help, double value) {
      char line[256];
      std::snprintf(line, sizeof line, "# HELP %s %s\n# TYPE %s %s\n%s %.17g\n", name, help, name, type, name, value);
      out += line;
    };
    gauge("tetrascope_sessions_active", "gauge", "WebSocket sessions open", double(m.sessions_active.load()));
    gauge("tetrascope_sessions_total", "counter", "WebSocket sessions accepted", double(m.sessions_total.load()));
    gauge("tetrascope_sessions_refused_total", "counter", "sessions refused at the session limit", double(m.sessions_refused.load()));
    out += "# HELP tetrascope_frames_total frames rendered\n# TYPE tetrascope_frames_total counter\n";
    out += "tetrascope_frames_total{kind=\"interaction\"} " + std::to_string(m.frames_interaction.load()) + "\n";
    out += "tetrascope_frames_total{kind=\"still\"} " + std::to_string(m.frames_still.load()) + "\n";
    gauge("tetrascope_frames_dropped_total", "counter", "frames replaced by a newer one before a slow client took them", double(m.frames_dropped.load()));
    gauge("tetrascope_frame_bytes_total", "counter", "bytes of frames rendered", double(m.frame_bytes.load()));
    gauge("tetrascope_messages_total", "counter", "WebSocket messages received", double(m.messages.load()));
    gauge("tetrascope_http_requests_total", "counter", "HTTP requests", double(m.http_requests.load()));
    out += "# HELP tetrascope_errors_total error replies by code\n# TYPE tetrascope_errors_total counter\n";
    for (const auto& [code, count] : m.errors()) out += "tetrascope_errors_total{code=\"" + code + "\"} " + std::to_string(count) + "\n";
    m.render_ms.write(out, "tetrascope_render_ms", "cut update, assembly and drawing of a frame, ms");
    m.encode_ms.write(out, "tetrascope_encode_ms", "JPEG/PNG encoding of a frame, ms");
    m.cut_ms.write(out, "tetrascope_cut_update_ms", "cut update of a frame, ms");
    m.assemble_ms.write(out, "tetrascope_assemble_ms", "assembly of a changed cut's mesh and scene, ms (0: unchanged)");
    m.upload_ms.write(out, "tetrascope_upload_ms", "scene upload to a render context, ms (0: the context held it)");
    m.draw_ms.write(out, "tetrascope_draw_ms", "drawing and readback of a frame, ms");
    uint64_t hits = 0, misses = 0, resident = 0;
    server_.datasets->cache_stats(hits, misses, resident);
    gauge("tetrascope_cache_hits_total", "counter", "segment cache hits", double(hits));
    gauge("tetrascope_cache_misses_total", "counter", "segment cache misses (segments mapped)", double(misses));
    gauge("tetrascope_cache_resident_bytes", "gauge", "bytes of segments mapped", double(resident));
    out += "# HELP tetrascope_jobs jobs by state\n# TYPE tetrascope_jobs gauge\n";
    for (const auto& [state, count] : server_.jobs->count_by_state()) out += "tetrascope_jobs{state=\"" + state + "\"} " + std::to_string(count) + "\n";
    return out;
  }

  // POST /api/v1/uploads?name=FILE: the body streams into uploads/.FILE.part (never held in
  // memory), renamed to uploads/FILE when complete.
  void start_upload(const Target& target) {
    const unsigned v = parser_->get().version();
    auto it = target.query.find("name");
    const std::string name = it == target.query.end() ? "" : it->second;
    if (!valid_name(name)) return reply_then_close(error_response(v, false, 400, "bad_request", "name: 1-128 letters, digits, '.', '_' or '-', not starting with '.'"));
    const fs::path folder = server_.options.data_dir / "uploads";
    std::error_code fec;
    fs::create_directories(folder, fec);
    upload_final_ = folder / name;
    upload_temp_ = folder / ("." + name + ".part");
    upload_parser_.emplace(std::move(*parser_));
    upload_parser_->body_limit(server_.options.max_upload_bytes);
    beast::error_code open_ec;
    upload_parser_->get().body().open(upload_temp_.c_str(), beast::file_mode::write, open_ec);
    if (open_ec) return reply_then_close(error_response(v, false, 500, "internal", "cannot write the upload: " + open_ec.message()));
    stream_.expires_after(kUploadTimeout);
    http::async_read(stream_, buffer_, *upload_parser_, [self = shared_from_this(), v](beast::error_code ec, size_t) {
      self->upload_parser_->get().body().close();
      std::error_code rm;
      if (ec) {
        fs::remove(self->upload_temp_, rm);
        if (ec == http::error::body_limit)
          return self->reply_then_close(error_response(v, false, 413, "too_large", "upload over the limit of " + std::to_string(self->server_.options.max_upload_bytes) + " bytes"));
        return self->shutdown();
      }
      const bool ka = self->upload_parser_->get().keep_alive();
      std::error_code mv;
      const uint64_t bytes = fs::file_size(self->upload_temp_, mv);
      fs::rename(self->upload_temp_, self->upload_final_, mv);
      if (mv) return self->reply(error_response(v, ka, 500, "internal", "cannot store the upload: " + mv.message()));
      self->reply(json_response(v, ka, http::status::created, {{"path", "uploads/" + self->upload_final_.filename().string()}, {"bytes", bytes}}));
    });
  }

  void reply(Response response) {
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
  fs::path upload_final_, upload_temp_;
};

}  // namespace

void Server::Impl::accept() {
  acceptor->async_accept(net::make_strand(io), [this](beast::error_code ec, tcp::socket socket) {
    if (stopped) return;
    if (!ec) std::make_shared<HttpSession>(*this, std::move(socket))->start();
    accept();
  });
}

bool Server::Impl::token_matches(std::string_view offered) const {
  const std::string& token = options.token;
  unsigned char diff = static_cast<unsigned char>(offered.size() != token.size());
  for (size_t i = 0; i < token.size(); ++i) diff |= static_cast<unsigned char>(token[i] ^ (i < offered.size() ? offered[i] : 0));
  return diff == 0;
}

}  // namespace tetrascope::server
