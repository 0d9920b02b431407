// GET /api/v1/health and GET /metrics.
#include <fstream>

#include "rest.h"

namespace tetrascope::server {
namespace {

// This process's resident memory (VmRSS) or its peak (VmHWM), bytes.
double memory_bytes(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind(field, 0) == 0) return 1024.0 * std::strtod(line.c_str() + field.size(), nullptr);
  return 0;
}

}  // namespace

Response get_health(const RestRequest& r) {
  const Server::Impl& s = r.server;
  const double uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - s.started).count();
  return json_response(r.request, http::status::ok,
                       {{"status", "ok"}, {"version", "0.1.0"}, {"protocol", protocol::kVersion}, {"renderer", s.pool->description()}, {"backend", s.pool->cpu() ? "cpu" : "gl"},
                        {"uptime_s", uptime}, {"sessions", s.metrics.sessions_active.load()}, {"render_workers", s.options.render_workers},
                        {"read_only", s.options.read_only}, {"rss_bytes", memory_bytes("VmRSS:")}, {"peak_rss_bytes", memory_bytes("VmHWM:")}});
}

Response get_metrics(const RestRequest& r) {
  MetricsSnapshotExtras extras;
  extras.cache = r.server.datasets->cache_totals();
  extras.cache_budget_bytes = r.server.datasets->cache_budget();
  extras.cache_by_dataset = r.server.datasets->cache_by_dataset();
  if (r.server.jobs) extras.jobs_by_state = r.server.jobs->count_by_state();
  return make_response(r.request, http::status::ok, prometheus_text(r.server.metrics, extras), "text/plain; version=0.0.4");
}

}  // namespace tetrascope::server
