// Several servers on one data folder (docs/deploy.md): a --read-only replica serves datasets
// but never touches what the writer beside it owns (jobs, uploads). The real server on an
// ephemeral loopback port and real HTTP clients.
#include <gtest/gtest.h>

#include <fstream>

#include "rest_helpers.h"
#include "tetrascope/server/client.h"
#include "tetrascope/server/server.h"
#include "test_paths.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;
using tetrascope::testing::scratch_dir;

ServerOptions replica_options(const fs::path& data) {
  ServerOptions o = testing::test_server_options(data);
  o.read_only = true;
  return o;
}

TEST(Replicas, AReadOnlyReplicaNeverFailsTheWritersRunningJobs) {
  // the writer's state while it runs a job: a running job record with its output folder,
  // and an upload in progress
  const fs::path data = scratch_dir("replica-read-only");
  const fs::path job = data / ".jobs" / "jwriter";
  fs::create_directories(job / "out.tmp");
  std::ofstream(job / "out.tmp" / "segments.bin") << "being written";
  const std::string record = nlohmann::json({{"id", "jwriter"}, {"state", "running"}, {"name", "wing"}, {"source", "uploads/wing.vtk"}}).dump();
  std::ofstream(job / "job.json") << record;
  fs::create_directories(data / "uploads");
  std::ofstream(data / "uploads" / ".wing.vtk.1234.part") << "half an upload";

  Server replica(replica_options(data));
  const std::string base = "http://127.0.0.1:" + std::to_string(replica.port());
  // the record, its output and the upload are untouched
  std::ifstream in(job / "job.json");
  const std::string after((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(after, record);
  EXPECT_TRUE(fs::exists(job / "out.tmp" / "segments.bin"));
  EXPECT_TRUE(fs::exists(data / "uploads" / ".wing.vtk.1234.part"));

  EXPECT_EQ(testing::get_json(base, "/api/v1/health")["read_only"], true);
  EXPECT_TRUE(testing::get_json(base, "/api/v1/jobs")["jobs"].empty());
  EXPECT_EQ(http_request(base + "/api/v1/jobs/jwriter", "GET").status, 404);
}

TEST(Replicas, AReadOnlyReplicaRefusesUploadsJobsAndDeletesWithAnswersSayingWhere) {
  const fs::path data = scratch_dir("replica-refuses");
  Server replica(replica_options(data));
  const std::string base = "http://127.0.0.1:" + std::to_string(replica.port());
  const HttpResult job = http_request(base + "/api/v1/jobs", "POST", nlohmann::json({{"source", "uploads/x.vtk"}, {"name", "x"}}).dump());
  EXPECT_EQ(job.status, 403);
  EXPECT_NE(job.body.find("read_only"), std::string::npos) << job.body;
  EXPECT_NE(job.body.find("writer"), std::string::npos) << job.body;
  const HttpResult upload = http_request(base + "/api/v1/uploads?name=x.vtk", "POST", std::string(1000, 'x'), "", "application/octet-stream");
  EXPECT_EQ(upload.status, 403) << upload.body;
  EXPECT_FALSE(fs::exists(data / "uploads" / "x.vtk"));
  const HttpResult cancel = http_request(base + "/api/v1/jobs/j1", "DELETE");
  EXPECT_EQ(cancel.status, 403) << cancel.body;
  EXPECT_FALSE(fs::exists(data / ".jobs"));  // a replica never creates the writer's job folder
  // reading is what a replica is for
  EXPECT_EQ(http_request(base + "/api/v1/datasets", "GET").status, 200);
}

}  // namespace
}  // namespace tetrascope::server
