// A viewing session's control messages and what they change (ViewSession), apart from the
// socket that carries them (session.cpp) and the scheduling of the frames they ask for
// (frame_scheduler.h): a handler per message (`on_message`), the limits on messages (rate,
// hello first, bad ones in a row), the checks against the open dataset, and the watch on that
// dataset (deleted or found damaged). Messages arrive untrusted and are checked here.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "server_impl.h"
#include "session_state.h"

namespace tetrascope::server {

class ViewSession {
 public:
  // What a ViewSession asks of the rest of its session, so that it runs without a socket or a
  // pool. Every callback but `hold` is called on `strand`.
  struct Link {
    net::any_io_executor strand;                          // where messages are handled; dataset watchers post to it
    std::function<std::shared_ptr<void>()> hold;          // a share in what owns this ViewSession, held by what it posts
    std::function<void(std::string)> send_text;           // a reply, after every reply before it
    std::function<void()> said_hello;                     // hello accepted: no hello timeout any more
    std::function<void()> close;                          // too many bad messages, or a wrong token: the connection closes
    std::function<void(FrameRequest)> request_frames;     // frames for what a message changed
    std::function<void(ViewState, double x, double y, uint32_t id)> probe;  // answered later through send_text
  };

  // Sets the session's defaults from the server's options into `shared`.
  ViewSession(Server::Impl& server, SessionState& shared, Link link);

  // Strand. One message as it came off the socket (untrusted): applied, or answered with an
  // error reply (and the connection closed after max_bad_messages of these in a row).
  void handle(bool text, const std::string& message);
  bool said_hello() const { return hello_; }

 private:
  // What a message asks for once applied: nothing more (a reply was sent), refinement up to a
  // still, or an interaction frame with refinement after still_delay.
  enum class Then { kReplied, kStill, kInteraction, kPlaying };

  void apply(const protocol::Envelope& envelope);
  void refuse(const std::string& code, const std::string& message, std::optional<uint32_t> id);
  std::string client_text(const std::string& message) const;
  std::shared_ptr<Dataset> need_dataset(uint32_t id);
  template <class Change>
  void change_state(uint32_t id, Change change);
  void watch(const std::shared_ptr<Dataset>& dataset);
  void on_dataset_closed(const Dataset* closed, const std::string& code, const std::string& message);

  Then on_message(const protocol::Hello& m, uint32_t id);
  Then on_message(const protocol::DatasetOpen& m, uint32_t id);
  Then on_message(const protocol::CameraSet& m, uint32_t id);
  Then on_message(const protocol::TfSet& m, uint32_t id);
  Then on_message(const protocol::ModeSet& m, uint32_t id);
  Then on_message(const protocol::IsoSet& m, uint32_t id);
  Then on_message(const protocol::LodSet& m, uint32_t id);
  Then on_message(const protocol::ViewResize& m, uint32_t id);
  Then on_message(const protocol::QualitySet& m, uint32_t id);
  Then on_message(const protocol::LinesSet& m, uint32_t id);
  Then on_message(const protocol::PointsSet& m, uint32_t id);
  Then on_message(const protocol::Ping& m, uint32_t id);
  Then on_message(const protocol::ClipSet& m, uint32_t id);
  Then on_message(const protocol::SliceSet& m, uint32_t id);
  Then on_message(const protocol::Probe& m, uint32_t id);
  Then on_message(const protocol::RegionsSet& m, uint32_t id);
  Then on_message(const protocol::TensorsSet& m, uint32_t id);
  Then on_message(const protocol::TimeSet& m, uint32_t id);

  Server::Impl& server_;
  SessionState& shared_;
  const Link link_;
  // strand only
  bool hello_ = false;
  uint32_t bad_in_row_ = 0, window_count_ = 0;
  std::chrono::steady_clock::time_point window_start_{};
};

}  // namespace tetrascope::server
