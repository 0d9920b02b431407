// Counters and histograms of the server, and the one place that writes them in Prometheus'
// text format (served at /metrics).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include "tetrascope/storage/store.h"

namespace tetrascope::server {

class Histogram {
 public:
  static constexpr std::array<double, 12> kBucketsMs{0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000};
  void observe(double ms);
  void write(std::string& out, const std::string& name, const std::string& help) const;

 private:
  mutable std::mutex mutex_;
  std::array<uint64_t, kBucketsMs.size() + 1> counts_{};
  double sum_ = 0;
  uint64_t count_ = 0;
};

struct Metrics {
  std::atomic<int64_t> sessions_active{0};
  std::atomic<uint64_t> sessions_total{0}, sessions_refused{0};
  std::atomic<uint64_t> frames_interaction{0}, frames_still{0}, frames_dropped{0}, frame_bytes{0};
  std::atomic<uint64_t> frames_refining{0};     // refinement steps sent before the still
  std::atomic<uint64_t> frames_interrupted{0};  // refinement steps stopped by input (not sent)
  std::atomic<uint64_t> handler_exceptions{0};  // exceptions no handler caught (logged; the server goes on)
  std::atomic<uint64_t> connections_evicted{0}; // connections idle or slow in their header, closed at the cap to let another in
  // the frame-time model's error on interaction frames, |measured - predicted| / measured (frame_cost.h)
  std::atomic<double> cost_error_p50_pct{0}, cost_error_p90_pct{0};
  std::atomic<uint64_t> messages{0}, http_requests{0};
  Histogram render_ms, encode_ms, cut_ms, assemble_ms, upload_ms, draw_ms;
  void count_error(const std::string& code);
  std::map<std::string, uint64_t> errors() const;
  // An HTTP answer of 400 and up, by route class (rest.h's route_class, or "malformed" or
  // "connection" before a request was read) and status.
  void count_http_error(const std::string& route, unsigned status);
  std::map<std::pair<std::string, unsigned>, uint64_t> http_errors() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, uint64_t> errors_;
  std::map<std::pair<std::string, unsigned>, uint64_t> http_errors_;
};

// Figures that live outside Metrics, read when /metrics is asked for.
struct MetricsSnapshotExtras {
  storage::SegmentPool::Stats cache;  // the one segment cache budget every dataset shares
  uint64_t cache_budget_bytes = 0;
  std::map<std::string, storage::SegmentCache::Stats> cache_by_dataset;  // the open datasets
  std::map<std::string, uint64_t> jobs_by_state;
};

// Prometheus text exposition format 0.0.4.
std::string prometheus_text(const Metrics& metrics, const MetricsSnapshotExtras& extras);

}  // namespace tetrascope::server
