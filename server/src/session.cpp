// One WebSocket viewing session (Beast: one class per concern, do_x / on_x, explicit limits).
//
// Network work runs on the session's strand; renders run on the pool. What the two share
// (the view state, what is pending) sits under `mutex_`. Scheduling:
//  - a control message updates the state and asks for a frame (interaction or still);
//  - a session has at most one pool task queued or running (`busy_`); the task renders the
//    newest state when it starts, so a burst of camera moves renders once;
//  - frames start no faster than max_fps;
//  - still_delay after the last interacting message, a still frame (full budget, quality,
//    size) follows;
//  - outgoing: replies in order; frames latest-wins, one in flight and one waiting.
#include <chrono>
#include <cmath>
#include <deque>
#include <mutex>
#include <optional>

#include <boost/beast/websocket.hpp>

#include "server_impl.h"

namespace tetrascope::server {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using Clock = std::chrono::steady_clock;

enum class Pending { kNone, kInteraction, kStill };

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(Server::Impl& server, beast::tcp_stream stream)
      : server_(server), ws_(std::move(stream)), still_timer_(ws_.get_executor()), pace_timer_(ws_.get_executor()) {
    ++server_.metrics.sessions_active;
    ++server_.metrics.sessions_total;
    const auto& o = server_.options;
    state_.budget = o.still_budget;
    state_.interaction_budget = o.interaction_budget;
    state_.interaction_quality = o.interaction_quality;
    state_.still_quality = o.still_quality;
    state_.interaction_scale = o.interaction_scale;
  }
  ~WsSession() { --server_.metrics.sessions_active; }

  void start(http::request<http::empty_body> request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& r) { r.set(http::field::server, "tetrascope"); }));
    // Messages up to the hard cap are read and answered (too_large past the protocol limit);
    // past the cap Beast closes the connection (1009).
    ws_.read_message_max(std::max<size_t>(4 * server_.options.limits.max_message_bytes, 1 << 20));
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

 private:
  void on_accept(beast::error_code ec) {
    if (ec) return;
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
    if (!closing_) handle(text, message);
    if (!closing_) do_read();
  }

  void handle(bool text, const std::string& message) {
    try {
      // messages per second, over a one-second window
      const auto now = Clock::now();
      if (now - window_start_ > std::chrono::seconds(1)) {
        window_start_ = now;
        window_count_ = 0;
      }
      if (++window_count_ > server_.options.limits.max_messages_per_second)
        throw protocol::ProtocolError(protocol::code::kRateLimited, "more than " + std::to_string(server_.options.limits.max_messages_per_second) + " messages a second; this one was dropped");
      if (!text) throw protocol::ProtocolError(protocol::code::kBinaryMessage, "control messages are JSON text frames");
      protocol::Envelope envelope = protocol::parse_message(message, server_.options.limits);
      if (!hello_ && envelope.type != "hello") throw protocol::ProtocolError(protocol::code::kHelloFirst, "send hello first", envelope.id);
      apply(envelope);
      bad_in_row_ = 0;
    } catch (const protocol::ProtocolError& e) {
      refuse(e.code(), e.what(), e.id());
    }
  }

  void refuse(const std::string& code, const std::string& message, std::optional<uint32_t> id) {
    server_.metrics.count_error(code);
    send_text(protocol::error_reply(code, message, id));
    if (++bad_in_row_ > server_.options.limits.max_bad_messages || code == protocol::code::kUnauthorized) {
      closing_ = true;
      close_down();
      ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, "too many bad messages"),
                      [self = shared_from_this()](beast::error_code) {});
    }
  }

  std::shared_ptr<Dataset> need_dataset(uint32_t id) {
    std::lock_guard lock(mutex_);
    if (!state_.dataset) throw protocol::ProtocolError(protocol::code::kNoDataset, "open a dataset first (dataset.open)", id);
    return state_.dataset;
  }

  void apply(const protocol::Envelope& envelope) {
    using namespace protocol;
    const uint32_t id = envelope.id;
    Pending wanted = Pending::kStill;
    bool interacting = false;
    bool reply_only = false;  // hello, dataset.open (schedules itself), ping
    std::visit([&](const auto& message) {
      using T = std::decay_t<decltype(message)>;
      [[maybe_unused]] const T* m = &message;
      if constexpr (std::is_same_v<T, Hello>) {
        if (!server_.options.token.empty() && !m->token.empty() && !server_.token_matches(m->token))
          throw ProtocolError(code::kUnauthorized, "wrong token", id);
        hello_ = true;
        const auto& o = server_.options;
        const auto& l = o.limits;
        nlohmann::json colormaps = nlohmann::json::object();  // for the client's legend and editor
        for (const char* name : {"viridis", "plasma", "cool-warm", "grayscale"}) {
          nlohmann::json samples = nlohmann::json::array();
          for (int i = 0; i < 32; ++i) {
            const auto rgb = renderer::colormap(name, i / 31.0);
            samples.push_back({std::round(rgb[0] * 1000) / 1000, std::round(rgb[1] * 1000) / 1000, std::round(rgb[2] * 1000) / 1000});
          }
          colormaps[name] = samples;
        }
        send_text(nlohmann::json({{"type", "hello.ok"},
                                  {"id", id},
                                  {"version", kVersion},
                                  {"server", "tetrascope"},
                                  {"renderer", server_.pool->description()},
                                  {"limits",
                                   {{"max_message_bytes", l.max_message_bytes},
                                    {"max_messages_per_second", l.max_messages_per_second},
                                    {"max_image_side", l.max_image_side},
                                    {"max_isovalues", l.max_isovalues},
                                    {"max_tf_points", l.max_tf_points}}},
                                  {"colormaps", colormaps},
                                  {"defaults",
                                   {{"budget", o.still_budget},
                                    {"interaction_budget", o.interaction_budget},
                                    {"interaction_quality", o.interaction_quality},
                                    {"still_quality", o.still_quality},
                                    {"max_fps", o.max_fps},
                                    {"still_delay_ms", o.still_delay.count()}}}})
                      .dump());
        reply_only = true;
        return;
      }
      if constexpr (std::is_same_v<T, DatasetOpen>) {
        std::shared_ptr<Dataset> dataset;
        try {
          dataset = server_.datasets->open(m->name);
        } catch (const NotFound& e) {
          throw ProtocolError(code::kNotFound, e.what(), id);
        } catch (const std::exception& e) {
          throw ProtocolError(code::kNotFound, std::string("cannot open '") + m->name + "': " + e.what(), id);
        }
        nlohmann::json info = dataset->info;
        const lod::Camera camera = opening_camera(dataset->store->manifest().bounds);
        info["type"] = "dataset.info";
        info["id"] = id;
        info["camera"] = {{"eye", camera.eye}, {"target", camera.target}, {"up", camera.up}, {"fov", camera.fov_degrees}};
        {
          std::lock_guard lock(mutex_);
          state_.dataset = dataset;
          state_.camera_set = false;
          state_.tf = lod::TransferFunction{};
          state_.isovalues.clear();
          state_.color_by.clear();
          state_.message_id = id;
        }
        send_text(info.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
        schedule(Pending::kStill);
        reply_only = true;
        return;
      }
      if constexpr (std::is_same_v<T, CameraSet>) {
        need_dataset(id);
        std::lock_guard lock(mutex_);
        state_.camera.eye = m->eye;
        state_.camera.target = m->target;
        state_.camera.up = m->up;
        state_.camera.fov_degrees = m->fov;
        state_.camera.orthographic = m->orthographic;
        state_.camera.ortho_height = m->height;
        state_.camera_set = true;
        state_.message_id = id;
        interacting = m->interacting;
      } else if constexpr (std::is_same_v<T, TfSet>) {
        auto dataset = need_dataset(id);
        lod::TransferFunction tf;
        try {
          tf = lod::TransferFunction::from_json(m->tf);
        } catch (const std::invalid_argument& e) {
          throw ProtocolError(code::kBadField, e.what(), id);
        }
        if (!renderer::known_colormap(tf.colormap)) throw ProtocolError(code::kBadField, "colormap: unknown '" + tf.colormap + "' (viridis, plasma, cool-warm, grayscale)", id);
        check_attribute(*dataset, tf.attribute, id);
        std::lock_guard lock(mutex_);
        state_.tf = tf;
        state_.message_id = id;
        interacting = true;  // the editor sends a stream of these while dragging
      } else if constexpr (std::is_same_v<T, ModeSet>) {
        std::lock_guard lock(mutex_);
        state_.dvr = m->dvr;
        state_.iso = m->iso;
        state_.surface = m->surface;
        if (m->wireframe) state_.wireframe = *m->wireframe;
        if (m->box) state_.box = *m->box;
        state_.message_id = id;
      } else if constexpr (std::is_same_v<T, IsoSet>) {
        if (m->color_by && !m->color_by->empty()) check_attribute(*need_dataset(id), *m->color_by, id);
        std::lock_guard lock(mutex_);
        state_.isovalues = m->values;
        if (m->opacity) state_.iso_opacity = *m->opacity;
        if (m->color_by) state_.color_by = *m->color_by;
        state_.message_id = id;
        interacting = true;  // the isovalue slider
      } else if constexpr (std::is_same_v<T, LodSet>) {
        std::lock_guard lock(mutex_);
        if (m->budget) state_.budget = *m->budget;
        if (m->interaction_budget) state_.interaction_budget = *m->interaction_budget;
        state_.message_id = id;
      } else if constexpr (std::is_same_v<T, ViewResize>) {
        std::lock_guard lock(mutex_);
        state_.width = m->width;
        state_.height = m->height;
        state_.message_id = id;
      } else if constexpr (std::is_same_v<T, QualitySet>) {
        std::lock_guard lock(mutex_);
        if (m->interaction) state_.interaction_quality = *m->interaction;
        if (m->still) state_.still_quality = *m->still;
        if (m->still_codec) state_.png_stills = *m->still_codec == "png";
        if (m->interaction_scale) state_.interaction_scale = *m->interaction_scale;
        state_.message_id = id;
      } else if constexpr (std::is_same_v<T, Ping>) {
        send_text(pong_reply(id));
        reply_only = true;
        return;
      }
    }, envelope.message);
    if (reply_only) return;
    if (interacting) {
      wanted = Pending::kInteraction;
      still_timer_.expires_after(server_.options.still_delay);
      still_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
        if (!ec) self->schedule(Pending::kStill);
      });
    }
    schedule(wanted);
  }

  static void check_attribute(const Dataset& dataset, const std::string& name, uint32_t id) {
    if (name.empty()) return;
    for (const auto& a : dataset.store->manifest().attributes)
      if (a.name == name) return;
    std::string names;
    for (const auto& a : dataset.store->manifest().attributes) names += (names.empty() ? "" : ", ") + a.name;
    throw protocol::ProtocolError(protocol::code::kNotFound, "no attribute '" + name + "' in " + dataset.name + " (it has: " + names + ")", id);
  }

  // Any thread.
  void schedule(Pending kind) {
    std::unique_lock lock(mutex_);
    if (!state_.dataset || closed_) return;
    pending_ = kind;
    if (busy_) return;  // the queued or running turn takes the newest state
    busy_ = true;
    lock.unlock();
    submit_paced();
  }

  // Any thread; busy_ is set.
  void submit_paced() {
    const auto delay = next_allowed_.load() - Clock::now();
    if (delay <= Clock::duration::zero()) {
      server_.pool->submit([self = shared_from_this()](Worker& worker) { self->render_turn(worker); });
      return;
    }
    net::post(ws_.get_executor(), [self = shared_from_this(), delay] {
      self->pace_timer_.expires_after(delay);
      self->pace_timer_.async_wait([self](beast::error_code) {
        self->server_.pool->submit([self](Worker& worker) { self->render_turn(worker); });
      });
    });
  }

  // On a pool worker.
  void render_turn(Worker& worker) {
    Pending kind;
    ViewState snapshot;
    uint32_t number;
    {
      std::lock_guard lock(mutex_);
      kind = pending_;
      pending_ = Pending::kNone;
      if (kind == Pending::kNone || closed_) {
        busy_ = false;
        return;
      }
      snapshot = state_;
      number = ++frame_number_;
    }
    const auto start = Clock::now();
    next_allowed_ = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / std::max(0.1, server_.options.max_fps)));
    try {
      RenderedFrame frame = view_.render(snapshot, kind == Pending::kStill, worker, number);
      server_.metrics.render_ms.observe(frame.header.render_ms);
      server_.metrics.encode_ms.observe(frame.header.encode_ms);
      server_.metrics.cut_ms.observe(frame.cut_ms);
      server_.metrics.assemble_ms.observe(frame.assemble_ms);
      server_.metrics.upload_ms.observe(frame.upload_ms);
      server_.metrics.draw_ms.observe(frame.draw_ms);
      ++(kind == Pending::kStill ? server_.metrics.frames_still : server_.metrics.frames_interaction);
      server_.metrics.frame_bytes += frame.bytes.size();
      net::post(ws_.get_executor(), [self = shared_from_this(), bytes = std::move(frame.bytes)]() mutable { self->send_frame(std::move(bytes)); });
    } catch (const std::invalid_argument& e) {
      const std::string reply = protocol::error_reply(protocol::code::kBadField, e.what(), snapshot.message_id);
      server_.metrics.count_error(protocol::code::kBadField);
      net::post(ws_.get_executor(), [self = shared_from_this(), reply] { self->send_text(reply); });
    } catch (const std::exception& e) {
      const std::string reply = protocol::error_reply(protocol::code::kInternal, std::string("rendering failed: ") + e.what(), snapshot.message_id);
      server_.metrics.count_error(protocol::code::kInternal);
      net::post(ws_.get_executor(), [self = shared_from_this(), reply] { self->send_text(reply); });
    }
    {
      std::lock_guard lock(mutex_);
      if (pending_ == Pending::kNone || closed_) {
        busy_ = false;
        return;
      }
    }
    submit_paced();
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
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    still_timer_.cancel();
    pace_timer_.cancel();
  }

  Server::Impl& server_;
  websocket::stream<beast::tcp_stream> ws_;
  net::steady_timer still_timer_, pace_timer_;
  beast::flat_buffer buffer_;
  // strand only
  bool hello_ = false, closing_ = false, writing_ = false;
  uint32_t bad_in_row_ = 0, window_count_ = 0;
  Clock::time_point window_start_{};
  std::deque<std::string> texts_;
  std::optional<std::vector<uint8_t>> waiting_frame_;
  std::vector<uint8_t> frame_in_flight_;
  // shared with the render turn
  std::mutex mutex_;
  ViewState state_;
  Pending pending_ = Pending::kNone;
  bool busy_ = false, closed_ = false;
  uint32_t frame_number_ = 0;
  std::atomic<Clock::time_point> next_allowed_{Clock::time_point{}};
  // render turn only (one at a time)
  ViewRenderer view_;
};

}  // namespace

void start_ws_session(Server::Impl& server, beast::tcp_stream stream, http::request<http::empty_body> request) {
  std::make_shared<WsSession>(server, std::move(stream))->start(std::move(request));
}

}  // namespace tetrascope::server
