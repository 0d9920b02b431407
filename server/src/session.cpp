// One WebSocket viewing session's connection (Beast: one class per concern, do_x / on_x,
// explicit limits): accept, the read loop, the outgoing queue, close. What the messages change
// is the session's ViewSession (view_session.h), when its frames are drawn its FrameScheduler
// (frame_scheduler.h); both report back here, on the connection's strand.
//  - incoming: messages up to a hard cap, each handed to the ViewSession in order;
//  - outgoing: replies in order; frames latest-wins, one in flight and one waiting.
#include <deque>
#include <memory>
#include <optional>

#include <boost/beast/websocket.hpp>

#include "frame_scheduler.h"
#include "server_impl.h"
#include "session_state.h"
#include "view_session.h"

namespace tetrascope::server {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(Server::Impl& server, beast::tcp_stream stream)
      : server_(server), ws_(std::move(stream)), hello_timer_(ws_.get_executor()), view_(server, shared_, view_link()), frames_(server, shared_, frame_link()) {
    ++server_.metrics.sessions_active;
    ++server_.metrics.sessions_total;
  }
  ~WsSession() { --server_.metrics.sessions_active; }

  void start(http::request<http::empty_body> request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& r) { r.set(http::field::server, "tetrascope"); }));
    // Messages up to the hard cap are read and answered (too_large past the protocol limit);
    // past the cap Beast closes the connection (1009).
    ws_.read_message_max(kHardCapFactor * server_.options.limits.max_message_bytes);
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

 private:
  // The session's parts hold the whole session alive through these while they have work out.
  std::shared_ptr<void> hold() { return shared_from_this(); }

  ViewSession::Link view_link() {
    return {ws_.get_executor(),
            [this] { return hold(); },
            [this](std::string text) { send_text(std::move(text)); },
            [this] { hello_timer_.cancel(); },
            [this] { close_for_policy(); },
            [this](FrameRequest kind) { frames_.request(kind); },
            [this](ViewState snapshot, double x, double y, uint32_t id) { frames_.probe(std::move(snapshot), x, y, id); }};
  }

  FrameScheduler::Link frame_link() {
    return {ws_.get_executor(),
            [this] { return hold(); },
            [this](std::string text) { send_text(std::move(text)); },
            [this](std::vector<uint8_t> bytes) { send_frame(std::move(bytes)); }};
  }

  void on_accept(beast::error_code ec) {
    if (ec) return;
    // a connection that never says hello would hold a session slot: it gets hello_timeout
    hello_timer_.expires_after(server_.options.hello_timeout);
    hello_timer_.async_wait([self = shared_from_this()](beast::error_code wait_ec) {
      if (wait_ec || self->view_.said_hello()) return;
      beast::error_code ignored;
      beast::get_lowest_layer(self->ws_).socket().close(ignored);  // the read fails, the session ends, its slot is free
    });
    do_read();
  }

  void do_read() { ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::on_read, shared_from_this())); }

  void on_read(beast::error_code ec, size_t) {
    if (ec) {
      close_down();
      return;
    }
    ++server_.metrics.messages;
    const bool text = ws_.got_text();
    std::string message = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    if (!closing_) view_.handle(text, message);
    if (!closing_) do_read();
  }

  // Strand. Too many bad messages in a row, or a wrong token.
  void close_for_policy() {
    closing_ = true;
    close_down();
    ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, "too many bad messages"),
                    [self = shared_from_this()](beast::error_code) {});
  }

  // Strand.
  void send_text(std::string text) {
    texts_.push_back(std::move(text));
    do_write();
  }
  void send_frame(std::vector<uint8_t> bytes) {
    if (waiting_frame_) ++server_.metrics.frames_dropped;  // the client is slower than we render: newest wins
    waiting_frame_ = std::move(bytes);
    do_write();
  }
  void do_write() {
    if (writing_ || closing_) return;
    if (!texts_.empty()) {
      writing_ = true;
      ws_.text(true);
      ws_.async_write(net::buffer(texts_.front()), beast::bind_front_handler(&WsSession::on_write_text, shared_from_this()));
    } else if (waiting_frame_) {
      writing_ = true;
      frame_in_flight_ = std::move(*waiting_frame_);
      waiting_frame_.reset();
      ws_.binary(true);
      ws_.async_write(net::buffer(frame_in_flight_), beast::bind_front_handler(&WsSession::on_write_frame, shared_from_this()));
    }
  }
  void on_write_text(beast::error_code ec, size_t) {
    writing_ = false;
    texts_.pop_front();
    if (ec) return close_down();
    do_write();
  }
  void on_write_frame(beast::error_code ec, size_t) {
    writing_ = false;
    if (ec) return close_down();
    do_write();
  }

  void close_down() {
    frames_.close();
    hello_timer_.cancel();
  }

  Server::Impl& server_;
  websocket::stream<beast::tcp_stream> ws_;
  net::steady_timer hello_timer_;
  static constexpr size_t kHardCapFactor = 4;  // docs/security.md: "closed past 4x the message limit"
  beast::flat_buffer buffer_;
  // strand only
  bool closing_ = false, writing_ = false;
  std::deque<std::string> texts_;
  std::optional<std::vector<uint8_t>> waiting_frame_;
  std::vector<uint8_t> frame_in_flight_;
  // the session's parts: what they share, its messages, its frames
  SessionState shared_;
  ViewSession view_;
  FrameScheduler frames_;
};

}  // namespace

void start_ws_session(Server::Impl& server, beast::tcp_stream stream, http::request<http::empty_body> request) {
  std::make_shared<WsSession>(server, std::move(stream))->start(std::move(request));
}

}  // namespace tetrascope::server
