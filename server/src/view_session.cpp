// A viewing session's control messages, one handler each (view_session.h).
#include "view_session.h"

#include <algorithm>
#include <chrono>
#include <variant>

#include "line_request.h"
#include "session_replies.h"

namespace tetrascope::server {
namespace {

[[noreturn]] void no_dataset(uint32_t id) { throw protocol::ProtocolError(protocol::code::kNoDataset, "open a dataset first (dataset.open)", id); }

void check_attribute(const Dataset& dataset, const std::string& name, uint32_t id) {
  if (name.empty()) return;
  for (const auto& a : dataset.store->manifest().attributes)
    if (a.name == name) return;
  std::string names;
  for (const auto& a : dataset.store->manifest().attributes) names += (names.empty() ? "" : ", ") + a.name;
  throw protocol::ProtocolError(protocol::code::kNotFound, "no attribute '" + name + "' in " + dataset.name + " (it has: " + names + ")", id);
}

// A transfer function's component: one the attribute (the dataset's first when none is named)
// has; a scalar has none.
void check_component(const Dataset& dataset, const view::TransferFunction& tf, uint32_t id) {
  const auto& attributes = dataset.store->manifest().attributes;
  if (tf.component == view::kMagnitude || attributes.empty()) return;
  auto it = tf.attribute.empty() ? attributes.begin() : std::find_if(attributes.begin(), attributes.end(), [&](const auto& a) { return a.name == tf.attribute; });
  if (it == attributes.end()) return;  // check_attribute's to refuse
  const std::string name(view::kComponentNames[size_t(tf.component)]);
  if (it->components < 2) throw protocol::ProtocolError(protocol::code::kBadField, "component: '" + it->name + "' is a scalar; it has no component " + name + " (only \"magnitude\")", id);
  if (uint32_t(tf.component) >= it->components)
    throw protocol::ProtocolError(protocol::code::kBadField, "component: '" + it->name + "' has " + std::to_string(it->components) + " components; it has no component " + name, id);
}

}  // namespace

ViewSession::ViewSession(Server::Impl& server, SessionState& shared, Link link) : server_(server), shared_(shared), link_(std::move(link)) {
  const auto& o = server_.options;
  ViewState& state = shared_.state;
  state.view.budget = o.still_budget;
  state.interaction_budget = o.interaction_budget;
  state.max_error = 0;
  state.interaction_quality = o.interaction_quality;
  state.still_quality = o.still_quality;
  state.interaction_scale = o.interaction_scale;
}

void ViewSession::handle(bool text, const std::string& message) {
  std::optional<uint32_t> id;  // the message's, once parsed
  try {
    // messages per second, over a one-second window
    const auto now = std::chrono::steady_clock::now();
    if (now - window_start_ > std::chrono::seconds(1)) {
      window_start_ = now;
      window_count_ = 0;
    }
    if (++window_count_ > server_.options.limits.max_messages_per_second)
      throw protocol::ProtocolError(protocol::code::kRateLimited, "more than " + std::to_string(server_.options.limits.max_messages_per_second) + " messages a second; this one was dropped");
    if (!text) throw protocol::ProtocolError(protocol::code::kBinaryMessage, "control messages are JSON text frames");
    protocol::Envelope envelope = protocol::parse_message(message, server_.options.limits);
    id = envelope.id;
    if (!hello_ && envelope.type != "hello") throw protocol::ProtocolError(protocol::code::kHelloFirst, "send hello first", envelope.id);
    apply(envelope);
    bad_in_row_ = 0;
  } catch (const protocol::ProtocolError& e) {
    refuse(e.code(), client_text(e.what()), e.id());
  } catch (const std::exception& e) {
    // whatever a message makes fail stays in this session's reply, never the process's end; the
    // server's fault, so it does not count towards the client's bad messages in a row
    server_.metrics.count_error(protocol::code::kInternal);
    link_.send_text(protocol::error_reply(protocol::code::kInternal, client_text(e.what()), id));
  }
}

// An error's text as a client may see it: no path on the server, paths inside the data
// folder relative to it.
std::string ViewSession::client_text(const std::string& message) const { return without_server_paths(message, server_.options.data_dir); }

void ViewSession::refuse(const std::string& code, const std::string& message, std::optional<uint32_t> id) {
  server_.metrics.count_error(code);
  link_.send_text(protocol::error_reply(code, message, id));
  if (++bad_in_row_ >= server_.options.limits.max_bad_messages || code == protocol::code::kUnauthorized) link_.close();
}

std::shared_ptr<Dataset> ViewSession::need_dataset(uint32_t id) {
  std::lock_guard lock(shared_.mutex);
  if (!shared_.state.dataset) no_dataset(id);
  return shared_.state.dataset;
}

void ViewSession::apply(const protocol::Envelope& envelope) {
  const Then then = std::visit([&](const auto& message) { return on_message(message, envelope.id); }, envelope.message);
  if (then == Then::kReplied) return;
  link_.request_frames(then == Then::kInteraction ? FrameRequest::kInteraction : then == Then::kPlaying ? FrameRequest::kPlaying : FrameRequest::kStill);
}

// Updates the shared view state under the lock and records the message as the newest applied.
template <class Change>
void ViewSession::change_state(uint32_t id, Change change) {
  std::lock_guard lock(shared_.mutex);
  change(shared_.state);
  shared_.state.message_id = id;
  ++shared_.input_epoch;  // a refinement step under way stops at its next chunk
}

ViewSession::Then ViewSession::on_message(const protocol::Hello& m, uint32_t id) {
  if (!server_.options.token.empty() && !m.token.empty() && !server_.token_matches(m.token))
    throw protocol::ProtocolError(protocol::code::kUnauthorized, "wrong token", id);
  hello_ = true;
  link_.said_hello();
  link_.send_text(hello_ok_reply(server_.options, server_.pool->description(), id));
  return Then::kReplied;
}

ViewSession::Then ViewSession::on_message(const protocol::DatasetOpen& m, uint32_t id) {
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
    s.view.tf = view::TransferFunction{};
    s.view.isovalues.clear();
    s.view.iso_color_attribute.clear();
    s.view.hidden_regions.clear();  // the last dataset's ids
    s.view.line = view::LineRequest{};  // fields and seeds of the last dataset
    s.view.clip = {};
    s.view.slices = {};
    s.time_step = 0;  // the last dataset's step
    s.prefetch_step.reset();
  });
  watch(dataset);
  link_.send_text(dataset_info_reply(*dataset, view::default_camera(dataset->store->manifest().bounds), id));
  link_.request_frames(FrameRequest::kStill);
  return Then::kReplied;
}

// DELETE /api/v1/datasets/NAME, or a check its store fails, closes the dataset for its
// sessions: this one is told
void ViewSession::watch(const std::shared_ptr<Dataset>& dataset) {
  const std::weak_ptr<void> owner = link_.hold();
  dataset->watch(owner, [this, owner, raw = dataset.get()](const std::string& code, const std::string& message) {
    if (auto keep = owner.lock()) net::post(link_.strand, [this, keep, raw, code, message] { on_dataset_closed(raw, code, message); });
  });
}

// Strand. The dataset shown was deleted or found damaged: no more frames of it, and the
// client hears why.
void ViewSession::on_dataset_closed(const Dataset* closed, const std::string& code, const std::string& message) {
  {
    std::lock_guard lock(shared_.mutex);
    if (shared_.state.dataset.get() != closed) return;  // another dataset is open by now
    shared_.state.dataset.reset();
    shared_.pending = Pending::kNone;
    ++shared_.input_epoch;  // a step under way stops at its next chunk and asks for no next one
  }
  server_.metrics.count_error(code);
  link_.send_text(protocol::error_reply(code, message, std::nullopt));
}

ViewSession::Then ViewSession::on_message(const protocol::CameraSet& m, uint32_t id) {
  need_dataset(id);
  view::Camera camera;
  camera.eye = m.eye;
  camera.target = m.target;
  camera.up = m.up;
  camera.fov_degrees = m.fov;
  camera.orthographic = m.orthographic;
  camera.ortho_height = m.height;
  change_state(id, [&](ViewState& s) { s.view.camera = camera; });
  return m.interacting ? Then::kInteraction : Then::kStill;
}

ViewSession::Then ViewSession::on_message(const protocol::TfSet& m, uint32_t id) {
  check_attribute(*need_dataset(id), m.tf.attribute, id);
  check_component(*need_dataset(id), m.tf, id);
  change_state(id, [&](ViewState& s) { s.view.tf = m.tf; });
  return Then::kInteraction;  // the editor sends a stream of these while dragging
}

ViewSession::Then ViewSession::on_message(const protocol::ModeSet& m, uint32_t id) {
  change_state(id, [&](ViewState& s) {
    s.view.dvr = m.dvr;
    s.view.iso = m.iso;
    s.view.surface = m.surface;
    s.view.lines = m.lines;
    s.view.points = m.points;
    s.view.tensors = m.tensors;
    if (m.wireframe) s.view.wireframe = *m.wireframe;
    if (m.box) s.view.box = *m.box;
    if (m.background) s.background = *m.background;
  });
  return Then::kStill;
}

ViewSession::Then ViewSession::on_message(const protocol::IsoSet& m, uint32_t id) {
  if (m.color_by && !m.color_by->empty()) check_attribute(*need_dataset(id), *m.color_by, id);
  change_state(id, [&](ViewState& s) {
    s.view.isovalues = m.values;
    if (m.opacity) s.view.iso_opacity = *m.opacity;
    if (m.color_by) s.view.iso_color_attribute = *m.color_by;
  });
  return Then::kInteraction;  // the isovalue slider
}

ViewSession::Then ViewSession::on_message(const protocol::LodSet& m, uint32_t id) {
  change_state(id, [&](ViewState& s) {
    if (m.budget) s.view.budget = *m.budget;
    if (m.interaction_budget) s.interaction_budget = *m.interaction_budget;
    if (m.max_error) s.max_error = *m.max_error;
  });
  return Then::kStill;
}

ViewSession::Then ViewSession::on_message(const protocol::ViewResize& m, uint32_t id) {
  change_state(id, [&](ViewState& s) {
    s.view.width = m.width;
    s.view.height = m.height;
  });
  return Then::kStill;
}

ViewSession::Then ViewSession::on_message(const protocol::QualitySet& m, uint32_t id) {
  change_state(id, [&](ViewState& s) {
    if (m.interaction) s.interaction_quality = *m.interaction;
    if (m.still) s.still_quality = *m.still;
    if (m.still_codec) s.png_stills = *m.still_codec == "png";
    if (m.interaction_scale) s.interaction_scale = *m.interaction_scale;
  });
  return Then::kStill;
}

ViewSession::Then ViewSession::on_message(const protocol::LinesSet& m, uint32_t id) {
  if (m.field) check_vector_field(*need_dataset(id), *m.field, id);
  change_state(id, [&](ViewState& s) { apply_lines_set(m, s.view.line); });
  if (is_animation_step(m)) return Then::kInteraction;  // the viewer's dash animation
  return Then::kStill;  // tracing takes a while: one still, not a burst of interaction frames
}

ViewSession::Then ViewSession::on_message(const protocol::PointsSet& m, uint32_t id) {
  change_state(id, [&](ViewState& s) { apply_points_set(m, s.view); });
  return Then::kStill;
}

ViewSession::Then ViewSession::on_message(const protocol::TensorsSet& m, uint32_t id) {
  if (m.field) check_tensor_field(*need_dataset(id), *m.field, id);
  change_state(id, [&](ViewState& s) { apply_tensors_set(m, s.view.tensor); });
  return Then::kStill;  // tracing takes a while: one still
}

// The ids were checked against kMaxHiddenRegions at the edge; here against the dataset's count.
ViewSession::Then ViewSession::on_message(const protocol::RegionsSet& m, uint32_t id) {
  const auto dataset = need_dataset(id);
  const size_t count = dataset->regions ? dataset->regions->regions().size() : 0;
  if (!m.hidden.empty() && m.hidden.back() >= count)
    throw protocol::ProtocolError(protocol::code::kBadField,
                                  "hidden: no region " + std::to_string(m.hidden.back()) + " in " + dataset->name + " (it has " + std::to_string(count) + ")", id);
  change_state(id, [&](ViewState& s) { s.view.hidden_regions = m.hidden; });
  return Then::kStill;
}

// The step was checked against kMaxTimeStep at the edge; here against the dataset's steps.
// While a series plays (a step with the next one to prefetch) each step is an interaction
// frame and nothing refines; a step alone (the slider, a pause) refines to a still.
ViewSession::Then ViewSession::on_message(const protocol::TimeSet& m, uint32_t id) {
  const auto dataset = need_dataset(id);
  const uint32_t count = dataset->steps ? dataset->steps->count() : 1;
  if (m.step >= count)
    throw protocol::ProtocolError(protocol::code::kBadField, "step: no time step " + std::to_string(m.step) + " in " + dataset->name + " (it has " + std::to_string(count) + ")", id);
  if (m.prefetch && *m.prefetch >= count)
    throw protocol::ProtocolError(protocol::code::kBadField, "prefetch: no time step " + std::to_string(*m.prefetch) + " in " + dataset->name + " (it has " + std::to_string(count) + ")", id);
  if (m.prefetch) dataset->prefetch(*m.prefetch);  // inflated while this step's frame is made
  change_state(id, [&](ViewState& s) {
    s.time_step = m.step;
    s.prefetch_step = m.prefetch;
  });
  return m.prefetch ? Then::kPlaying : Then::kInteraction;
}

ViewSession::Then ViewSession::on_message(const protocol::Ping&, uint32_t id) {
  link_.send_text(protocol::pong_reply(id));
  return Then::kReplied;
}

// clip.set and slice.set: the planes replace the session's; a drag streams these.
ViewSession::Then ViewSession::on_message(const protocol::ClipSet& m, uint32_t id) {
  change_state(id, [&](ViewState& s) { s.view.clip = m.clip; });
  return Then::kInteraction;
}

ViewSession::Then ViewSession::on_message(const protocol::SliceSet& m, uint32_t id) {
  change_state(id, [&](ViewState& s) { s.view.slices = m.slice; });
  return Then::kInteraction;
}

// probe: answered from a pool worker, between (never during) the session's render turns
ViewSession::Then ViewSession::on_message(const protocol::Probe& m, uint32_t id) {
  ViewState snapshot;
  {
    std::lock_guard lock(shared_.mutex);
    snapshot = shared_.state;
  }
  if (!snapshot.dataset) no_dataset(id);  // deleted (the strand sets it) or never opened
  link_.probe(std::move(snapshot), m.x, m.y, id);
  return Then::kReplied;
}

}  // namespace tetrascope::server
