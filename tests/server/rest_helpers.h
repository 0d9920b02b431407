// REST calls the server tests make against a running server at `base` (http://127.0.0.1:PORT):
// one copy for every server test file.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <string>
#include <thread>

#include <boost/asio.hpp>
#include <nlohmann/json.hpp>

#include "tetrascope/server/client.h"
#include "tetrascope/server/server.h"
#include "test_paths.h"

namespace tetrascope::testing {

// The sample mesh (disk_out_ref) preprocessed with `--segment-tets segment_tets --base-tets 3000`
// (small segments, so refinement has steps to take); the path of the store, which callers copy
// and never change. Under ctest the fixture test `server_sample_stores` builds the stores once
// a run into TETRA_TEST_STORES (each test is a process of its own, and under ASan a preprocess
// takes seconds); a test run alone builds its own in its scratch folder.
inline const std::filesystem::path& sample_store(uint32_t segment_tets = 2000) {
  static std::map<uint32_t, std::filesystem::path> stores;
  auto [at, added] = stores.try_emplace(segment_tets);
  const std::filesystem::path shared = std::filesystem::path(TETRA_TEST_STORES) / ("disk-" + std::to_string(segment_tets));
  if (added && std::getenv("TETRA_TEST_STORES_BUILT") && std::filesystem::exists(shared / "manifest.json")) {
    at->second = shared;
  } else if (added) {
    at->second = run_scratch_dir("sample-store-" + std::to_string(segment_tets)) / "disk";
    const std::string command = tetrascope_binary().string() + " preprocess " + sample_mesh().string() + " -o " + at->second.string() + " --segment-tets " +
                                std::to_string(segment_tets) + " --base-tets 3000 --progress none > /dev/null";
    EXPECT_EQ(std::system(command.c_str()), 0);
  }
  return at->second;
}

// A test server's options: `data`, the source tree's web client and protocol files, any free
// loopback port, one render worker, jobs run by the tetrascope binary, a 64 MiB cache.
inline server::ServerOptions test_server_options(const std::filesystem::path& data) {
  server::ServerOptions o;
  o.data_dir = data;
  o.web_root = source_dir() / "web-client";
  o.protocol_root = source_dir() / "protocol";
  o.port = 0;
  o.render_workers = 1;
  o.job_binary = tetrascope_binary();
  o.cache_bytes = 64ull << 20;
  return o;
}

// GET `path`, expecting 200 and a JSON body.
// Sends `request` as is on a new connection to 127.0.0.1:`port` (as a page elsewhere could)
// and reads until the server closes it; the whole response.
inline std::string raw_request(uint16_t port, const std::string& request) {
  boost::asio::io_context io;
  boost::asio::ip::tcp::socket socket(io);
  socket.connect({boost::asio::ip::make_address("127.0.0.1"), port});
  boost::asio::write(socket, boost::asio::buffer(request));
  std::string response;
  boost::system::error_code ec;
  char buffer[4096];
  for (;;) {
    const size_t n = socket.read_some(boost::asio::buffer(buffer), ec);
    if (ec) break;
    response.append(buffer, n);
  }
  return response;
}

inline nlohmann::json get_json(const std::string& base, const std::string& path, const std::string& token = "") {
  const server::HttpResult r = server::http_request(base + path, "GET", "", token);
  EXPECT_EQ(r.status, 200) << path << ": " << r.body;
  return nlohmann::json::parse(r.body);
}

// Polls job `id` until `until` holds (or the timeout passes: a test failure).
inline nlohmann::json wait_job(const std::string& base, const std::string& id, const std::function<bool(const nlohmann::json&)>& until,
                               std::chrono::seconds timeout = std::chrono::seconds(300)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  nlohmann::json job;
  while (std::chrono::steady_clock::now() < deadline) {
    job = get_json(base, "/api/v1/jobs/" + id);
    if (until(job)) return job;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ADD_FAILURE() << "job " << id << " never reached the state wanted: " << job.dump();
  return job;
}

// Uploads `file` as `name`, expecting 201; returns the stored path the server reports.
inline std::string upload(const std::string& base, const std::filesystem::path& file, const std::string& name) {
  std::ifstream in(file, std::ios::binary);
  const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const server::HttpResult r = server::http_request(base + "/api/v1/uploads?name=" + name, "POST", body, "", "application/octet-stream");
  EXPECT_EQ(r.status, 201) << r.body;
  return nlohmann::json::parse(r.body).value("path", "");
}

// The next text message of `type` on a session (errors included), skipping frames and other
// messages; a test failure (and null) when none comes within `timeout`.
inline nlohmann::json next_text(server::SessionClient& c, const std::string& type, std::chrono::milliseconds timeout = std::chrono::seconds(30)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    auto m = c.read(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
    if (!m) break;
    if (m->binary) continue;
    auto j = nlohmann::json::parse(m->data);
    if (j["type"] == type) return j;
  }
  ADD_FAILURE() << "no '" << type << "' message within the timeout";
  return {};
}

}  // namespace tetrascope::testing
