// What the parts of one viewing session share: the connection (session.cpp), its messages
// (view_session.h) and its frames in time (frame_scheduler.h). The view the client asked for
// and the frame pending sit under one mutex, so that a render turn takes both in one step and
// a dataset closed clears both in one step.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>

#include "frame_maker.h"

namespace tetrascope::server {

// The frame a session's next render turn draws.
enum class Pending { kNone, kInteraction, kRefine };

// What a message asks of the scheduler once applied: an interaction frame (with refinement
// after still_delay), refinement up to a still, or an interaction frame of a play (a time
// series' step with the next one to come: no refinement, which the next step would stop).
enum class FrameRequest { kInteraction, kStill, kPlaying };

struct SessionState {
  std::mutex mutex;  // guards state, pending and the scheduler's bookkeeping (frame_scheduler.h)
  ViewState state;
  Pending pending = Pending::kNone;
  std::atomic<uint64_t> input_epoch{0};  // moves with every change of state
};

}  // namespace tetrascope::server
