#include "tetrascope/server/server.h"

#include <malloc.h>

#include <csignal>
#include <cstdio>

#include "rest.h"
#include "server_impl.h"

namespace tetrascope::server {
namespace fs = std::filesystem;

Server::Server(ServerOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  std::error_code ec;
  if (!fs::is_directory(options.data_dir, ec)) throw std::invalid_argument("--data " + options.data_dir.string() + ": not a folder");
  options.data_dir = fs::canonical(options.data_dir);
  if (!fs::is_regular_file(options.web_root / "index.html", ec)) throw std::invalid_argument("the web client is missing: no " + (options.web_root / "index.html").string());
  boost::system::error_code net_ec;
  const auto address = net::ip::make_address(options.bind, net_ec);
  if (net_ec) throw std::invalid_argument("--bind " + options.bind + ": not an IP address");
  if (!address.is_loopback() && options.token.empty())
    throw std::invalid_argument("--bind " + options.bind + " reaches beyond this machine: give a --token (clients then send Authorization: Bearer TOKEN)");
  if (options.max_fps <= 0) throw std::invalid_argument("--max-fps must be above 0");
  if (options.job_binary.empty()) options.job_binary = fs::read_symlink("/proc/self/exe", ec);
  s.options = std::move(options);
  s.datasets = std::make_unique<DatasetRegistry>(s.options.data_dir, s.options.cache_bytes);
  JobLimits job_limits;
  job_limits.memory_bytes = s.options.job_memory_bytes > 0 ? s.options.job_memory_bytes : (kAddressSpaceLimitWorks ? physical_memory_bytes() : 0);
  job_limits.cpu_seconds = s.options.job_cpu_seconds;
  job_limits.max_queued = s.options.max_queued_jobs;
  // a read-only replica neither runs jobs nor sweeps: the writer beside it owns .jobs, uploads
  // and the stores it is writing
  if (!s.options.read_only) {
    s.jobs = std::make_unique<JobRunner>(s.options.data_dir, s.options.job_binary, s.options.max_running_jobs, job_limits);
    sweep_stale_uploads(s.options.data_dir);   // no upload runs yet: every .part is a leftover
    sweep_data_leftovers(s.options.data_dir);  // DATA/*.tmp and .trash-*: stores half written, deletes cut off
  }
  s.pool = std::make_unique<RenderPool>(s.options.render_workers, s.options.worker_idle_release, s.options.backend);
  s.acceptor = std::make_unique<net::ip::tcp::acceptor>(s.io);
  s.accept_pause = std::make_unique<net::steady_timer>(s.io);
  const net::ip::tcp::endpoint endpoint(address, s.options.port);
  s.acceptor->open(endpoint.protocol());
  s.acceptor->set_option(net::socket_base::reuse_address(true));
  s.acceptor->bind(endpoint, net_ec);
  if (net_ec) throw std::runtime_error("cannot listen on " + s.options.bind + ":" + std::to_string(s.options.port) + ": " + net_ec.message());
  s.acceptor->listen(net::socket_base::max_listen_connections);
  s.accept();
  s.idle_trim = std::make_unique<net::steady_timer>(s.io);
  s.trim_when_idle();
  for (unsigned i = 0; i < std::max(1u, s.options.io_threads); ++i) s.threads.emplace_back([&s] { s.run_io(); });
}

void Server::Impl::run_io() {
  // Handlers catch what they expect; an exception one did not is logged and counted, and the
  // thread goes on serving: one request or session never ends the process for every user.
  for (;;) {
    try {
      io.run();
      return;
    } catch (const std::exception& e) {
      ++metrics.handler_exceptions;
      std::fprintf(stderr, "tetrascope serve: a request failed unexpectedly: %s\n", without_server_paths(e.what(), options.data_dir).c_str());
    } catch (...) {
      ++metrics.handler_exceptions;
      std::fprintf(stderr, "tetrascope serve: a request failed unexpectedly\n");
    }
  }
}

Server::~Server() {
  stop();
  wait();
  // sessions hold the pool and datasets through Impl: the io threads are joined, so no
  // handler runs any more; the pool's workers finish their current task and stop.
  impl_->io.restart();
  impl_->io.poll();  // lets pending handlers release their sessions
  // a worker's task may submit the session's next one to the pool: stop the workers while the
  // pool is still there (resetting the pointer first left them a null pool: a crash on SIGTERM
  // with sessions rendering, found by the replicas test)
  if (impl_->pool) impl_->pool->shutdown();
  impl_->pool.reset();
}

void Server::Impl::trim_when_idle() {
  idle_trim->expires_after(kIdleTrimPeriod);
  idle_trim->async_wait([this](const boost::system::error_code& ec) {
    if (ec || stopped) return;
    const uint64_t frames = metrics.frames_still + metrics.frames_interaction;
    if (metrics.sessions_active == 0 && frames != frames_at_last_trim) {
      frames_at_last_trim = frames;
      ::malloc_trim(0);
    }
    trim_when_idle();
  });
}

uint16_t Server::port() const { return impl_->acceptor->local_endpoint().port(); }

void Server::stop() {
  if (impl_->stopped.exchange(true)) return;
  net::post(impl_->io, [this] {
    boost::system::error_code ec;
    impl_->acceptor->close(ec);
  });
  impl_->io.stop();
}

void Server::wait() {
  for (auto& t : impl_->threads)
    if (t.joinable()) t.join();
}

void Server::run_until_signal() {
  net::signal_set signals(impl_->io, SIGINT, SIGTERM);
  signals.async_wait([this](const boost::system::error_code& ec, int) {
    if (!ec) stop();
  });
  wait();
}

}  // namespace tetrascope::server
