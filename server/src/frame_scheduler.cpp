// When a viewing session's frames are drawn, and the render turn (frame_scheduler.h).
#include "frame_scheduler.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace tetrascope::server {

FrameScheduler::FrameScheduler(Server::Impl& server, SessionState& shared, Link link)
    : server_(server), shared_(shared), link_(std::move(link)), still_timer_(link_.strand), pace_timer_(link_.strand) {}

void FrameScheduler::request(FrameRequest kind) {
  if (kind == FrameRequest::kPlaying) still_timer_.cancel();  // a play: the next step comes, no still
  if (kind == FrameRequest::kInteraction) {
    still_timer_.expires_after(server_.options.still_delay);
    still_timer_.async_wait([this, keep = link_.hold()](const boost::system::error_code& ec) {
      if (!ec) schedule(Pending::kRefine);
    });
  }
  schedule(kind == FrameRequest::kStill ? Pending::kRefine : Pending::kInteraction);
}

void FrameScheduler::close() {
  {
    std::lock_guard lock(shared_.mutex);
    closed_ = true;
  }
  still_timer_.cancel();
  pace_timer_.cancel();
}

// An error's text as a client may see it: no path on the server, paths inside the data
// folder relative to it.
std::string FrameScheduler::client_text(const std::string& message) const { return without_server_paths(message, server_.options.data_dir); }

// Any thread.
void FrameScheduler::post_text(std::string text) {
  net::post(link_.strand, [this, keep = link_.hold(), text = std::move(text)] { link_.send_text(text); });
}

void FrameScheduler::probe(ViewState snapshot, double x, double y, uint32_t id) {
  server_.pool->submit([this, keep = link_.hold(), snapshot = std::move(snapshot), x, y, id](Worker&) {
    std::string reply;
    try {
      std::lock_guard frames(frames_mutex_);
      reply = frames_.probe(snapshot, x, y, id);
    } catch (const std::exception& e) {
      if (is_store_damage(e)) server_.datasets->close_damaged(snapshot.dataset, e.what());
      reply = protocol::error_reply(is_store_damage(e) ? protocol::code::kDatasetDamaged : protocol::code::kInternal,
                                    "probe failed: " + client_text(e.what()), id);
    }
    post_text(std::move(reply));
  });
}

// Any thread.
void FrameScheduler::schedule(Pending kind) {
  std::unique_lock lock(shared_.mutex);
  if (!shared_.state.dataset || closed_) return;
  shared_.pending = kind;
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
void FrameScheduler::submit_paced(uint64_t ticket, Pending kind) {
  auto task = [this, keep = link_.hold(), ticket](Worker& worker) { render_turn(worker, ticket); };
  if (kind == Pending::kRefine) {
    server_.pool->submit(std::move(task), RenderPool::Priority::kRefinement);
    return;
  }
  const auto delay = next_allowed_.load() - Clock::now();
  if (delay <= Clock::duration::zero()) {
    server_.pool->submit(std::move(task));
    return;
  }
  net::post(link_.strand, [this, keep = link_.hold(), delay, task = std::move(task)]() mutable {
    pace_timer_.expires_after(delay);
    pace_timer_.async_wait([this, task = std::move(task)](const boost::system::error_code&) mutable { server_.pool->submit(std::move(task)); });
  });
}

// On a pool worker.
void FrameScheduler::render_turn(Worker& worker, uint64_t ticket) {
  const std::optional<Turn> turn = start_turn(ticket);
  if (!turn) return;
  draw(worker, *turn);
  end_turn();
}

// The state to draw and the plan, or none: a stale ticket, or nothing (left) to draw.
std::optional<FrameScheduler::Turn> FrameScheduler::start_turn(uint64_t ticket) {
  Turn turn;
  FramePlan& plan = turn.plan;
  {
    std::lock_guard lock(shared_.mutex);
    if (ticket != ticket_) return std::nullopt;  // overtaken by an interaction task, which owns busy_ now
    queued_refinement_ = false;
    const Pending kind = shared_.pending;
    shared_.pending = Pending::kNone;
    // no dataset: it was deleted while the step before was drawing, which then asked for
    // the next step (ManageTest.DeletingADatasetWhileItsSessionRefinesNeverCrashesTheServer)
    if (kind == Pending::kNone || closed_ || !shared_.state.dataset) {
      busy_ = false;
      return std::nullopt;
    }
    turn.snapshot = shared_.state;
    turn.number = ++frame_number_;
    turn.epoch = shared_.input_epoch;
    plan.refinement = kind == Pending::kRefine;
    plan.step = refine_step_;
    plan.previous_budget = refine_budget_;
  }
  if (plan.refinement) {
    // the pool by address: a server being stopped has reset its pointer while the pool's
    // destructor waits for this turn
    plan.should_stop = [this, epoch = turn.epoch, pool = server_.pool.get()] {
      return shared_.input_epoch.load(std::memory_order_relaxed) != epoch || pool->interaction_waiting();
    };
  }
  if (!plan.refinement) {
    // more interaction frames waiting than workers: each aims at a share of the frame time
    // (down to a quarter), so many sessions keep moving with coarser frames rather than
    // every session's frames coming slowly (16 clients and more)
    const RenderPool& pool = *server_.pool;
    plan.frame_ms = shared_frame_ms(server_.options.frame_ms, pool.interaction_queued(), pool.workers());
  }
  return turn;
}

// Draws the turn's frame and hands it on; what fails is told to the client, and store damage
// closes the dataset.
void FrameScheduler::draw(Worker& worker, const Turn& turn) {
  const FramePlan& plan = turn.plan;
  const auto start = Clock::now();
  if (!plan.refinement)
    next_allowed_ = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / std::max(0.1, server_.options.max_fps)));
  try {
    std::unique_lock frames(frames_mutex_);  // a probe may be using the pipeline
    RenderedFrame frame = frames_.render(turn.snapshot, plan, server_.frame_cost, server_.options, worker, turn.number);
    frames.unlock();
    if (frame.interrupted) {
      ++server_.metrics.frames_interrupted;
      std::lock_guard lock(shared_.mutex);
      // stopped for another session's interaction frame: this step again, once a worker is idle
      if (shared_.pending == Pending::kNone && shared_.input_epoch == turn.epoch) {
        shared_.pending = Pending::kRefine;
      }
    } else {
      on_drawn(turn, frame);
    }
  } catch (const std::invalid_argument& e) {
    const std::string reply = protocol::error_reply(protocol::code::kBadField, client_text(e.what()), turn.snapshot.message_id);
    server_.metrics.count_error(protocol::code::kBadField);
    post_text(reply);
  } catch (const std::exception& e) {
    if (is_store_damage(e)) {
      // a segment or variant failed its check: the dataset closes for every session viewing it
      // (each is told dataset_damaged), this one included
      server_.datasets->close_damaged(turn.snapshot.dataset, e.what());
    } else {
      const std::string reply = protocol::error_reply(protocol::code::kInternal, "rendering failed: " + client_text(e.what()), turn.snapshot.message_id);
      server_.metrics.count_error(protocol::code::kInternal);
      post_text(reply);
    }
  }
}

// A frame drawn to the end: the cost model and metrics learn from it, a refinement step asks
// for the next, and the frame goes to the connection.
void FrameScheduler::on_drawn(const Turn& turn, RenderedFrame& frame) {
  const FramePlan& plan = turn.plan;
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
    std::lock_guard lock(shared_.mutex);
    if (shared_.pending == Pending::kNone && shared_.input_epoch == turn.epoch) {  // no input since: the next step
      shared_.pending = Pending::kRefine;
      refine_step_ = plan.step + 1;
      refine_budget_ = frame.budget;
    }
  }
  net::post(link_.strand, [this, keep = link_.hold(), bytes = std::move(frame.bytes), of = turn.snapshot.dataset.get()]() mutable {
    deliver(std::move(bytes), of);
  });
}

// The next turn if something is pending, else the session is idle.
void FrameScheduler::end_turn() {
  Pending next;
  uint64_t next_ticket;
  {
    std::lock_guard lock(shared_.mutex);
    if (shared_.pending == Pending::kNone || closed_ || !shared_.state.dataset) {
      busy_ = false;
      return;
    }
    next = shared_.pending;
    queued_refinement_ = next == Pending::kRefine;
    next_ticket = ++ticket_;
  }
  submit_paced(next_ticket, next);
}

// Strand.
void FrameScheduler::deliver(std::vector<uint8_t> bytes, const Dataset* of) {
  {
    std::lock_guard lock(shared_.mutex);
    if (shared_.state.dataset.get() != of) return;  // drawn before its dataset was deleted or another opened: after their replies, never
  }
  link_.send_frame(std::move(bytes));
}

}  // namespace tetrascope::server
