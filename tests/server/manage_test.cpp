// Managing what the server holds: deleting datasets and uploads (never half
// deleted; a dataset in use is closed for its sessions with a message), cancel answering the
// final state, REST error answers counted in /metrics, no server path in any reply a client
// sees. The real server on an ephemeral loopback port, real HTTP and WebSocket clients.
#include <chrono>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "rest_helpers.h"
#include "tetrascope/server/client.h"
#include "tetrascope/server/server.h"
#include "test_paths.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using tetrascope::testing::shared_data;
using tetrascope::testing::source_dir;
using tetrascope::testing::tetrascope_binary;

class ManageTest : public ::testing::Test {
 protected:
  ServerOptions options() { return testing::test_server_options(data_dir()); }
  void start(const ServerOptions& o) {
    server_ = std::make_unique<Server>(o);
    base_ = "http://127.0.0.1:" + std::to_string(server_->port());
    ws_ = "ws://127.0.0.1:" + std::to_string(server_->port()) + "/api/v1/session";
  }
  void start() { start(options()); }
  fs::path data_dir() {
    if (data_.empty()) {
      data_ = tetrascope::testing::scratch_dir(std::string("manage-") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
      fs::copy(testing::sample_store(), data_ / "disk", fs::copy_options::recursive);
    }
    return data_;
  }
  HttpResult call(const std::string& method, const std::string& path, const std::string& body = "") { return http_request(base_ + path, method, body); }
  HttpResult submit(const std::string& source, const std::string& name) {
    return call("POST", "/api/v1/jobs", nlohmann::json({{"source", source}, {"name", name}}).dump());
  }
  std::string upload_text(const std::string& name, const std::string& text) {
    const HttpResult r = http_request(base_ + "/api/v1/uploads?name=" + name, "POST", text, "", "application/octet-stream");
    EXPECT_EQ(r.status, 201) << r.body;
    return nlohmann::json::parse(r.body).value("path", "");
  }
  static nlohmann::json next_text(SessionClient& c, const std::string& type, std::chrono::milliseconds timeout = 30s) {
    return testing::next_text(c, type, timeout);
  }
  bool no_trash_left() {
    for (const auto& entry : fs::directory_iterator(data_dir()))
      if (entry.path().filename().string().rfind(".trash-", 0) == 0) return false;
    return true;
  }

  fs::path data_;
  std::unique_ptr<Server> server_;
  std::string base_, ws_;
};

// ---- deleting datasets ------------------------------------------------------------------------

TEST_F(ManageTest, DeletingADatasetInUseClosesItForItsSessionsWithAMessage) {
  start();
  SessionClient c(ws_);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send("view.resize", {{"width", 160}, {"height", 120}});
  c.send("dataset.open", {{"name", "disk"}});
  c.expect("dataset.info", 60s);

  const HttpResult r = call("DELETE", "/api/v1/datasets/disk");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto reply = nlohmann::json::parse(r.body);
  EXPECT_EQ(reply["deleted"], "disk");
  EXPECT_EQ(reply["sessions_closed"], 1);
  const auto told = next_text(c, "error");
  EXPECT_EQ(told["code"], "dataset_deleted") << told.dump();
  EXPECT_TRUE(told["id"].is_null()) << told.dump();
  EXPECT_NE(told["message"].get<std::string>().find("disk"), std::string::npos) << told.dump();
  // nothing of it is left, under its name or aside
  EXPECT_FALSE(fs::exists(data_dir() / "disk"));
  EXPECT_TRUE(no_trash_left());
  EXPECT_TRUE(testing::get_json(base_, "/api/v1/datasets")["datasets"].empty());
  EXPECT_EQ(call("GET", "/api/v1/datasets/disk").status, 404);
  // the session lives on, without a dataset
  c.send("camera.set", {{"eye", {0, 0, 30}}, {"target", {0, 0, 0}}, {"up", {0, 1, 0}}, {"fov", 30}});
  EXPECT_EQ(next_text(c, "error")["code"], "no_dataset");
  c.send("ping", nlohmann::json::object());
  next_text(c, "pong");
}

// A refinement step in flight when its dataset is deleted used to queue the next step: a turn
// that rendered no dataset and crashed the server (a null dataset), for every user. Many small
// steps (frame_ms 2, growth 1.3) so that a step is drawing when the deletion lands.
TEST_F(ManageTest, DeletingADatasetWhileItsSessionRefinesNeverCrashesTheServer) {
  ServerOptions o = options();
  o.frame_ms = 2;
  o.refine_growth = 1.3;
  o.still_delay = 0ms;
  start(o);
  SessionClient c(ws_);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send("view.resize", {{"width", 320}, {"height", 240}});
  for (int round = 0; round < 12; ++round) {
    const std::string name = "victim-" + std::to_string(round);
    fs::copy(testing::sample_store(), data_dir() / name, fs::copy_options::recursive);
    c.send("dataset.open", {{"name", name}});
    c.expect("dataset.info", 60s);
    c.send("camera.set", {{"eye", {0, 0, 30}}, {"target", {0, 0, 0}}, {"up", {0, 1, 0}}, {"fov", 30}});
    std::this_thread::sleep_for(std::chrono::milliseconds(5 * round));  // somewhere in the refinement
    ASSERT_EQ(call("DELETE", "/api/v1/datasets/" + name).status, 200) << "round " << round;
    EXPECT_EQ(next_text(c, "error")["code"], "dataset_deleted") << "round " << round;
    // what was in flight has landed: the session and the server still answer
    std::this_thread::sleep_for(200ms);
    c.send("ping", nlohmann::json::object());
    next_text(c, "pong");
  }
  c.send("dataset.open", {{"name", "disk"}});
  c.expect("dataset.info", 60s);
  EXPECT_EQ(testing::get_json(base_, "/api/v1/datasets")["datasets"].size(), 1u);
  EXPECT_TRUE(no_trash_left());
}

TEST_F(ManageTest, DeletingADatasetNoSessionViewsTellsNobody) {
  start();
  const HttpResult r = call("DELETE", "/api/v1/datasets/disk");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(nlohmann::json::parse(r.body)["sessions_closed"], 0);
  EXPECT_FALSE(fs::exists(data_dir() / "disk"));
  EXPECT_EQ(call("DELETE", "/api/v1/datasets/disk").status, 404);  // once
}

TEST_F(ManageTest, DeletingWhatIsNotADatasetIs404AndTouchesNothing) {
  fs::create_directories(data_dir() / "uploads");
  std::ofstream(data_dir() / "uploads" / "keep.vtk") << "kept";
  fs::create_directories(data_dir() / "plain-folder");
  start();
  for (const std::string target : {"nope", "uploads", "plain-folder", "..%2Fdisk", ".jobs", ""}) {
    const HttpResult r = call("DELETE", "/api/v1/datasets/" + target);
    EXPECT_EQ(r.status, 404) << target << ": " << r.body;
  }
  EXPECT_TRUE(fs::exists(data_dir() / "disk" / "manifest.json"));
  EXPECT_TRUE(fs::exists(data_dir() / "uploads" / "keep.vtk"));
  EXPECT_TRUE(fs::exists(data_dir() / "plain-folder"));
}

TEST_F(ManageTest, DeletingNeedsTheSameAuthorityAsOtherWrites) {
  {  // with a token: none, no deletion
    ServerOptions o = options();
    o.token = "secret-token";
    start(o);
    EXPECT_EQ(http_request(base_ + "/api/v1/datasets/disk", "DELETE").status, 401);
    EXPECT_TRUE(fs::exists(data_dir() / "disk"));
    EXPECT_EQ(http_request(base_ + "/api/v1/datasets/disk", "DELETE", "", "secret-token").status, 200);
    EXPECT_FALSE(fs::exists(data_dir() / "disk"));
    server_.reset();
  }
  fs::copy(testing::sample_store(), data_dir() / "disk", fs::copy_options::recursive);
  start();  // without a token: a cross-site request (no intent header) deletes nothing
  {  // a raw request, as a page elsewhere could send it
    const std::string host = "127.0.0.1:" + std::to_string(server_->port());
    const std::string request = "DELETE /api/v1/datasets/disk HTTP/1.1\r\nHost: " + host + "\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
    const std::string response = testing::raw_request(server_->port(), request);
    EXPECT_EQ(response.rfind("HTTP/1.1 403", 0), 0u) << response;
    EXPECT_NE(response.find("missing_intent"), std::string::npos) << response;
  }
  EXPECT_TRUE(fs::exists(data_dir() / "disk" / "manifest.json"));
}

// ---- deleting uploads ---------------------------------------------------------------------------

TEST_F(ManageTest, DeletingAnUploadRemovesItOnceAndNeverOneAJobReads) {
  start();
  const std::string path = upload_text("old.vtk", "# vtk DataFile Version 2.0\n");
  EXPECT_EQ(path, "uploads/old.vtk");
  const HttpResult r = call("DELETE", "/api/v1/uploads/old.vtk");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(nlohmann::json::parse(r.body)["deleted"], "uploads/old.vtk");
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "old.vtk"));
  EXPECT_EQ(call("DELETE", "/api/v1/uploads/old.vtk").status, 404);
  EXPECT_EQ(call("DELETE", "/api/v1/uploads/..%2Fdisk%2Fmanifest.json").status, 400);  // not a name in uploads/
  EXPECT_TRUE(fs::exists(data_dir() / "disk" / "manifest.json"));

  // a job reading an upload keeps it: the delete is refused while the job is queued or running
  const fs::path mesh = shared_data().empty() ? tetrascope::testing::sample_mesh() : shared_data() / "nasa_oxygen_post.vtk";
  const std::string source = testing::upload(base_, mesh, "busy.vtk");
  const HttpResult job = submit(source, "busy");
  ASSERT_EQ(job.status, 202) << job.body;
  const std::string id = nlohmann::json::parse(job.body)["id"];
  const HttpResult refused = call("DELETE", "/api/v1/uploads/busy.vtk");
  const auto state = testing::get_json(base_, "/api/v1/jobs/" + id)["state"];
  if (state == "queued" || state == "running") {  // (the job did not end between the two calls)
    EXPECT_EQ(refused.status, 409) << refused.body;
    EXPECT_NE(refused.body.find(id), std::string::npos) << refused.body;
    EXPECT_TRUE(fs::exists(data_dir() / "uploads" / "busy.vtk"));
  }
  call("DELETE", "/api/v1/jobs/" + id);
  EXPECT_EQ(call("DELETE", "/api/v1/uploads/busy.vtk").status, 200);
}

// ---- cancelling jobs ----------------------------------------------------------------------------

TEST_F(ManageTest, CancellingARunningJobAnswersItsFinalState) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to the checkout";
  start();
  const std::string source = testing::upload(base_, shared_data() / "nasa_oxygen_post.vtk", "oxygen.vtk");
  const HttpResult r = submit(source, "oxygen");
  ASSERT_EQ(r.status, 202) << r.body;
  const std::string id = nlohmann::json::parse(r.body)["id"];
  testing::wait_job(base_, id, [](const nlohmann::json& j) { return j["pid"].is_number() || j["state"] != "running"; }, 120s);
  const HttpResult cancelled = call("DELETE", "/api/v1/jobs/" + id);
  ASSERT_EQ(cancelled.status, 200) << cancelled.body;
  const auto job = nlohmann::json::parse(cancelled.body);
  EXPECT_TRUE(job["state"] == "cancelled" || job["state"] == "done") << job.dump();  // never "running"
  EXPECT_TRUE(job["pid"].is_null()) << job.dump();
  EXPECT_FALSE(fs::exists(data_dir() / ".jobs" / id / "out"));
}

TEST_F(ManageTest, CancellingAQueuedJobAnswersCancelled) {
  ServerOptions o = options();
  o.max_running_jobs = 1;
  start(o);
  const std::string source = testing::upload(base_, tetrascope::testing::sample_mesh(), "small.vtk");
  const HttpResult first = submit(source, "first");
  const HttpResult second = submit(source, "second");
  ASSERT_EQ(second.status, 202) << second.body;
  const std::string id = nlohmann::json::parse(second.body)["id"];
  const HttpResult cancelled = call("DELETE", "/api/v1/jobs/" + id);
  ASSERT_EQ(cancelled.status, 200) << cancelled.body;
  const std::string state = nlohmann::json::parse(cancelled.body)["state"];
  EXPECT_TRUE(state == "cancelled" || state == "done" || state == "failed") << cancelled.body;
  testing::wait_job(base_, nlohmann::json::parse(first.body)["id"], [](const nlohmann::json& j) { return j["state"] != "running" && j["state"] != "queued"; });
}

// ---- metrics --------------------------------------------------------------------------------

TEST_F(ManageTest, RestErrorAnswersAreCountedInMetricsByRouteAndStatus) {
  start();
  EXPECT_EQ(call("GET", "/api/v1/datasets/nope").status, 404);
  EXPECT_EQ(call("DELETE", "/api/v1/datasets/nope").status, 404);
  EXPECT_EQ(call("GET", "/api/v1/jobs/nope").status, 404);
  EXPECT_EQ(call("POST", "/api/v1/jobs", "not json").status, 400);
  EXPECT_EQ(call("GET", "/api/v1/nothing-here").status, 404);
  EXPECT_EQ(call("GET", "/api/v1/datasets").status, 200);  // not counted
  const HttpResult m = call("GET", "/metrics");
  ASSERT_EQ(m.status, 200);
  EXPECT_NE(m.body.find("tetrascope_http_errors_total{route=\"datasets\",status=\"404\"} 2\n"), std::string::npos) << m.body;
  EXPECT_NE(m.body.find("tetrascope_http_errors_total{route=\"jobs\",status=\"404\"} 1\n"), std::string::npos) << m.body;
  EXPECT_NE(m.body.find("tetrascope_http_errors_total{route=\"jobs\",status=\"400\"} 1\n"), std::string::npos) << m.body;
  EXPECT_NE(m.body.find("tetrascope_http_errors_total{route=\"api_other\",status=\"404\"} 1\n"), std::string::npos) << m.body;
  EXPECT_EQ(m.body.find("status=\"200\""), std::string::npos) << m.body;
}

// ---- no server path in any reply ----------------------------------------------------------------

TEST_F(ManageTest, FailingJobsUploadsAndDatasetsNeverShowTheServersPaths) {
  // a damaged store next to the good one
  fs::create_directories(data_dir() / "broken");
  std::ofstream(data_dir() / "broken" / "manifest.json") << "{\"format\": \"not a store\"";
  start();
  const std::string root = data_dir().string();
  std::vector<std::pair<std::string, std::string>> replies;  // what, body

  // a job that fails on a file that is no mesh, and one whose mesh has the wrong extension
  for (const auto& [file, text] : std::vector<std::pair<std::string, std::string>>{{"bad.vtk", "# vtk DataFile Version 2.0\nbroken\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 9 float\n1 2\n"},
                                                                                  {"bad.xyz", "nothing"}}) {
    const std::string source = upload_text(file, text);
    const HttpResult r = submit(source, "from-" + fs::path(file).stem().string() + fs::path(file).extension().string().substr(1));
    ASSERT_EQ(r.status, 202) << r.body;
    const auto job = testing::wait_job(base_, nlohmann::json::parse(r.body)["id"], [](const nlohmann::json& j) { return j["state"] != "running" && j["state"] != "queued"; });
    EXPECT_EQ(job["state"], "failed") << job.dump();
    replies.emplace_back("job " + file, job.dump());
  }
  replies.emplace_back("jobs", call("GET", "/api/v1/jobs").body);
  replies.emplace_back("datasets", call("GET", "/api/v1/datasets").body);
  replies.emplace_back("dataset broken", call("GET", "/api/v1/datasets/broken").body);
  replies.emplace_back("submit missing", submit("uploads/missing.vtk", "x").body);
  replies.emplace_back("upload bad name", http_request(base_ + "/api/v1/uploads?name=..%2Fx", "POST", "x", "", "application/octet-stream").body);
  // the session's answer to opening the damaged store
  SessionClient c(ws_);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send("dataset.open", {{"name", "broken"}});
  replies.emplace_back("session open broken", next_text(c, "error").dump());

  for (const auto& [what, body] : replies) EXPECT_EQ(body.find(root), std::string::npos) << what << " shows the data folder: " << body;
  // and the damaged store's state still says why
  EXPECT_NE(replies[3].second.find("unreadable"), std::string::npos) << replies[3].second;
}

// ---- names ------------------------------------------------------------------------------------

TEST_F(ManageTest, AJobMayNotMakeADatasetNamedLikeALeftover) {
  start();
  const std::string source = upload_text("m.vtk", "x");
  const HttpResult r = submit(source, "mesh.tmp");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_NE(r.body.find(".tmp"), std::string::npos) << r.body;
}

}  // namespace
}  // namespace tetrascope::server
