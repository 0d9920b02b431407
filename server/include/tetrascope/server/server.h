// `tetrascope serve`: one port for the web client (static files), the REST API under
// /api/v1/ and WebSocket viewing sessions at /api/v1/session (Boost.Asio + Boost.Beast).
//
// Sessions share one pool of render workers (each with its own EGL context) and one segment
// cache budget (ServerOptions::cache_bytes) that every open dataset's segments compete for,
// least recently used released first. A session has at most one render queued or running; camera
// moves are latest-wins, so a burst renders once. Interaction frames use a smaller tet
// budget (chosen by time, see frame_ms) and JPEG quality; ~150 ms after input stops the
// session refines in steps up to a still frame at full budget, quality and size, each step
// interruptible by new input. A slow client never makes frames pile up: one frame is in
// flight and only the newest waits behind it.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "tetrascope/protocol/protocol.h"
#include "tetrascope/storage/sanitizer.h"

namespace tetrascope::server {

// Whether an address-space limit (RLIMIT_AS) can be put on a job: not in a build under
// AddressSanitizer, whose job children reserve terabytes of shadow address space at start and
// would fail under any such limit. There the default is no limit (an explicit one still applies).
constexpr bool kAddressSpaceLimitWorks = !storage::kAddressSanitizer;

struct ServerOptions {
  std::filesystem::path data_dir;      // the stores (datasets), uploads/ and .jobs/
  std::filesystem::path web_root;      // web-client/
  std::filesystem::path protocol_root; // protocol/ (codec.js, schema, openapi.yaml)
  std::string bind = "127.0.0.1";
  uint16_t port = 8080;                // 0: any free port (tests)
  std::string token;                   // empty: no auth, loopback only
  unsigned io_threads = 1;
  unsigned render_workers = 1;
  protocol::Limits limits;
  uint64_t max_upload_bytes = 8ull << 30;
  uint64_t max_request_body_bytes = 1 << 20;  // REST bodies other than uploads
  uint64_t min_upload_bytes_per_second = 4096;  // an upload slower than this over a window is cut off (408)
  std::chrono::milliseconds upload_rate_window{10000};
  unsigned max_running_jobs = 1;
  unsigned max_connections = 256;      // HTTP connections at once (WebSocket sessions count in max_sessions); more are answered 503
  unsigned max_connections_per_ip = 32;  // of them from one client address (503 past it), so no one address fills the cap; 0: no such cap (behind a proxy)
  unsigned max_queued_jobs = 16;       // jobs waiting for a slot; a submit past it gets 429
  uint64_t job_memory_bytes = 0;       // address space (RLIMIT_AS) of each job; 0: the machine's physical memory
  uint32_t job_cpu_seconds = 0;        // CPU time (RLIMIT_CPU) of each job; 0: no limit
  uint64_t cache_bytes = 2ull << 30;   // the segment cache: one budget every open dataset shares
  double max_fps = 30;
  uint64_t interaction_budget = 15000; // tets: the upper limit of interaction frames (their budget comes from frame_ms)
  // Interaction frames aim at this many ms of render-worker time (cut, draw, encode): their
  // tets (and, where even the coarsest cut is over, their pixels) come from a cost model
  // fitted to the frames just drawn (tetrascope/server/frame_cost.h). Default: bench/server_bench.sh.
  double frame_ms = 60;
  // Who draws volumes: "gl" (the GL renderer), "cpu" (the CPU ray caster, renderer/ray_caster.h;
  // the GL renderer draws what it does not) or "auto" (cpu where the GL renderer is software).
  std::string backend = "gl";
  // Refinement after input stops: step k aims at frame_ms * refine_growth^(k+1) ms (at least
  // twice the tets of the step before), up to still_budget (or the error bound); each step a
  // frame flagged refining, the last flagged still. Input stops a step between chunks.
  double refine_growth = 4;
  uint64_t still_budget = 500000;
  int interaction_quality = 60, still_quality = 90;
  double interaction_scale = 0.375;    // of the view size, for interaction frames (fragments dominate on llvmpipe; bench/server_bench.sh)
  std::chrono::milliseconds still_delay{150};
  std::chrono::milliseconds hello_timeout{10000};  // a WebSocket that has not sent hello by then is closed (its session slot freed)
  // A render worker given no task for this long gives back its uploaded scene, framebuffers
  // and caches (Renderer::release_memory) and trims its heap; the next frame uploads again.
  std::chrono::milliseconds worker_idle_release{5000};
  std::filesystem::path job_binary;    // the tetrascope executable jobs run (default: this one)
  bool read_only = false;              // a replica beside a writer on one data folder: no uploads, jobs or deletes, .jobs untouched
};

class Server {
 public:
  // Checks the options (data folder exists, a token when binding beyond loopback), binds the
  // port, opens the render contexts and starts serving. Throws std::invalid_argument or
  // std::runtime_error with a message for the operator.
  explicit Server(ServerOptions options);
  ~Server();  // stops
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  uint16_t port() const;
  void stop();
  void wait();  // until stop() (or SIGINT/SIGTERM when run_until_signal)
  void run_until_signal();

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace tetrascope::server
