// Preprocessing jobs: `tetrascope preprocess --progress json` run as child processes (a job
// that crashes or runs out of memory never harms the server), at most `max_running` at a
// time, the rest queued. Each job lives in DATA/.jobs/ID/: job.json (its state, rewritten
// atomically), log (everything the child printed) and out/ (the store being written). A
// finished store is renamed to DATA/NAME, so a dataset never appears half written; a failed
// or cancelled job's out/ is removed. After a restart, jobs that were running are reported
// failed and queued ones run.
//
// What a job may cost: each child runs under RLIMIT_AS (JobLimits::memory_bytes), so
// a hostile mesh fails its own job with "out of memory" instead of pushing the machine into
// swap; at most JobLimits::max_queued jobs wait (submit answers 429 past it). Whatever ends a
// job (done, failed, cancelled, killed, out of memory) its out/ and out.tmp/ are removed, and
// on start the runner sweeps what a killed server left behind.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

namespace tetrascope::server {

class BadRequest : public std::runtime_error {
 public:
  BadRequest(int status, std::string code, const std::string& message) : std::runtime_error(message), status_(status), code_(std::move(code)) {}
  int status() const { return status_; }
  const std::string& code() const { return code_; }

 private:
  int status_;
  std::string code_;
};

struct JobLimits {
  static constexpr unsigned kDefaultMaxQueued = 16;
  uint64_t memory_bytes = 0;                // address space of each child (RLIMIT_AS); 0: no limit
  uint32_t cpu_seconds = 0;                 // CPU time of each child (RLIMIT_CPU, SIGXCPU then SIGKILL); 0: no limit
  unsigned max_queued = kDefaultMaxQueued;  // jobs waiting for a slot; submit answers 429 past it
};

// The machine's physical memory: the default job memory limit.
uint64_t physical_memory_bytes();

class JobRunner {
 public:
  JobRunner(std::filesystem::path data_dir, std::filesystem::path binary, unsigned max_running, JobLimits limits = {});
  ~JobRunner();  // kills running children, waits for their threads

  // body: {"source": "uploads/mesh.vtk" (inside the data folder), "name": "mesh",
  //        "options": {"base_tets", "segment_tets", "level_ratio", "bins", "threads", "seed"}}.
  // Throws BadRequest.
  nlohmann::json submit(const nlohmann::json& body);
  std::optional<nlohmann::json> get(const std::string& id) const;
  nlohmann::json list() const;
  // A running job is killed and waited for (at most kCancelWait): the answer holds its final
  // state (cancelled, or done/failed when it ended first), not "running".
  std::optional<nlohmann::json> cancel(const std::string& id);
  static constexpr std::chrono::seconds kCancelWait{10};
  // The id of a queued or running job whose source is `source` (a path inside the data folder).
  std::optional<std::string> job_reading(const std::string& source) const;
  std::map<std::string, uint64_t> count_by_state() const;

 private:
  struct Job;
  void load();
  void schedule();  // starts queued jobs while slots are free (mutex held)
  void run(std::shared_ptr<Job> job);
  void save(const Job& job) const;  // mutex held
  nlohmann::json to_json(const Job& job) const;

  std::filesystem::path data_dir_, jobs_dir_, binary_;
  unsigned max_running_;
  JobLimits limits_;
  mutable std::mutex mutex_;
  std::condition_variable ended_;  // a job's run ended (its state is final)
  std::map<std::string, std::shared_ptr<Job>> jobs_;
  std::deque<std::string> queue_;
  unsigned running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace tetrascope::server
