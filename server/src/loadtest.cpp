#include "tetrascope/server/loadtest.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include "tetrascope/protocol/protocol.h"
#include "tetrascope/server/client.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::server {
namespace {

using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double at = p * (v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(at)), hi = std::min(v.size() - 1, lo + 1);
  return v[lo] + (v[hi] - v[lo]) * (at - lo);
}

Vec3 rotate(const Vec3& v, const Vec3& axis, double angle) {  // Rodrigues
  const Vec3 k = normalise(axis);
  const double c = std::cos(angle), s = std::sin(angle);
  return v * c + cross(k, v) * s + k * (dot(k, v) * (1 - c));
}

struct ClientResult {
  uint64_t frames = 0, still_frames = 0, refining_frames = 0, errors = 0, bytes = 0, interaction_bytes = 0, still_bytes = 0;
  std::vector<double> latency_ms;
  std::vector<double> resume_ms;       // first frame after each resume (orbit-pause)
  std::vector<double> release_to_still_ms, release_to_first_step_ms;
  uint64_t pauses_with_still = 0, pauses = 0;
  uint64_t reconnects = 0;              // sessions lost and opened again
  std::string failure;
  double seconds = 0;
};

// A session: connected, greeted, the view sized and the dataset open; its dataset.info.
nlohmann::json open_session(const LoadtestOptions& o, std::unique_ptr<SessionClient>& client) {
  client = std::make_unique<SessionClient>(o.url, o.token);
  client->send("hello", {{"version", protocol::kVersion}, {"token", o.token}});
  client->expect("hello.ok");
  client->send("view.resize", {{"width", o.width}, {"height", o.height}});
  client->send("dataset.open", {{"name", o.dataset}});
  nlohmann::json info = client->expect("dataset.info", std::chrono::seconds(60));
  if (!o.mode.empty()) client->send("mode.set", {{"mode", o.mode}});
  return info;
}

// A session lost under the client (its server went away: a replica killed behind a load
// balancer) is opened again, through the same URL, until the run's end; false when that
// never succeeded, with the attempts and the last one's error in `why`.
bool reopen_session(const LoadtestOptions& o, std::unique_ptr<SessionClient>& client, Clock::time_point end, std::string& why) {
  client.reset();
  unsigned attempts = 0;
  while (Clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    ++attempts;
    try {
      open_session(o, client);
      return true;
    } catch (const std::exception& e) {
      why = std::to_string(attempts) + " attempts, the last: " + e.what();
      client.reset();
    }
  }
  if (why.empty()) why = "no time left in the run";
  return false;
}

// One client's run over an open session: camera moves along the path at the rate (on
// orbit-pause, orbits and pauses in turn), and what the frames that answer them measure.
struct ClientRun {
  ClientRun(const LoadtestOptions& options, unsigned index, std::unique_ptr<SessionClient>& session, const nlohmann::json& info, ClientResult& result)
      : o(options),
        r(result),
        client(session),
        eye(info["camera"]["eye"].get<Vec3>()),
        target(info["camera"]["target"].get<Vec3>()),
        up(info["camera"]["up"].get<Vec3>()),
        offset(eye - target),
        fov(info["camera"]["fov"].get<double>()),
        random(1234 + index),
        start(Clock::now()),
        end(start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration_s))),
        period(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.rate_hz))),
        pausing(o.path == "orbit-pause"),
        orbit_for(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.orbit_s))),
        pause_for(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.pause_s))),
        next_send(start),
        phase_end(start + orbit_for),
        saving(!o.save_refinement.empty() && index == 0),
        azimuth(0.3 * index) {}

  // Moves and reads until the run's end; a lost session is opened again where o.reconnect.
  void run() {
    while (Clock::now() < end) {
      try {
        if (pausing && Clock::now() >= phase_end) switch_phase();
        if (!paused && Clock::now() >= next_send) send_move();
        receive();
      } catch (const std::runtime_error& e) {
        // the connection went away (read says closed; send fails): open the session again
        if (!(client->closed() || std::string_view(e.what()).starts_with("send:")) || !o.reconnect) throw;
        ++r.reconnects;
        sent.clear();
        resume_id.reset();
        std::string why;
        if (!reopen_session(o, client, end, why))
          throw std::runtime_error(std::string("lost the session (") + e.what() + ") and could not open it again (" + why + ")");
      }
    }
  }

  // orbit-pause: the current orbit (or pause) ended; the other begins.
  void switch_phase() {
    paused = !paused;
    phase_end += paused ? pause_for : orbit_for;
    if (paused) {
      ++r.pauses;
      released = Clock::now();
      release_saw_step = release_saw_still = false;
    } else {
      next_send = Clock::now();
      resuming = true;
      if (release_saw_still) saving = false;  // one pause's steps are enough
    }
  }

  // The next camera move along the path.
  void send_move() {
    if (o.path == "random") {
      azimuth += step(random);
      elevation = std::clamp(elevation + step(random), -1.2, 1.2);
    } else {
      azimuth += 2 * M_PI / 6 / o.rate_hz;  // a turn in six seconds
    }
    const Vec3 side = cross(offset, up);
    const Vec3 rotated = rotate(rotate(offset, side, elevation), up, azimuth);
    const uint32_t id = client->send("camera.set", {{"eye", target + rotated},
                                                   {"target", target}, {"up", up}, {"fov", fov}, {"interacting", true}});
    sent[id] = Clock::now();
    if (resuming) resume_id = id;
    resuming = false;
    next_send += period;
  }

  // Waits for messages until the next thing to do (a move, the phase's or the run's end) and
  // takes every one that arrived.
  void receive() {
    const auto wake = paused ? std::min(phase_end, end) : std::min({next_send, end, pausing ? phase_end : end});
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(wake - Clock::now());
    auto message = client->read(std::max(std::chrono::milliseconds(1), wait));
    while (message) {
      if (message->binary) {
        on_frame(*message);
      } else {
        const nlohmann::json j = nlohmann::json::parse(message->data, nullptr, false);
        if (j.is_object() && j.value("type", "") == "error") ++r.errors;
      }
      message = client->read(std::chrono::milliseconds(0));
    }
  }

  // A frame: its bytes, the latency of the move it answers, the first frame after a resume.
  void on_frame(const SessionClient::Message& message) {
    const auto* bytes = reinterpret_cast<const uint8_t*>(message.data.data());
    const auto header = protocol::decode_frame_header(std::span<const uint8_t>(bytes, message.data.size()), limits);
    ++r.frames;
    r.bytes += message.data.size();
    if (header.still || header.refining) {
      header.still ? ++r.still_frames : ++r.refining_frames;
      r.still_bytes += message.data.size();
    } else {
      r.interaction_bytes += message.data.size();
    }
    if (pausing && paused && (header.still || header.refining)) on_refinement(header, message);
    if (resume_id && header.message_id >= *resume_id && !header.still && !header.refining) {
      r.resume_ms.push_back(std::chrono::duration<double, std::milli>(message.received - sent[*resume_id]).count());
      resume_id.reset();
    }
    auto it = sent.find(header.message_id);
    if (it != sent.end()) {
      r.latency_ms.push_back(std::chrono::duration<double, std::milli>(message.received - it->second).count());
      sent.erase(sent.begin(), std::next(it));  // older moves were superseded
    }
  }

  // A refinement step or the still during a pause: the times since the release, and the
  // frame saved where o.save_refinement asks for it.
  void on_refinement(const protocol::FrameHeader& header, const SessionClient::Message& message) {
    const double since_release = std::chrono::duration<double, std::milli>(message.received - released).count();
    if (!release_saw_step) r.release_to_first_step_ms.push_back(since_release);
    release_saw_step = true;
    if (header.still && !release_saw_still) {
      r.release_to_still_ms.push_back(since_release);
      ++r.pauses_with_still;
      release_saw_still = true;
    }
    if (saving) {
      const std::string name = (header.still ? std::string("still") : "step-" + std::to_string(saved_steps.size())) + (header.codec == protocol::Codec::kPng ? ".png" : ".jpg");
      std::ofstream(std::filesystem::path(o.save_refinement) / name, std::ios::binary)
          .write(message.data.data() + protocol::kFrameHeaderBytes, static_cast<std::streamsize>(header.payload_bytes));
      saved_steps.push_back({{"file", name}, {"ms_since_release", since_release}, {"tets", header.tets}, {"estimated_error", header.estimated_error},
                             {"still", header.still}, {"render_ms", header.render_ms}});
      if (header.still) {
        std::ofstream(std::filesystem::path(o.save_refinement) / "steps.json") << saved_steps.dump(1) << "\n";
        saving = false;
      }
    }
  }

  const LoadtestOptions& o;
  ClientResult& r;
  std::unique_ptr<SessionClient>& client;
  const Vec3 eye, target, up;
  const Vec3 offset;
  const double fov;
  std::mt19937 random;
  std::normal_distribution<double> step{0, 0.05};
  std::map<uint32_t, Clock::time_point> sent;
  const Clock::time_point start, end;
  const Clock::duration period;
  const bool pausing;
  const Clock::duration orbit_for, pause_for;
  Clock::time_point next_send;
  Clock::time_point phase_end;         // orbit-pause: when the current orbit (or pause) ends
  bool paused = false;
  std::optional<uint32_t> resume_id;   // the first move after a pause, until a frame answers it
  bool resuming = false;               // the next move is the first after a pause
  Clock::time_point released{};        // the last move before the pause
  bool release_saw_step = false, release_saw_still = false;
  bool saving;
  nlohmann::json saved_steps = nlohmann::json::array();
  double azimuth, elevation = 0;
  const protocol::Limits limits{};
};

void run_client(const LoadtestOptions& o, unsigned index, ClientResult& r) {
  try {
    std::unique_ptr<SessionClient> client;
    const nlohmann::json info = open_session(o, client);
    ClientRun client_run(o, index, client, info, r);
    client_run.run();
    r.seconds = std::chrono::duration<double>(Clock::now() - client_run.start).count();
    client->close();
  } catch (const std::exception& e) {
    r.failure = e.what();
    ++r.errors;
  }
}

}  // namespace

nlohmann::json run_loadtest(const LoadtestOptions& o) {
  if (o.clients < 1 || o.clients > kMaxLoadtestClients) throw std::invalid_argument("--clients must be 1 to " + std::to_string(kMaxLoadtestClients));
  if (!(o.duration_s >= 1 && o.duration_s <= kMaxLoadtestSeconds)) throw std::invalid_argument("--duration must be 1 to 600 seconds");
  if (!o.mode.empty()) protocol::parse_modes(o.mode);  // std::invalid_argument naming an unknown part
  if (o.path != "orbit" && o.path != "random" && o.path != "orbit-pause") throw std::invalid_argument("--path must be orbit, random or orbit-pause");
  if (!(o.orbit_s > 0 && o.orbit_s <= kMaxLoadtestSeconds) || !(o.pause_s > 0 && o.pause_s <= kMaxLoadtestSeconds))
    throw std::invalid_argument("--orbit and --pause must be above 0 and at most 600 seconds");
  if (!o.save_refinement.empty()) std::filesystem::create_directories(o.save_refinement);
  if (!(o.rate_hz > 0 && o.rate_hz <= 240)) throw std::invalid_argument("--rate must be above 0 and at most 240");
  const ParsedUrl url = parse_url(o.url);
  if (!o.allow_remote && url.host != "127.0.0.1" && url.host != "localhost" && url.host != "[::1]")
    throw std::invalid_argument("loadtest targets loopback only (" + url.host + " given); --allow-remote to load another host");
  const std::string http_base = "http://" + url.host + ":" + url.port;
  auto health = [&]() -> nlohmann::json {
    try {
      const HttpResult h = http_request(http_base + "/api/v1/health", "GET", "", o.token);
      return nlohmann::json::parse(h.body, nullptr, false);
    } catch (const std::exception&) {
      return nullptr;
    }
  };
  const nlohmann::json before = health();
  std::vector<ClientResult> results(o.clients);
  std::vector<std::thread> threads;
  for (unsigned c = 0; c < o.clients; ++c) threads.emplace_back([&, c] { run_client(o, c, results[c]); });
  for (auto& t : threads) t.join();
  const nlohmann::json after = health();

  nlohmann::json per_client = nlohmann::json::array();
  std::vector<double> all_latency, fps, resume, to_still, to_step;
  uint64_t pauses = 0, pauses_with_still = 0, refining = 0;
  uint64_t frames = 0, still = 0, errors = 0, bytes = 0, interaction_bytes = 0, still_bytes = 0, reconnects = 0;
  double seconds = 0;
  for (const auto& r : results) {
    const double f = r.seconds > 0 ? r.frames / r.seconds : 0;
    fps.push_back(f);
    per_client.push_back({{"frames", r.frames}, {"still_frames", r.still_frames}, {"fps", f}, {"errors", r.errors}, {"reconnects", r.reconnects}, {"bytes", r.bytes},
                          {"latency_ms", {{"p50", percentile(r.latency_ms, 0.5)}, {"p95", percentile(r.latency_ms, 0.95)}, {"p99", percentile(r.latency_ms, 0.99)}}},
                          {"failure", r.failure.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.failure)}});
    all_latency.insert(all_latency.end(), r.latency_ms.begin(), r.latency_ms.end());
    resume.insert(resume.end(), r.resume_ms.begin(), r.resume_ms.end());
    to_still.insert(to_still.end(), r.release_to_still_ms.begin(), r.release_to_still_ms.end());
    to_step.insert(to_step.end(), r.release_to_first_step_ms.begin(), r.release_to_first_step_ms.end());
    pauses += r.pauses;
    pauses_with_still += r.pauses_with_still;
    refining += r.refining_frames;
    frames += r.frames;
    still += r.still_frames;
    errors += r.errors;
    reconnects += r.reconnects;
    bytes += r.bytes;
    interaction_bytes += r.interaction_bytes;
    still_bytes += r.still_bytes;
    seconds = std::max(seconds, r.seconds);
  }
  const double min_fps = *std::min_element(fps.begin(), fps.end()), max_fps = *std::max_element(fps.begin(), fps.end());
  nlohmann::json out = {
      {"url", o.url},
      {"dataset", o.dataset},
      {"clients", o.clients},
      {"duration_s", seconds},
      {"path", o.path},
      {"size", std::to_string(o.width) + "x" + std::to_string(o.height)},
      {"frames", frames},
      {"total_fps", seconds > 0 ? frames / seconds : 0},
      {"min_client_fps", min_fps},
      {"max_client_fps", max_fps},
      {"fairness_max_over_min", min_fps > 0 ? nlohmann::json(max_fps / min_fps) : nlohmann::json(nullptr)},
      {"latency_ms", {{"p50", percentile(all_latency, 0.5)}, {"p95", percentile(all_latency, 0.95)}, {"p99", percentile(all_latency, 0.99)}, {"samples", all_latency.size()}}},
      {"bytes_per_s", seconds > 0 ? bytes / seconds : 0},
      {"kb_per_interaction_frame", frames > still ? interaction_bytes / 1024.0 / (frames - still) : 0},
      {"kb_per_still_frame", still ? still_bytes / 1024.0 / still : 0},
      {"errors", errors},
      {"reconnects", reconnects},
      {"clients_without_frames", std::count_if(results.begin(), results.end(), [](const ClientResult& r) { return r.frames == 0; })},
      {"per_client", per_client}};
  out["refining_frames"] = refining;
  if (o.path == "orbit-pause") {
    auto quantiles = [](const std::vector<double>& v) {
      return nlohmann::json{{"p50", percentile(v, 0.5)}, {"p99", percentile(v, 0.99)}, {"max", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}, {"samples", v.size()}};
    };
    out["resume_first_frame_ms"] = quantiles(resume);
    out["release_to_first_refinement_ms"] = quantiles(to_step);
    out["release_to_still_ms"] = quantiles(to_still);
    out["pauses"] = pauses;
    out["pauses_reaching_the_still"] = pauses_with_still;
  }
  if (before.is_object() && after.is_object()) {
    out["server_rss_mb_before"] = before.value("rss_bytes", 0.0) / 1048576.0;
    out["server_rss_mb_after"] = after.value("rss_bytes", 0.0) / 1048576.0;
    out["server_peak_rss_mb"] = after.value("peak_rss_bytes", 0.0) / 1048576.0;
  }
  return out;
}

}  // namespace tetrascope::server
