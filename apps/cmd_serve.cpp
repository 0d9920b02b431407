// serve, loadtest: the viewer's server and its load test.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <thread>

#include "args.h"
#include "commands.h"
#include <cstdlib>

#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/ray_caster.h"
#include "tetrascope/renderer/view_frame.h"
#include "tetrascope/server/loadtest.h"
#include "tetrascope/server/memory_fit.h"
#include "tetrascope/server/server.h"

namespace tetrascope::apps {
namespace {

constexpr uint32_t kDefaultRenderWorkers = 2;

}  // namespace

int run_serve(const Arguments& raw) {
  Args args(raw, {"--read-only"}, {"--data", "--port", "--bind", "--token", "--threads", "--workers", "--cache-mb", "--max-sessions", "--max-message-bytes",
                      "--max-messages-per-second", "--max-image-side", "--max-upload-mb", "--max-jobs", "--max-queued-jobs", "--job-memory-mb", "--job-cpu-seconds", "--max-connections", "--max-connections-per-ip", "--hello-timeout", "--worker-idle-release", "--min-upload-rate", "--max-fps", "--budget", "--interaction-budget",
                      "--interaction-scale", "--frame-ms", "--refine-growth", "--web", "--memory-mb", "--backend"});
  if (!args.has("--data") || !args.positionals().empty()) {
    std::fprintf(stderr, "usage: tetrascope serve --data DIR [--port 8080] [--bind ADDR] [--token T] [--threads N] ... (tetrascope --help)\n");
    return 2;
  }
  server::ServerOptions o;
  o.data_dir = args.get("--data");
  const std::filesystem::path source = TETRA_SOURCE_DIR;
  o.web_root = args.has("--web") ? std::filesystem::path(args.get("--web")) : source / "web-client";
  o.protocol_root = (o.web_root / "..").lexically_normal() / "protocol";  // a trailing '/' on --web too
  const uint32_t port = args.number("--port", 8080);
  if (port > 65535) throw std::invalid_argument("--port must be 0 to 65535");
  o.port = static_cast<uint16_t>(port);
  o.bind = args.get("--bind", "127.0.0.1");
  o.token = token_option(args);
  o.io_threads = std::max(1u, args.number("--threads", 1));
  o.render_workers = std::max(1u, args.number("--workers", kDefaultRenderWorkers));
  o.cache_bytes = uint64_t(args.number("--cache-mb", static_cast<uint32_t>(o.cache_bytes >> 20))) << 20;
  o.limits.max_sessions = args.number("--max-sessions", o.limits.max_sessions);
  o.limits.max_message_bytes = args.number("--max-message-bytes", static_cast<uint32_t>(o.limits.max_message_bytes));
  o.limits.max_messages_per_second = args.number("--max-messages-per-second", o.limits.max_messages_per_second);
  o.limits.max_image_side = std::min(renderer::kMaxImageSide, args.number("--max-image-side", o.limits.max_image_side));
  o.max_upload_bytes = uint64_t(args.number("--max-upload-mb", static_cast<uint32_t>(o.max_upload_bytes >> 20))) << 20;
  o.max_running_jobs = std::max(1u, args.number("--max-jobs", o.max_running_jobs));
  o.max_queued_jobs = args.number("--max-queued-jobs", o.max_queued_jobs);
  o.max_connections = std::max(1u, args.number("--max-connections", o.max_connections));
  o.max_connections_per_ip = args.number("--max-connections-per-ip", o.max_connections_per_ip);  // 0: none (behind a proxy every client has its address)
  o.min_upload_bytes_per_second = args.number("--min-upload-rate", static_cast<uint32_t>(o.min_upload_bytes_per_second));
  o.hello_timeout = std::chrono::seconds(std::max(1u, args.number("--hello-timeout", static_cast<uint32_t>(o.hello_timeout.count() / 1000))));
  // 0: a worker keeps its scene and buffers while idle
  o.worker_idle_release = std::chrono::seconds(args.number("--worker-idle-release", static_cast<uint32_t>(o.worker_idle_release.count() / 1000)));
  o.job_memory_bytes = uint64_t(args.number("--job-memory-mb", static_cast<uint32_t>(o.job_memory_bytes >> 20))) << 20;
  o.job_cpu_seconds = args.number("--job-cpu-seconds", o.job_cpu_seconds);
  o.max_fps = args.positive("--max-fps", o.max_fps);
  o.still_budget = args.number("--budget", static_cast<uint32_t>(o.still_budget));
  o.interaction_budget = args.number("--interaction-budget", static_cast<uint32_t>(o.interaction_budget));
  o.interaction_scale = args.positive("--interaction-scale", o.interaction_scale);
  o.frame_ms = args.positive("--frame-ms", o.frame_ms);
  if (o.frame_ms < 5 || o.frame_ms > 10000) throw std::invalid_argument("--frame-ms must be 5 to 10000 (ms of render time an interaction frame aims at)");
  o.refine_growth = args.positive("--refine-growth", o.refine_growth);
  if (o.refine_growth < 1.5 || o.refine_growth > 16) throw std::invalid_argument("--refine-growth must be 1.5 to 16 (how much longer each refinement step may take than the one before)");
  if (o.interaction_scale < protocol::kMinInteractionScale || o.interaction_scale > 1) throw std::invalid_argument("--interaction-scale must be 0.25 to 1");
  o.read_only = args.has("--read-only");
  o.backend = args.get("--backend", o.backend);
  if (!renderer::known_backend(o.backend)) throw std::invalid_argument("--backend: gl, cpu or auto");
  // inside a memory limit (the process's cgroup, or --memory-mb, the smaller): a still budget
  // and a segment cache that fit it, or a clear refusal when nothing would (memory_fit.h)
  std::optional<server::MemoryLimit> limit = server::process_memory_limit();
  if (args.has("--memory-mb")) {
    const uint64_t bytes = uint64_t(args.number("--memory-mb", 0)) << 20;
    if (bytes == 0) throw std::invalid_argument("--memory-mb must be at least 1");
    if (!limit || bytes < limit->bytes) limit = server::MemoryLimit{bytes, "--memory-mb"};
  }
  if (limit) {
    const server::MemoryFit fit = server::fit_to_memory(o, *limit);
    o.still_budget = fit.still_budget;
    o.cache_bytes = fit.cache_bytes;
    if (fit.changed) std::printf("tetrascope serve: %s\n", fit.message.c_str());
  }
  server::Server server(o);
  std::printf("tetrascope serve: open http://%s:%u/ (data %s, %u render workers%s)\n", o.bind == "0.0.0.0" ? "localhost" : o.bind.c_str(), server.port(),
              o.data_dir.c_str(), o.render_workers, o.token.empty() ? "" : ", token required");
  std::fflush(stdout);
  server.run_until_signal();
  return 0;
}

int run_loadtest(const Arguments& raw) {
  Args args(raw, {"--json", "--allow-remote", "--no-reconnect"}, {"--url", "--dataset", "--clients", "--duration", "--path", "--rate", "--size", "--token", "--orbit", "--pause", "--save-refinement", "--mode"});
  if (!args.has("--url") || !args.has("--dataset")) {
    std::fprintf(stderr, "usage: tetrascope loadtest --url ws://HOST:PORT/api/v1/session --dataset NAME [--clients N] [--duration S] [--path orbit|random|orbit-pause] [--orbit S] [--pause S] [--save-refinement DIR] [--mode MODE] [--json]\n");
    return 2;
  }
  server::LoadtestOptions o;
  o.url = args.get("--url");
  o.dataset = args.get("--dataset");
  o.token = token_option(args);
  o.clients = args.number("--clients", 1);
  o.duration_s = args.positive("--duration", 10);
  o.path = args.get("--path", "orbit");
  o.rate_hz = args.positive("--rate", 30);
  o.orbit_s = args.positive("--orbit", o.orbit_s);
  o.pause_s = args.positive("--pause", o.pause_s);
  o.save_refinement = args.get("--save-refinement", "");
  o.allow_remote = args.has("--allow-remote");
  o.reconnect = !args.has("--no-reconnect");
  o.mode = args.get("--mode", "");
  if (args.has("--size")) {
    const ImageSize size = parse_size("--size", args.get("--size"), protocol::kMinImageSide, protocol::Limits{}.max_image_side);
    o.width = size.width;
    o.height = size.height;
  }
  const nlohmann::json r = server::run_loadtest(o);
  if (args.has("--json")) {
    std::cout << r.dump() << "\n";
  } else {
    for (size_t c = 0; c < r["per_client"].size(); ++c) {
      const auto& pc = r["per_client"][c];
      std::printf("client %2zu: %6.1f fps  %5llu frames  latency p50 %6.1f p95 %6.1f p99 %6.1f ms  %llu errors%s%s\n", c, pc["fps"].get<double>(),
                  static_cast<unsigned long long>(pc["frames"].get<uint64_t>()), pc["latency_ms"]["p50"].get<double>(), pc["latency_ms"]["p95"].get<double>(),
                  pc["latency_ms"]["p99"].get<double>(), static_cast<unsigned long long>(pc["errors"].get<uint64_t>()), pc["failure"].is_null() ? "" : "  ",
                  pc["failure"].is_null() ? "" : pc["failure"].get<std::string>().c_str());
    }
    std::printf("total: %.1f fps over %u clients, latency p50 %.1f p95 %.1f p99 %.1f ms, %.0f KB/s, %llu errors\n", r["total_fps"].get<double>(), o.clients,
                r["latency_ms"]["p50"].get<double>(), r["latency_ms"]["p95"].get<double>(), r["latency_ms"]["p99"].get<double>(), r["bytes_per_s"].get<double>() / 1024,
                static_cast<unsigned long long>(r["errors"].get<uint64_t>()));
    if (r.contains("resume_first_frame_ms"))
      std::printf("after a pause: first frame after resuming p50 %.1f p99 %.1f ms; release to first refinement step p50 %.1f ms, to the still p50 %.1f ms (%llu of %llu pauses reached it)\n",
                  r["resume_first_frame_ms"]["p50"].get<double>(), r["resume_first_frame_ms"]["p99"].get<double>(), r["release_to_first_refinement_ms"]["p50"].get<double>(),
                  r["release_to_still_ms"]["p50"].get<double>(), static_cast<unsigned long long>(r["pauses_reaching_the_still"].get<uint64_t>()),
                  static_cast<unsigned long long>(r["pauses"].get<uint64_t>()));
  }
  return r["errors"].get<uint64_t>() == 0 && r["clients_without_frames"].get<int64_t>() == 0 ? 0 : 1;
}

}  // namespace tetrascope::apps
