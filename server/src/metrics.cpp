#include "metrics.h"

#include <cstdio>

namespace tetrascope::server {

void Histogram::observe(double ms) {
  std::lock_guard lock(mutex_);
  size_t b = 0;
  while (b < kBucketsMs.size() && ms > kBucketsMs[b]) ++b;
  ++counts_[b];
  sum_ += ms;
  ++count_;
}

void Histogram::write(std::string& out, const std::string& name, const std::string& help) const {
  std::lock_guard lock(mutex_);
  char line[160];
  out += "# HELP " + name + " " + help + "\n# TYPE " + name + " histogram\n";
  uint64_t cumulative = 0;
  for (size_t b = 0; b < kBucketsMs.size(); ++b) {
    cumulative += counts_[b];
    std::snprintf(line, sizeof line, "%s_bucket{le=\"%g\"} %llu\n", name.c_str(), kBucketsMs[b], static_cast<unsigned long long>(cumulative));
    out += line;
  }
  std::snprintf(line, sizeof line, "%s_bucket{le=\"+Inf\"} %llu\n%s_sum %.3f\n%s_count %llu\n", name.c_str(), static_cast<unsigned long long>(count_), name.c_str(), sum_,
                name.c_str(), static_cast<unsigned long long>(count_));
  out += line;
}

void Metrics::count_error(const std::string& code) {
  std::lock_guard lock(mutex_);
  ++errors_[code];
}

std::map<std::string, uint64_t> Metrics::errors() const {
  std::lock_guard lock(mutex_);
  return errors_;
}

void Metrics::count_http_error(const std::string& route, unsigned status) {
  std::lock_guard lock(mutex_);
  ++http_errors_[{route, status}];
}

std::map<std::pair<std::string, unsigned>, uint64_t> Metrics::http_errors() const {
  std::lock_guard lock(mutex_);
  return http_errors_;
}

std::string prometheus_text(const Metrics& m, const MetricsSnapshotExtras& extras) {
  std::string out;
  auto single = [&](const char* name, const char* type, const char* help, double value) {
    char line[512];
    std::snprintf(line, sizeof line, "# HELP %s %s\n# TYPE %s %s\n%s %.17g\n", name, help, name, type, name, value);
    out += line;
  };
  auto labelled = [&](const char* name, const char* type, const char* help, const char* label, const std::map<std::string, uint64_t>& values) {
    out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
    for (const auto& [key, count] : values) out += std::string(name) + "{" + label + "=\"" + key + "\"} " + std::to_string(count) + "\n";
  };
  single("tetrascope_sessions_active", "gauge", "WebSocket sessions open", double(m.sessions_active.load()));
  single("tetrascope_sessions_total", "counter", "WebSocket sessions accepted", double(m.sessions_total.load()));
  single("tetrascope_sessions_refused_total", "counter", "sessions refused at the session limit", double(m.sessions_refused.load()));
  labelled("tetrascope_frames_total", "counter", "frames rendered", "kind", {{"interaction", m.frames_interaction.load()}, {"refining", m.frames_refining.load()}, {"still", m.frames_still.load()}});
  single("tetrascope_handler_exceptions_total", "counter", "exceptions no request or session handler caught (logged; the server went on)", double(m.handler_exceptions.load()));
  single("tetrascope_connections_evicted_total", "counter", "connections waiting on their request header, closed at the connection cap to let a new one in", double(m.connections_evicted.load()));
  single("tetrascope_frames_interrupted_total", "counter", "refinement steps stopped by input before they were done (not sent)", double(m.frames_interrupted.load()));
  single("tetrascope_frame_cost_error_p50_percent", "gauge", "frame-time model: median of |measured - predicted| / measured over recent interaction frames", m.cost_error_p50_pct.load());
  single("tetrascope_frame_cost_error_p90_percent", "gauge", "frame-time model: 90th percentile of |measured - predicted| / measured", m.cost_error_p90_pct.load());
  single("tetrascope_frames_dropped_total", "counter", "frames replaced by a newer one before a slow client took them", double(m.frames_dropped.load()));
  single("tetrascope_frame_bytes_total", "counter", "bytes of frames rendered", double(m.frame_bytes.load()));
  single("tetrascope_messages_total", "counter", "WebSocket messages received", double(m.messages.load()));
  single("tetrascope_http_requests_total", "counter", "HTTP requests", double(m.http_requests.load()));
  labelled("tetrascope_errors_total", "counter", "error replies by code", "code", m.errors());
  out += "# HELP tetrascope_http_errors_total HTTP answers of 400 and up, by route class and status\n# TYPE tetrascope_http_errors_total counter\n";
  for (const auto& [key, count] : m.http_errors())
    out += "tetrascope_http_errors_total{route=\"" + key.first + "\",status=\"" + std::to_string(key.second) + "\"} " + std::to_string(count) + "\n";
  m.render_ms.write(out, "tetrascope_render_ms", "cut update, assembly and drawing of a frame, ms");
  m.encode_ms.write(out, "tetrascope_encode_ms", "JPEG/PNG encoding of a frame, ms");
  m.cut_ms.write(out, "tetrascope_cut_update_ms", "cut update of a frame, ms");
  m.assemble_ms.write(out, "tetrascope_assemble_ms", "assembly of a changed cut's mesh and scene, ms (0: unchanged)");
  m.upload_ms.write(out, "tetrascope_upload_ms", "scene upload to a render context, ms (0: the context held it)");
  m.draw_ms.write(out, "tetrascope_draw_ms", "drawing and readback of a frame, ms");
  single("tetrascope_cache_hits_total", "counter", "segment cache hits, all datasets", double(extras.cache.hits));
  single("tetrascope_cache_misses_total", "counter", "segment cache misses (segments mapped), all datasets", double(extras.cache.misses));
  single("tetrascope_cache_evictions_total", "counter", "segments released to keep the shared budget, all datasets", double(extras.cache.evictions));
  single("tetrascope_cache_resident_bytes", "gauge", "bytes of segments mapped, all datasets", double(extras.cache.resident_bytes));
  single("tetrascope_cache_budget_bytes", "gauge", "the segment cache budget every dataset shares (--cache-mb)", double(extras.cache_budget_bytes));
  auto per_dataset = [&](const char* name, const char* type, const char* help, uint64_t storage::SegmentCache::Stats::*field) {
    std::map<std::string, uint64_t> values;
    for (const auto& [dataset, stats] : extras.cache_by_dataset) values[dataset] = stats.*field;
    labelled(name, type, help, "dataset", values);
  };
  per_dataset("tetrascope_dataset_cache_hits_total", "counter", "segment cache hits by open dataset", &storage::SegmentCache::Stats::hits);
  per_dataset("tetrascope_dataset_cache_misses_total", "counter", "segment cache misses by open dataset", &storage::SegmentCache::Stats::misses);
  per_dataset("tetrascope_dataset_cache_evictions_total", "counter", "segments of the dataset released for the shared budget", &storage::SegmentCache::Stats::evictions);
  per_dataset("tetrascope_dataset_cache_resident_bytes", "gauge", "bytes of the dataset's segments mapped", &storage::SegmentCache::Stats::resident_bytes);
  labelled("tetrascope_jobs", "gauge", "jobs by state", "state", extras.jobs_by_state);
  return out;
}

}  // namespace tetrascope::server
