// The server against the threats of issue 13, each test named after one: jobs that would eat
// the machine, a job queue flooded in a burst, leftovers of killed jobs and servers. The real
// server on an ephemeral loopback port, real HTTP clients (and raw sockets for malformed HTTP).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "tetrascope/server/client.h"
#include "tetrascope/server/server.h"
#include "test_paths.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using tetrascope::testing::scratch_dir;
using tetrascope::testing::shared_data;
using tetrascope::testing::source_dir;
using tetrascope::testing::tetrascope_binary;

class HardeningTest : public ::testing::Test {
 protected:
  ServerOptions options() {
    ServerOptions o;
    o.data_dir = data_dir();
    o.web_root = source_dir() / "web-client";
    o.protocol_root = source_dir() / "protocol";
    o.port = 0;
    o.render_workers = 1;
    o.job_binary = tetrascope_binary();
    o.cache_bytes = 64ull << 20;
    return o;
  }
  void start(const ServerOptions& o) {
    server_ = std::make_unique<Server>(o);
    base_ = "http://127.0.0.1:" + std::to_string(server_->port());
  }
  void start() { start(options()); }
  fs::path data_dir() {
    if (data_.empty()) data_ = scratch_dir(std::string("hardening-") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    return data_;
  }
  nlohmann::json get_json(const std::string& path) {
    const HttpResult r = http_request(base_ + path, "GET");
    EXPECT_EQ(r.status, 200) << path << ": " << r.body;
    return nlohmann::json::parse(r.body);
  }
  nlohmann::json wait_job(const std::string& id, const std::function<bool(const nlohmann::json&)>& until, std::chrono::seconds timeout = 300s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    nlohmann::json job;
    while (std::chrono::steady_clock::now() < deadline) {
      job = get_json("/api/v1/jobs/" + id);
      if (until(job)) return job;
      std::this_thread::sleep_for(50ms);
    }
    ADD_FAILURE() << "job " << id << " never reached the state wanted: " << job.dump();
    return job;
  }
  std::string upload(const fs::path& file, const std::string& name) {
    std::ifstream in(file, std::ios::binary);
    const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const HttpResult r = http_request(base_ + "/api/v1/uploads?name=" + name, "POST", body, "", "application/octet-stream");
    EXPECT_EQ(r.status, 201) << r.body;
    return nlohmann::json::parse(r.body).value("path", "");
  }
  HttpResult submit(const std::string& source, const std::string& name) {
    return http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", name}}).dump());
  }
  // No file a job writes may outlive it.
  void expect_no_job_output(const std::string& id) {
    for (const char* leftover : {"out", "out.tmp", "out.old"}) EXPECT_FALSE(fs::exists(data_dir() / ".jobs" / id / leftover)) << id << "/" << leftover;
  }

  fs::path data_;
  std::unique_ptr<Server> server_;
  std::string base_;
};

// ---- jobs ---------------------------------------------------------------------------------

TEST_F(HardeningTest, AJobPastItsMemoryLimitFailsAsOutOfMemoryAndLeavesNothing) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to the checkout";
  ServerOptions o = options();
  o.job_memory_bytes = 64ull << 20;  // the oxygen mesh needs more; the sample mesh less
  start(o);
  const std::string source = upload(shared_data() / "nasa_oxygen_post.vtk", "oxygen.vtk");
  HttpResult r = submit(source, "oxygen");
  ASSERT_EQ(r.status, 202) << r.body;
  const std::string id = nlohmann::json::parse(r.body)["id"];
  const auto job = wait_job(id, [](const nlohmann::json& j) { return j["state"] != "running" && j["state"] != "queued"; });
  EXPECT_EQ(job["state"], "failed");
  EXPECT_NE(job["error"].get<std::string>().find("out of memory"), std::string::npos) << job.dump();
  EXPECT_NE(job["error"].get<std::string>().find("--job-memory-mb"), std::string::npos) << job.dump();
  EXPECT_FALSE(fs::exists(data_dir() / "oxygen"));
  expect_no_job_output(id);
  EXPECT_EQ(get_json("/api/v1/health")["status"], "ok");
}

TEST_F(HardeningTest, ABurstOfJobsPastTheQueueBoundIsRefusedWith429) {
  ServerOptions o = options();
  o.max_running_jobs = 1;
  o.max_queued_jobs = 2;
  start(o);
  const std::string source = upload(tetrascope::testing::sample_mesh(), "small.vtk");
  std::vector<int> statuses;
  std::string refused;
  for (int i = 0; i < 6; ++i) {
    HttpResult r = submit(source, "small" + std::to_string(i));
    statuses.push_back(r.status);
    if (r.status == 429) refused = r.body;
  }
  // one runs, two wait, the rest are refused (a job may have finished meanwhile: at least 2)
  EXPECT_EQ(statuses[0], 202);
  EXPECT_EQ(statuses[1], 202);
  EXPECT_EQ(statuses[2], 202);
  EXPECT_GE(std::count(statuses.begin(), statuses.end(), 429), 2) << ::testing::PrintToString(statuses);
  EXPECT_NE(refused.find("--max-queued-jobs"), std::string::npos) << refused;
}

TEST_F(HardeningTest, ACancelledJobLeavesNoTemporaryStore) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to the checkout";
  start();
  const std::string source = upload(shared_data() / "nasa_oxygen_post.vtk", "oxygen.vtk");
  HttpResult r = submit(source, "oxygen");
  ASSERT_EQ(r.status, 202) << r.body;
  const std::string id = nlohmann::json::parse(r.body)["id"];
  // into the write stage, where out.tmp/ exists
  wait_job(id, [](const nlohmann::json& j) { return j["stage"] == "write" || j["state"] != "running"; }, 120s);
  http_request(base_ + "/api/v1/jobs/" + id, "DELETE");
  const auto job = wait_job(id, [](const nlohmann::json& j) { return j["state"] != "running"; });
  EXPECT_TRUE(job["state"] == "cancelled" || job["state"] == "done") << job.dump();
  if (job["state"] == "cancelled") expect_no_job_output(id);
}

TEST_F(HardeningTest, LeftoversOfAKilledServerAreSweptOnStart) {
  // what a server killed mid-job leaves: a job folder with out/ and out.tmp/, a job.json.tmp
  const fs::path job = data_dir() / ".jobs" / "jdead";
  fs::create_directories(job / "out.tmp");
  fs::create_directories(job / "out");
  std::ofstream(job / "out.tmp" / "segments.bin") << "partial";
  std::ofstream(job / "job.json") << nlohmann::json({{"id", "jdead"}, {"state", "running"}, {"name", "dead"}, {"source", "uploads/x.vtk"}}).dump();
  std::ofstream(job / "job.json.tmp") << "{";
  start();
  expect_no_job_output("jdead");
  EXPECT_FALSE(fs::exists(job / "job.json.tmp"));
  EXPECT_EQ(get_json("/api/v1/jobs/jdead")["state"], "failed");
}

}  // namespace
}  // namespace tetrascope::server
