// The parts of a running server, shared by the HTTP and WebSocket sessions.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "datasets.h"
#include "tetrascope/server/frame_cost.h"
#include "jobs.h"
#include "metrics.h"
#include "render_pool.h"
#include "tetrascope/server/server.h"

namespace tetrascope::server {

namespace net = boost::asio;

struct Server::Impl {
  ServerOptions options;
  // What a connection's or session's destructor touches is declared before io: handlers still
  // pending when the server stops are destroyed with io, after the members declared below it.
  Metrics metrics;
  std::atomic<int64_t> http_connections{0};
  // names under uploads/ whose upload is streaming in: a second one is refused (409)
  std::mutex uploads_mutex;
  std::set<std::string> uploads_in_progress;
  // Connections per client address, and those waiting on a request header (a slow or idle
  // client), by arrival: at the connection cap the oldest of these that has waited at least
  // kEvictAfter is closed to let a new connection in, so clients that trickle headers cannot
  // hold every slot; near the cap a header must arrive within kBusyHeaderTimeout.
  static constexpr std::chrono::seconds kEvictAfter{1};
  static constexpr std::chrono::seconds kBusyHeaderTimeout{5};
  struct Waiting {
    std::chrono::steady_clock::time_point since;
    std::function<void()> close;  // posts the close to the connection's strand
  };
  std::mutex connections_mutex;
  std::map<net::ip::address, unsigned> connections_by_ip;
  std::map<uint64_t, Waiting> waiting_headers;
  uint64_t next_waiting = 0;
  net::io_context io;
  std::unique_ptr<net::ip::tcp::acceptor> acceptor;
  std::vector<std::thread> threads;
  std::unique_ptr<DatasetRegistry> datasets;
  FrameCostModel frame_cost;  // what a frame costs the pool's workers, fitted from every session's frames (outlives the pool)
  std::unique_ptr<RenderPool> pool;
  std::unique_ptr<JobRunner> jobs;
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
  std::atomic<bool> stopped{false};
  // accept() waits this long when the process is out of file descriptors, instead of spinning
  static constexpr std::chrono::milliseconds kAcceptPause{100};
  std::unique_ptr<net::steady_timer> accept_pause;
  // Every kIdleTrimPeriod with no session open, after frames were rendered since the last
  // time: malloc_trim, so the heap freed by sessions and renders goes back to the system
  // (glibc keeps it in per-thread arenas otherwise; bench/idle_memory.py).
  static constexpr std::chrono::seconds kIdleTrimPeriod{5};
  std::unique_ptr<net::steady_timer> idle_trim;
  uint64_t frames_at_last_trim = 0;
  void trim_when_idle();

  void accept();
  void on_accept_failed(const boost::system::error_code& ec);
  void run_io();  // one io thread: io.run(), going on past any exception a handler let through
  // Admits a new connection from `address` or says why not: the per-address cap first (a
  // connection that will be refused evicts nobody), then the global cap, where the connection
  // waiting longest on its header makes room. Counts the address when admitted.
  bool admit(const net::ip::address& address);
  void accepted(net::ip::tcp::socket socket);  // admitted (a session started) or answered 503
  void release(const net::ip::address& address);  // a connection from `address` ended
  bool near_connection_cap() const { return http_connections * 4 >= int64_t{options.max_connections} * 3; }
  // Closes the oldest connection waiting on a header for kEvictAfter or longer; false if none.
  bool evict_one_waiting();
  // constant time in the token's length
  bool token_matches(std::string_view offered) const;
};

// Starts one WebSocket viewing session on an upgraded connection (session.cpp).
void start_ws_session(Server::Impl& server, boost::beast::tcp_stream stream, boost::beast::http::request<boost::beast::http::empty_body> request);

}  // namespace tetrascope::server
