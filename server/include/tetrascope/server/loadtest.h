// `tetrascope loadtest`: N concurrent viewing sessions replaying a camera path against a
// server; input-to-frame latency comes from each frame header's message id.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace tetrascope::server {

struct LoadtestOptions {
  std::string url;           // ws://HOST:PORT/api/v1/session
  std::string dataset;
  std::string token;
  unsigned clients = 1;      // 1..kMaxLoadtestClients
  double duration_s = 10;    // 1..kMaxLoadtestSeconds
  std::string path = "orbit";  // orbit | random | orbit-pause
  // orbit-pause: orbit for orbit_s, stop for pause_s (long enough for refinement to start),
  // orbit again, ...; reports the latency of the first frame after each resume, and for each
  // pause the time from the last move to each refinement step and to the still.
  double orbit_s = 2, pause_s = 1.5;
  std::string save_refinement;  // a folder: client 0's refinement steps of its first pause, as received (step-K.jpg, still.*, steps.json)
  double rate_hz = 30;       // camera messages a second per client
  uint32_t width = 1024, height = 768;
  bool allow_remote = false; // else loopback hosts only
  bool reconnect = true;     // a session lost mid-run (a replica gone) is opened again and counted, not a failure
  std::string mode;          // sent as mode.set once the dataset is open (protocol::parse_modes); empty: the server's default
};
constexpr unsigned kMaxLoadtestClients = 64;
constexpr double kMaxLoadtestSeconds = 600;

// Runs the test; throws std::invalid_argument for bad options, std::runtime_error when the
// server cannot be reached. Returns per-client and total figures (docs/commands/loadtest.md).
nlohmann::json run_loadtest(const LoadtestOptions& options);

}  // namespace tetrascope::server
