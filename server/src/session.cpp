// One WebSocket viewing session (Beast: one class per concern, do_x / on_x, explicit limits).
//
// Network work runs on the session's strand; renders run on the pool. What the two share
// (the view state, what is pending) sits under `mutex_`. Scheduling:
//  - a control message updates the state and asks for a frame (interaction or refinement);
//  - a session has at most one pool task queued or running (`busy_`); the task renders the
//    newest state when it starts, so a burst of camera moves renders once;
//  - interaction frames start no faster than max_fps and go to the pool's interaction
//    queue; their tets come from the frame-time model (frame_maker.cpp);
//  - still_delay after the last interacting message (at once after other changes),
//    refinement: steps of growing budget, each a frame flagged refining, the last the still
//    (full budget, quality, size); the steps go to the pool's refinement queue, which runs
//    only when no interaction frame waits;
//  - any input stops a running step between chunks of its draw (should_stop: the input
//    epoch moved) and the frame is dropped; so does another session's interaction frame
//    waiting for a worker (the step is queued again); a refinement task still queued when
//    input comes is overtaken by an interaction task;
//  - outgoing: replies in order; frames latest-wins, one in flight and one waiting.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <mutex>
#include <optional>

#include <boost/beast/websocket.hpp>

#include "frame_maker.h"
#include "line_request.h"
#include "server_impl.h"
#include "session_replies.h"

namespace tetrascope::server {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using Clock = std::chrono::steady_clock;

enum class Pending { kNone, kInteraction, kRefine };

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(Server::Impl& server, beast::tcp_stream stream)
      : server_(server), ws_(std::move(stream)), still_timer_(ws_.get_executor()), pace_timer_(ws_.get_executor()), hello_timer_(ws_.get_executor()) {
    ++server_.metrics.sessions_active;
    ++server_.metrics.sessions_total;
    const auto& o = server_.options;
    state_.view.budget = o.still_budget;
    state_.interaction_budget = o.interaction_budget;
    state_.max_error = 0;
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
    ws_.read_message_max(kHardCapFactor * server_.options.limits.max_message_bytes);
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

 private:
  void on_accept(beast::error_code ec) {
    if (ec) return;
    // a connection that never says hello would hold a session slot: it gets hello_timeout
    hello_timer_.expires_after(server_.options.hello_timeout);
    hello_timer_.async_wait([self = shared_from_this()](beast::error_code wait_ec) {
      if (wait_ec || self->hello_) return;
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
      refuse(e.code(), client_text(e.what()), e.id());
    } catch (const std::exception& e) {
      // whatever a message makes fail stays in this session's reply, never the process's end
      refuse(protocol::code::kInternal, client_text(e.what()), std::nullopt);
    }
  }

  // An error's text as a client may see it: no path on the server, paths inside the data
  // folder relative to it.
  std::string client_text(const std::string& message) const { return without_server_paths(message, server_.options.data_dir); }

  void refuse(const std::string& code, const std::string& message, std::optional<uint32_t> id) {
    server_.metrics.count_error(code);
    send_text(protocol::error_reply(code, message, id));
    if (++bad_in_row_ >= server_.options.limits.max_bad_messages || code == protocol::code::kUnauthorized) {
      closing_ = true;
      close_down();
      ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, "too many bad messages"),
                      [self = shared_from_this()](beast::error_code) {});
    }
  }

  [[noreturn]] static void no_dataset(uint32_t id) { throw protocol::ProtocolError(protocol::code::kNoDataset, "open a dataset first (dataset.open)", id); }
  std::shared_ptr<Dataset> need_dataset(uint32_t id) {
    std::lock_guard lock(mutex_);
    if (!state_.dataset) no_dataset(id);
    return state_.dataset;
  }

  // What a message asks for once applied: nothing more (a reply was sent), refinement up to a
  // still, or an interaction frame with refinement after still_delay.
  enum class Then { kReplied, kStill, kInteraction };

  void apply(const protocol::Envelope& envelope) {
    const Then then = std::visit([&](const auto& message) { return on_message(message, envelope.id); }, envelope.message);
    if (then == Then::kReplied) return;
    if (then == Then::kInteraction) {
      still_timer_.expires_after(server_.options.still_delay);
      still_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
        if (!ec) self->schedule(Pending::kRefine);
      });
    }
    schedule(then == Then::kInteraction ? Pending::kInteraction : Pending::kRefine);
  }

  // Updates the shared view state under the lock and records the message as the newest applied.
  template <class Change>
  void change_state(uint32_t id, Change change) {
    std::lock_guard lock(mutex_);
    change(state_);
    state_.message_id = id;
    ++input_epoch_;  // a refinement step under way stops at its next chunk
  }

  Then on_message(const protocol::Hello& m, uint32_t id) {
    if (!server_.options.token.empty() && !m.token.empty() && !server_.token_matches(m.token))
      throw protocol::ProtocolError(protocol::code::kUnauthorized, "wrong token", id);
    hello_ = true;
    hello_timer_.cancel();
    send_text(hello_ok_reply(server_.options, server_.pool->description(), id));
    return Then::kReplied;
  }

  Then on_message(const protocol::DatasetOpen& m, uint32_t id) {
    std::shared_ptr<Dataset> dataset;
    try {
      dataset = server_.datasets->open(m.name);
    } catch (const NotFound& e) {
      throw protocol::ProtocolError(protocol::code::kNotFound, e.what(), id);
    } catch (const DatasetDamaged& e) {
      throw protocol::ProtocolError(protocol::code::kDatasetDamaged, e.what(), id);
    } catch (const std::exception& e) {
      throw protocol::ProtocolError(protocol::code::kNotFound, std::string("cannot open '") + m.name + "': " + e.what(), id);
    }
    change_state(id, [&](ViewState& s) {
      s.dataset = dataset;
      s.view.camera.reset();
      s.view.tf = lod::TransferFunction{};
      s.view.isovalues.clear();
      s.view.iso_color_attribute.clear();
      s.view.line = renderer::LineRequest{};  // fields and seeds of the last dataset
      s.view.clip = {};
      s.view.slices = {};
    });
    // DELETE /api/v1/datasets/NAME, or a check its store fails, closes the dataset for its
    // sessions: this one is told
    dataset->watch(weak_from_this(), [weak = weak_from_this(), raw = dataset.get()](const std::string& code, const std::string& message) {
      if (auto self = weak.lock()) net::post(self->ws_.get_executor(), [self, raw, code, message] { self->on_dataset_closed(raw, code, message); });
    });
    send_text(dataset_info_reply(*dataset, lod::default_camera(dataset->store->manifest().bounds), id));
    schedule(Pending::kRefine);
    return Then::kReplied;
  }

  // Strand. The dataset shown was deleted or found damaged: no more frames of it, and the
  // client hears why.
  void on_dataset_closed(const Dataset* closed, const std::string& code, const std::string& message) {
    {
      std::lock_guard lock(mutex_);
      if (state_.dataset.get() != closed) return;  // another dataset is open by now
      state_.dataset.reset();
      pending_ = Pending::kNone;
      ++input_epoch_;  // a step under way stops at its next chunk and asks for no next one
    }
    server_.metrics.count_error(code);
    send_text(protocol::error_reply(code, message, std::nullopt));
  }

  Then on_message(const protocol::CameraSet& m, uint32_t id) {
    need_dataset(id);
    lod::Camera camera;
    camera.eye = m.eye;
    camera.target = m.target;
    camera.up = m.up;
    camera.fov_degrees = m.fov;
    camera.orthographic = m.orthographic;
    camera.ortho_height = m.height;
    change_state(id, [&](ViewState& s) { s.view.camera = camera; });
    return m.interacting ? Then::kInteraction : Then::kStill;
  }

  Then on_message(const protocol::TfSet& m, uint32_t id) {
    check_attribute(*need_dataset(id), m.tf.attribute, id);
    change_state(id, [&](ViewState& s) { s.view.tf = m.tf; });
    return Then::kInteraction;  // the editor sends a stream of these while dragging
  }

  Then on_message(const protocol::ModeSet& m, uint32_t id) {
    change_state(id, [&](ViewState& s) {
      s.view.dvr = m.dvr;
      s.view.iso = m.iso;
      s.view.surface = m.surface;
      s.view.lines = m.lines;
      s.view.points = m.points;
      if (m.wireframe) s.view.wireframe = *m.wireframe;
      if (m.box) s.view.box = *m.box;
    });
    return Then::kStill;
  }

  Then on_message(const protocol::IsoSet& m, uint32_t id) {
    if (m.color_by && !m.color_by->empty()) check_attribute(*need_dataset(id), *m.color_by, id);
    change_state(id, [&](ViewState& s) {
      s.view.isovalues = m.values;
      if (m.opacity) s.view.iso_opacity = *m.opacity;
      if (m.color_by) s.view.iso_color_attribute = *m.color_by;
    });
    return Then::kInteraction;  // the isovalue slider
  }

  Then on_message(const protocol::LodSet& m, uint32_t id) {
    change_state(id, [&](ViewState& s) {
      if (m.budget) s.view.budget = *m.budget;
      if (m.interaction_budget) s.interaction_budget = *m.interaction_budget;
      if (m.max_error) s.max_error = *m.max_error;
    });
    return Then::kStill;
  }

  Then on_message(const protocol::ViewResize& m, uint32_t id) {
    change_state(id, [&](ViewState& s) {
      s.view.width = m.width;
      s.view.height = m.height;
    });
    return Then::kStill;
  }

  Then on_message(const protocol::QualitySet& m, uint32_t id) {
    change_state(id, [&](ViewState& s) {
      if (m.interaction) s.interaction_quality = *m.interaction;
      if (m.still) s.still_quality = *m.still;
      if (m.still_codec) s.png_stills = *m.still_codec == "png";
      if (m.interaction_scale) s.interaction_scale = *m.interaction_scale;
    });
    return Then::kStill;
  }

  Then on_message(const protocol::LinesSet& m, uint32_t id) {
    if (m.field) check_vector_field(*need_dataset(id), *m.field, id);
    change_state(id, [&](ViewState& s) { apply_lines_set(m, s.view.line); });
    if (is_animation_step(m)) return Then::kInteraction;  // the viewer's dash animation
    return Then::kStill;  // tracing takes a while: one still, not a burst of interaction frames
  }

  Then on_message(const protocol::PointsSet& m, uint32_t id) {
    change_state(id, [&](ViewState& s) { apply_points_set(m, s.view); });
    return Then::kStill;
  }

  Then on_message(const protocol::Ping&, uint32_t id) {
    send_text(protocol::pong_reply(id));
    return Then::kReplied;
  }

  // clip.set and slice.set: the planes replace the session's; a drag streams these.
  Then on_message(const protocol::ClipSet& m, uint32_t id) {
    change_state(id, [&](ViewState& s) { s.view.clip = m.clip; });
    return Then::kInteraction;
  }

  Then on_message(const protocol::SliceSet& m, uint32_t id) {
    change_state(id, [&](ViewState& s) { s.view.slices = m.slice; });
    return Then::kInteraction;
  }

  // probe: answered from a pool worker, between (never during) the session's render turns
  Then on_message(const protocol::Probe& m, uint32_t id) {
    ViewState snapshot;
    {
      std::lock_guard lock(mutex_);
      snapshot = state_;
    }
    if (!snapshot.dataset) no_dataset(id);  // deleted (the strand sets it) or never opened
    server_.pool->submit([self = shared_from_this(), snapshot, m, id](Worker&) {
      std::string reply;
      try {
        std::lock_guard frames(self->frames_mutex_);
        reply = self->frames_.probe(snapshot, m.x, m.y, id);
      } catch (const std::exception& e) {
        if (is_store_damage(e)) self->server_.datasets->close_damaged(snapshot.dataset, e.what());
        reply = protocol::error_reply(is_store_damage(e) ? protocol::code::kDatasetDamaged : protocol::code::kInternal,
                                      "probe failed: " + self->client_text(e.what()), id);
      }
      net::post(self->ws_.get_executor(), [self, reply] { self->send_text(reply); });
    });
    return Then::kReplied;
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
    refine_step_ = 0;  // new input: refinement starts over
    refine_budget_ = 0;
    if (busy_) {
      // a refinement task still queued would wait behind other sessions' refinement: an
      // interaction task overtakes it (the queued one finds itself stale and returns)
      if (kind == Pending::kInteraction && queued_refinement_) {
        queued_refinement_ = false;
        const uint64_t ticket = ++ticket_;
        lock.unlock();
        submit_paced(ticket, Pending::kInteraction);
      }
      return;  // the queued or running turn takes the newest state
    }
    busy_ = true;
    queued_refinement_ = kind == Pending::kRefine;
    const uint64_t ticket = ++ticket_;
    lock.unlock();
    submit_paced(ticket, kind);
  }

  // Any thread; busy_ is set. Interaction frames are paced to max_fps; refinement steps
  // follow at once, behind every interaction frame waiting.
  void submit_paced(uint64_t ticket, Pending kind) {
    auto task = [self = shared_from_this(), ticket](Worker& worker) { self->render_turn(worker, ticket); };
    if (kind == Pending::kRefine) {
      server_.pool->submit(std::move(task), RenderPool::Priority::kRefinement);
      return;
    }
    const auto delay = next_allowed_.load() - Clock::now();
    if (delay <= Clock::duration::zero()) {
      server_.pool->submit(std::move(task));
      return;
    }
    net::post(ws_.get_executor(), [self = shared_from_this(), delay, task = std::move(task)]() mutable {
      self->pace_timer_.expires_after(delay);
      self->pace_timer_.async_wait([self, task = std::move(task)](beast::error_code) mutable { self->server_.pool->submit(std::move(task)); });
    });
  }

  // On a pool worker.
  void render_turn(Worker& worker, uint64_t ticket) {
    Pending kind;
    ViewState snapshot;
    uint32_t number;
    FramePlan plan;
    uint64_t epoch;
    {
      std::lock_guard lock(mutex_);
      if (ticket != ticket_) return;  // overtaken by an interaction task, which owns busy_ now
      queued_refinement_ = false;
      kind = pending_;
      pending_ = Pending::kNone;
      // no dataset: it was deleted while the step before was drawing, which then asked for
      // the next step (ManageTest.DeletingADatasetWhileItsSessionRefinesNeverCrashesTheServer)
      if (kind == Pending::kNone || closed_ || !state_.dataset) {
        busy_ = false;
        return;
      }
      snapshot = state_;
      number = ++frame_number_;
      epoch = input_epoch_;
      plan.refinement = kind == Pending::kRefine;
      plan.step = refine_step_;
      plan.previous_budget = refine_budget_;
    }
    if (plan.refinement) {
      // the pool by address: a server being stopped has reset its pointer while the pool's
      // destructor waits for this turn
      plan.should_stop = [this, epoch, pool = server_.pool.get()] {
        return input_epoch_.load(std::memory_order_relaxed) != epoch || pool->interaction_waiting();
      };
    }
    if (!plan.refinement) {
      // more interaction frames waiting than workers: each aims at a share of the frame time
      // (down to a quarter), so many sessions keep moving with coarser frames rather than
      // every session's frames coming slowly (16 clients and more)
      const RenderPool& pool = *server_.pool;
      plan.frame_ms = shared_frame_ms(server_.options.frame_ms, pool.interaction_queued(), pool.workers());
    }
    const auto start = Clock::now();
    if (!plan.refinement)
      next_allowed_ = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / std::max(0.1, server_.options.max_fps)));
    try {
      std::unique_lock frames(frames_mutex_);  // a probe may be using the pipeline
      RenderedFrame frame = frames_.render(snapshot, plan, server_.frame_cost, server_.options, worker, number);
      frames.unlock();
      if (frame.interrupted) {
        ++server_.metrics.frames_interrupted;
        std::lock_guard lock(mutex_);
        // stopped for another session's interaction frame: this step again, once a worker is idle
        if (pending_ == Pending::kNone && input_epoch_ == epoch) {
          pending_ = Pending::kRefine;
        }
      } else {
        // the model learns from interaction frames only: refinement steps (full size, better
        // JPEG, a large cut assembled and uploaded) cost differently per tet and pixel
        if (!plan.refinement) server_.frame_cost.observe(double(frame.header.tets), frame.covered_pixels, frame.header.render_ms + frame.header.encode_ms, frame.predicted_ms);
        if (!plan.refinement && ++cost_reports_ % kCostReportEvery == 0) {
          const auto q = server_.frame_cost.prediction_error();
          server_.metrics.cost_error_p50_pct = q.p50;
          server_.metrics.cost_error_p90_pct = q.p90;
        }
        server_.metrics.render_ms.observe(frame.header.render_ms);
        server_.metrics.encode_ms.observe(frame.header.encode_ms);
        server_.metrics.cut_ms.observe(frame.timings.cut_ms);
        server_.metrics.assemble_ms.observe(frame.timings.assemble_ms);
        server_.metrics.upload_ms.observe(frame.timings.upload_ms);
        server_.metrics.draw_ms.observe(frame.timings.draw_ms);
        ++(frame.header.still ? server_.metrics.frames_still : frame.header.refining ? server_.metrics.frames_refining : server_.metrics.frames_interaction);
        server_.metrics.frame_bytes += frame.bytes.size();
        if (frame.header.refining) {
          std::lock_guard lock(mutex_);
          if (pending_ == Pending::kNone && input_epoch_ == epoch) {  // no input since: the next step
            pending_ = Pending::kRefine;
            refine_step_ = plan.step + 1;
            refine_budget_ = frame.budget;
            }
        }
        net::post(ws_.get_executor(), [self = shared_from_this(), bytes = std::move(frame.bytes), of = snapshot.dataset.get()]() mutable {
          self->send_frame(std::move(bytes), of);
        });
      }
    } catch (const std::invalid_argument& e) {
      const std::string reply = protocol::error_reply(protocol::code::kBadField, client_text(e.what()), snapshot.message_id);
      server_.metrics.count_error(protocol::code::kBadField);
      net::post(ws_.get_executor(), [self = shared_from_this(), reply] { self->send_text(reply); });
    } catch (const std::exception& e) {
      if (is_store_damage(e)) {
        // a segment or variant failed its check: the dataset closes for every session viewing it
        // (each is told dataset_damaged), this one included
        server_.datasets->close_damaged(snapshot.dataset, e.what());
      } else {
        const std::string reply = protocol::error_reply(protocol::code::kInternal, "rendering failed: " + client_text(e.what()), snapshot.message_id);
        server_.metrics.count_error(protocol::code::kInternal);
        net::post(ws_.get_executor(), [self = shared_from_this(), reply] { self->send_text(reply); });
      }
    }
    Pending next;
    uint64_t next_ticket;
    {
      std::lock_guard lock(mutex_);
      if (pending_ == Pending::kNone || closed_ || !state_.dataset) {
        busy_ = false;
        return;
      }
      next = pending_;
      queued_refinement_ = next == Pending::kRefine;
      next_ticket = ++ticket_;
    }
    submit_paced(next_ticket, next);
  }

  // Strand.
  void send_text(std::string text) {
    texts_.push_back(std::move(text));
    do_write();
  }
  void send_frame(std::vector<uint8_t> bytes, const Dataset* of) {
    {
      std::lock_guard lock(mutex_);
      if (state_.dataset.get() != of) return;  // drawn before its dataset was deleted or another opened: after their replies, never
    }
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
    hello_timer_.cancel();
  }

  Server::Impl& server_;
  websocket::stream<beast::tcp_stream> ws_;
  net::steady_timer still_timer_, pace_timer_, hello_timer_;
  static constexpr size_t kHardCapFactor = 4;  // docs/security.md: "closed past 4x the message limit"
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
  bool queued_refinement_ = false;  // busy_ with a refinement task not yet started
  uint64_t ticket_ = 0;             // of the one task that may run the next turn (older ones are stale)
  uint32_t refine_step_ = 0;        // of the next refinement step
  uint64_t refine_budget_ = 0;      // tet budget of the step before
  uint32_t frame_number_ = 0;
  std::atomic<uint64_t> input_epoch_{0};  // moves with every change of state_
  static constexpr uint64_t kCostReportEvery = 16;  // interaction frames between updates of the prediction-error gauges
  uint64_t cost_reports_ = 0;       // render turns only
  std::atomic<Clock::time_point> next_allowed_{Clock::time_point{}};
  // render turn and probes, one at a time
  std::mutex frames_mutex_;
  FrameMaker frames_;
};

}  // namespace

void start_ws_session(Server::Impl& server, beast::tcp_stream stream, http::request<http::empty_body> request) {
  std::make_shared<WsSession>(server, std::move(stream))->start(std::move(request));
}

}  // namespace tetrascope::server
