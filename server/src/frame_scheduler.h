// When a viewing session's frames are drawn (FrameScheduler): pacing, the still timer,
// interaction frames and refinement steps, and the render turn on a pool worker.
//
// Network work runs on the session's strand; renders run on the pool. What the two share
// (the view state, what is pending) sits under the session's mutex (session_state.h).
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
//  - a frame reaches the connection only while its dataset is still the one open.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "server_impl.h"
#include "session_state.h"

namespace tetrascope::server {

class FrameScheduler {
 public:
  // What the scheduler asks of its connection. The callbacks are called on `strand`.
  struct Link {
    net::any_io_executor strand;                             // the connection's: timers and deliveries run on it
    std::function<std::shared_ptr<void>()> hold;             // a share in what owns this scheduler, held by each task and timer
    std::function<void(std::string)> send_text;              // a reply (render errors, probe results)
    std::function<void(std::vector<uint8_t>)> send_frame;    // a frame, latest wins
  };

  FrameScheduler(Server::Impl& server, SessionState& shared, Link link);

  // Strand. Frames for what a message changed: an interaction frame (paced to max_fps) and
  // refinement still_delay after the last of them, or refinement up to a still at once.
  void request(FrameRequest kind);
  // Any thread. Answers probe.result (or an error) through send_text, from a pool worker,
  // between (never during) the session's render turns.
  void probe(ViewState snapshot, double x, double y, uint32_t id);
  // Strand. The connection is closing: no turn after the running one, timers off.
  void close();

 private:
  using Clock = std::chrono::steady_clock;
  // What one render turn draws, taken under the lock when it starts.
  struct Turn {
    ViewState snapshot;
    FramePlan plan;
    uint32_t number = 0;
    uint64_t epoch = 0;
  };

  void schedule(Pending kind);
  void submit_paced(uint64_t ticket, Pending kind);
  void render_turn(Worker& worker, uint64_t ticket);
  std::optional<Turn> start_turn(uint64_t ticket);
  void draw(Worker& worker, const Turn& turn);
  void on_drawn(const Turn& turn, RenderedFrame& frame);
  void end_turn();
  void deliver(std::vector<uint8_t> bytes, const Dataset* of);
  void post_text(std::string text);
  std::string client_text(const std::string& message) const;

  Server::Impl& server_;
  SessionState& shared_;
  const Link link_;
  net::steady_timer still_timer_, pace_timer_;  // strand only
  // under shared_.mutex
  bool busy_ = false, closed_ = false;
  bool queued_refinement_ = false;  // busy_ with a refinement task not yet started
  uint64_t ticket_ = 0;             // of the one task that may run the next turn (older ones are stale)
  uint32_t refine_step_ = 0;        // of the next refinement step
  uint64_t refine_budget_ = 0;      // tet budget of the step before
  uint32_t frame_number_ = 0;
  static constexpr uint64_t kCostReportEvery = 16;  // interaction frames between updates of the prediction-error gauges
  uint64_t cost_reports_ = 0;       // render turns only
  std::atomic<Clock::time_point> next_allowed_{Clock::time_point{}};
  // render turn and probes, one at a time
  std::mutex frames_mutex_;
  FrameMaker frames_;
};

}  // namespace tetrascope::server
