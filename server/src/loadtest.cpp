#include "tetrascope/server/loadtest.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include "tetrascope/protocol/protocol.h"
#include "tetrascope/server/client.h"
#include "tetrascope/storage/vec3.h"

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
  uint64_t frames = 0, still_frames = 0, errors = 0, bytes = 0, interaction_bytes = 0, still_bytes = 0;
  std::vector<double> latency_ms;
  std::string failure;
  double seconds = 0;
};

void run_client(const LoadtestOptions& o, unsigned index, ClientResult& r) {
  try {
    SessionClient client(o.url, o.token);
    client.send("hello", {{"version", protocol::kVersion}, {"token", o.token}});
    client.expect("hello.ok");
    client.send("view.resize", {{"width", o.width}, {"height", o.height}});
    client.send("dataset.open", {{"name", o.dataset}});
    const nlohmann::json info = client.expect("dataset.info", std::chrono::seconds(60));
    const Vec3 eye = info["camera"]["eye"], target = info["camera"]["target"], up = info["camera"]["up"];
    const Vec3 offset = eye - target;
    const double fov = info["camera"]["fov"];
    std::mt19937 random(1234 + index);
    std::normal_distribution<double> step(0, 0.05);
    std::map<uint32_t, Clock::time_point> sent;
    const auto start = Clock::now(), end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration_s));
    const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.rate_hz));
    auto next_send = start;
    double azimuth = 0.3 * index, elevation = 0;
    const protocol::Limits limits;
    while (Clock::now() < end) {
      if (Clock::now() >= next_send) {
        if (o.path == "random") {
          azimuth += step(random);
          elevation = std::clamp(elevation + step(random), -1.2, 1.2);
        } else {
          azimuth += 2 * M_PI / 6 / o.rate_hz;  // a turn in six seconds
        }
        const Vec3 side = cross(offset, up);
        const Vec3 rotated = rotate(rotate(offset, side, elevation), up, azimuth);
        const uint32_t id = client.send("camera.set", {{"eye", target + rotated},
                                                       {"target", target}, {"up", up}, {"fov", fov}, {"interacting", true}});
        sent[id] = Clock::now();
        next_send += period;
      }
      const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(std::min(next_send, end) - Clock::now());
      auto message = client.read(std::max(std::chrono::milliseconds(1), wait));
      while (message) {
        if (message->binary) {
          const auto* bytes = reinterpret_cast<const uint8_t*>(message->data.data());
          const auto header = protocol::decode_frame_header(std::span<const uint8_t>(bytes, message->data.size()), limits);
          ++r.frames;
          r.bytes += message->data.size();
          if (header.still) {
            ++r.still_frames;
            r.still_bytes += message->data.size();
          } else {
            r.interaction_bytes += message->data.size();
          }
          auto it = sent.find(header.message_id);
          if (it != sent.end()) {
            r.latency_ms.push_back(std::chrono::duration<double, std::milli>(message->received - it->second).count());
            sent.erase(sent.begin(), std::next(it));  // older moves were superseded
          }
        } else {
          const nlohmann::json j = nlohmann::json::parse(message->data, nullptr, false);
          if (j.is_object() && j.value("type", "") == "error") ++r.errors;
        }
        message = client.read(std::chrono::milliseconds(0));
      }
    }
    r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    client.close();
  } catch (const std::exception& e) {
    r.failure = e.what();
    ++r.errors;
  }
}

}  // namespace

nlohmann::json run_loadtest(const LoadtestOptions& o) {
  if (o.clients < 1 || o.clients > kMaxLoadtestClients) throw std::invalid_argument("--clients must be 1 to " + std::to_string(kMaxLoadtestClients));
  if (!(o.duration_s >= 1 && o.duration_s <= kMaxLoadtestSeconds)) throw std::invalid_argument("--duration must be 1 to 600 seconds");
  if (o.path != "orbit" && o.path != "random") throw std::invalid_argument("--path must be orbit or random");
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
  std::vector<double> all_latency, fps;
  uint64_t frames = 0, still = 0, errors = 0, bytes = 0, interaction_bytes = 0, still_bytes = 0;
  double seconds = 0;
  for (const auto& r : results) {
    const double f = r.seconds > 0 ? r.frames / r.seconds : 0;
    fps.push_back(f);
    per_client.push_back({{"frames", r.frames}, {"still_frames", r.still_frames}, {"fps", f}, {"errors", r.errors}, {"bytes", r.bytes},
                          {"latency_ms", {{"p50", percentile(r.latency_ms, 0.5)}, {"p95", percentile(r.latency_ms, 0.95)}, {"p99", percentile(r.latency_ms, 0.99)}}},
                          {"failure", r.failure.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.failure)}});
    all_latency.insert(all_latency.end(), r.latency_ms.begin(), r.latency_ms.end());
    frames += r.frames;
    still += r.still_frames;
    errors += r.errors;
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
      {"clients_without_frames", std::count_if(results.begin(), results.end(), [](const ClientResult& r) { return r.frames == 0; })},
      {"per_client", per_client}};
  if (before.is_object() && after.is_object()) {
    out["server_rss_mb_before"] = before.value("rss_bytes", 0.0) / 1048576.0;
    out["server_rss_mb_after"] = after.value("rss_bytes", 0.0) / 1048576.0;
    out["server_peak_rss_mb"] = after.value("peak_rss_bytes", 0.0) / 1048576.0;
  }
  return out;
}

}  // namespace tetrascope::server
