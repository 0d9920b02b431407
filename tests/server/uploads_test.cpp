// The uploads a server holds: listed with what each is for (the datasets made from it, the job
// reading it, a failed job's error), deleted one at a time, and removed with the dataset made
// from them. The threats each have a test: a name that reaches outside uploads/, deleting
// while a job reads the file, a request from another site, a read-only replica. The real
// server on an ephemeral loopback port, real HTTP clients (a raw socket for requests a
// well-behaved client would not send).
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

constexpr const char* kNotAMesh = "these are notes, not a mesh\n";

double now_s() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

class UploadsTest : public ::testing::Test {
 protected:
  ServerOptions options() { return testing::test_server_options(data_dir()); }
  void start(const ServerOptions& o) {
    server_ = std::make_unique<Server>(o);
    base_ = "http://127.0.0.1:" + std::to_string(server_->port());
  }
  void start() { start(options()); }
  fs::path data_dir() {
    if (data_.empty()) data_ = tetrascope::testing::scratch_dir(std::string("uploads-") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    return data_;
  }
  HttpResult call(const std::string& method, const std::string& path, const std::string& body = "") { return http_request(base_ + path, method, body); }
  std::string upload_text(const std::string& name, const std::string& text) {
    const HttpResult r = http_request(base_ + "/api/v1/uploads?name=" + name, "POST", text, "", "application/octet-stream");
    EXPECT_EQ(r.status, 201) << r.body;
    return nlohmann::json::parse(r.body).value("path", "");
  }
  // Submits a job making `name` from `source` and waits until it has ended; returns the job.
  nlohmann::json preprocess(const std::string& source, const std::string& name) {
    const HttpResult r = call("POST", "/api/v1/jobs", nlohmann::json({{"source", source}, {"name", name}}).dump());
    EXPECT_EQ(r.status, 202) << r.body;
    if (r.status != 202) return {};
    const std::string id = nlohmann::json::parse(r.body)["id"];
    return testing::wait_job(base_, id, [](const nlohmann::json& j) { return j["state"] != "queued" && j["state"] != "running"; });
  }
  // The listing's entry for `name`, or null.
  nlohmann::json listed(const std::string& name) {
    const nlohmann::json list = testing::get_json(base_, "/api/v1/uploads");
    for (const auto& u : list["uploads"])
      if (u["name"] == name) return u;
    return nullptr;
  }
  // Sends `request` as is on a new connection; returns the status and the whole response.
  std::pair<int, std::string> raw(const std::string& request) {
    const std::string response = testing::raw_request(server_->port(), request);
    const int status = response.size() > 12 ? std::atoi(response.substr(9, 3).c_str()) : 0;
    return {status, response};
  }
  std::string host() const { return "127.0.0.1:" + std::to_string(server_->port()); }

  fs::path data_;
  std::unique_ptr<Server> server_;
  std::string base_;
};

TEST_F(UploadsTest, TheListingSaysEachUploadsSizeTimeAndWhatItIsFor) {
  start();
  const double before = now_s() - 1;
  const std::string good = testing::upload(base_, tetrascope::testing::sample_mesh(), "good.vtk");
  EXPECT_EQ(preprocess(good, "good")["state"], "done");
  const std::string notes = upload_text("notes.vtk", kNotAMesh);
  const nlohmann::json failed = preprocess(notes, "notes");
  EXPECT_EQ(failed["state"], "failed");
  upload_text("spare.vtk", "spare");

  const nlohmann::json used = listed("good.vtk");
  ASSERT_FALSE(used.is_null());
  EXPECT_EQ(used["path"], "uploads/good.vtk");
  EXPECT_EQ(used["bytes"], fs::file_size(tetrascope::testing::sample_mesh()));
  EXPECT_GE(used["modified"].get<double>(), before);
  EXPECT_LE(used["modified"].get<double>(), now_s() + 1);
  EXPECT_EQ(used["state"], "used") << used.dump();
  EXPECT_EQ(used["datasets"], nlohmann::json::array({"good"}));
  EXPECT_TRUE(used["job"].is_null());
  EXPECT_EQ(used["failed"], false);

  const nlohmann::json broken = listed("notes.vtk");
  EXPECT_EQ(broken["state"], "failed") << broken.dump();
  EXPECT_EQ(broken["failed"], true);
  EXPECT_EQ(broken["failed_job"], failed["id"]);
  EXPECT_EQ(broken["error"], failed["error"]);
  EXPECT_TRUE(broken["datasets"].empty());

  const nlohmann::json spare = listed("spare.vtk");
  EXPECT_EQ(spare["state"], "unused") << spare.dump();
  EXPECT_EQ(spare["bytes"], 5);
  // newest first
  const auto all = testing::get_json(base_, "/api/v1/uploads")["uploads"];
  ASSERT_EQ(all.size(), 3u) << all.dump();
  EXPECT_EQ(all[0]["name"], "spare.vtk");

  // the failed file replaced by another is no longer the one that failed
  std::this_thread::sleep_for(20ms);
  upload_text("notes.vtk", "# vtk DataFile Version 2.0\n");
  EXPECT_EQ(listed("notes.vtk")["state"], "unused");
  EXPECT_EQ(listed("notes.vtk")["failed"], false);
  // and a failed upload is deleted like any other
  EXPECT_EQ(call("DELETE", "/api/v1/uploads/notes.vtk").status, 200);
  EXPECT_TRUE(listed("notes.vtk").is_null());
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "notes.vtk"));
}

TEST_F(UploadsTest, DeletingADatasetDeletesTheUploadItWasMadeFromUnlessAnotherUsesIt) {
  start();
  const fs::path mesh = tetrascope::testing::sample_mesh();
  const std::string alone = testing::upload(base_, mesh, "alone.vtk");
  ASSERT_EQ(preprocess(alone, "alone")["state"], "done");
  HttpResult r = call("DELETE", "/api/v1/datasets/alone");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(nlohmann::json::parse(r.body)["upload_deleted"], "uploads/alone.vtk");
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "alone.vtk"));

  // two datasets from one upload: it goes with the last of them
  const std::string shared = testing::upload(base_, mesh, "shared.vtk");
  ASSERT_EQ(preprocess(shared, "first")["state"], "done");
  ASSERT_EQ(preprocess(shared, "second")["state"], "done");
  EXPECT_EQ(listed("shared.vtk")["datasets"], nlohmann::json::array({"first", "second"}));
  r = call("DELETE", "/api/v1/datasets/first");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_TRUE(nlohmann::json::parse(r.body)["upload_deleted"].is_null()) << r.body;
  EXPECT_TRUE(fs::exists(data_dir() / "uploads" / "shared.vtk"));
  EXPECT_EQ(listed("shared.vtk")["datasets"], nlohmann::json::array({"second"}));
  r = call("DELETE", "/api/v1/datasets/second");
  EXPECT_EQ(nlohmann::json::parse(r.body)["upload_deleted"], "uploads/shared.vtk") << r.body;
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "shared.vtk"));

  // a file uploaded again after its job is another mesh under that name: it stays
  const std::string again = testing::upload(base_, mesh, "again.vtk");
  ASSERT_EQ(preprocess(again, "again")["state"], "done");
  std::this_thread::sleep_for(20ms);
  testing::upload(base_, mesh, "again.vtk");
  r = call("DELETE", "/api/v1/datasets/again");
  EXPECT_TRUE(nlohmann::json::parse(r.body)["upload_deleted"].is_null()) << r.body;
  EXPECT_EQ(listed("again.vtk")["state"], "unused");
}

TEST_F(UploadsTest, DeletingAPathOutsideTheUploadsFolderIsRefused) {
  fs::copy(testing::sample_store(), data_dir() / "disk", fs::copy_options::recursive);
  const fs::path outside = tetrascope::testing::scratch_dir("uploads-outside");
  std::ofstream(outside / "secret.vtk") << "not the server's";
  fs::create_directories(data_dir() / "uploads");
  fs::create_symlink(outside / "secret.vtk", data_dir() / "uploads" / "link.vtk");
  std::ofstream(data_dir() / ".jobs-note") << "beside uploads";
  start();
  for (const std::string name : {"..%2Fdisk%2Fmanifest.json", "..%2F.jobs-note", "%2E%2E%2F%2E%2E%2Fsecret.vtk", "%2Fetc%2Fpasswd", "sub%2Fx.vtk", ".hidden"}) {
    const HttpResult r = call("DELETE", "/api/v1/uploads/" + name);
    EXPECT_EQ(r.status, 400) << name << ": " << r.body;
    EXPECT_NE(r.body.find("bad_name"), std::string::npos) << r.body;
  }
  // the raw path, as no browser sends it
  auto [status, reply] = raw("DELETE /api/v1/uploads/../disk/manifest.json HTTP/1.1\r\nHost: " + host() + "\r\nX-Tetrascope: 1\r\nConnection: close\r\n\r\n");
  EXPECT_TRUE(status == 400 || status == 404) << reply;
  // a symlink in uploads/ is no upload: neither it nor its target goes
  const HttpResult link = call("DELETE", "/api/v1/uploads/link.vtk");
  EXPECT_EQ(link.status, 404) << link.body;
  EXPECT_TRUE(listed("link.vtk").is_null());
  EXPECT_TRUE(fs::is_symlink(data_dir() / "uploads" / "link.vtk"));
  EXPECT_TRUE(fs::exists(outside / "secret.vtk"));
  EXPECT_TRUE(fs::exists(data_dir() / "disk" / "manifest.json"));
  EXPECT_TRUE(fs::exists(data_dir() / ".jobs-note"));
  EXPECT_EQ(reply.find(data_dir().string()), std::string::npos) << "no server path in a reply";
}

TEST_F(UploadsTest, DeletingAnUploadWhileAJobReadsItIsRefused) {
  // a job that reads for a minute: a script standing in for preprocess
  const fs::path slow = tetrascope::testing::scratch_dir("uploads-slow-job") / "slow-preprocess";
  std::ofstream(slow) << "#!/bin/sh\nexec sleep 60\n";
  fs::permissions(slow, fs::perms::owner_all);
  ServerOptions o = options();
  o.job_binary = slow;
  start(o);
  const std::string source = upload_text("busy.vtk", "# vtk DataFile Version 2.0\n");
  const HttpResult submitted = call("POST", "/api/v1/jobs", nlohmann::json({{"source", source}, {"name", "busy"}}).dump());
  ASSERT_EQ(submitted.status, 202) << submitted.body;
  const std::string id = nlohmann::json::parse(submitted.body)["id"];
  testing::wait_job(base_, id, [](const nlohmann::json& j) { return j["state"] == "running"; }, 30s);

  const nlohmann::json busy = listed("busy.vtk");
  EXPECT_EQ(busy["state"], "reading") << busy.dump();
  EXPECT_EQ(busy["job"], id);
  const HttpResult refused = call("DELETE", "/api/v1/uploads/busy.vtk");
  EXPECT_EQ(refused.status, 409) << refused.body;
  const auto error = nlohmann::json::parse(refused.body)["error"];
  EXPECT_EQ(error["code"], "in_use") << refused.body;
  EXPECT_NE(error["message"].get<std::string>().find(id), std::string::npos) << refused.body;
  EXPECT_NE(error["message"].get<std::string>().find("cancel"), std::string::npos) << refused.body;
  EXPECT_TRUE(fs::exists(data_dir() / "uploads" / "busy.vtk"));

  ASSERT_EQ(call("DELETE", "/api/v1/jobs/" + id).status, 200);
  EXPECT_EQ(listed("busy.vtk")["state"], "unused");
  EXPECT_EQ(call("DELETE", "/api/v1/uploads/busy.vtk").status, 200);
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "busy.vtk"));
}

TEST_F(UploadsTest, UploadRequestsFromAnotherSiteAreRefused) {
  start();
  upload_text("mine.vtk", "mine");
  // the listing names files: another site's page may not read it
  auto [status, reply] = raw("GET /api/v1/uploads HTTP/1.1\r\nHost: " + host() + "\r\nOrigin: http://attacker.example\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status, 403) << reply;
  EXPECT_NE(reply.find("cross_origin"), std::string::npos) << reply;
  EXPECT_EQ(reply.find("mine.vtk"), std::string::npos) << reply;
  // a delete a page elsewhere could send: no intent header, or another Origin
  const std::string del = "DELETE /api/v1/uploads/mine.vtk HTTP/1.1\r\nHost: " + host() + "\r\nConnection: close\r\n";
  std::tie(status, reply) = raw(del + "Content-Length: 0\r\n\r\n");
  EXPECT_EQ(status, 403) << reply;
  EXPECT_NE(reply.find("missing_intent"), std::string::npos) << reply;
  std::tie(status, reply) = raw(del + "Origin: http://attacker.example\r\nX-Tetrascope: 1\r\n\r\n");
  EXPECT_EQ(status, 403) << reply;
  EXPECT_TRUE(fs::exists(data_dir() / "uploads" / "mine.vtk"));
  EXPECT_EQ(listed("mine.vtk")["state"], "unused");
  // the server's own page deletes it
  std::tie(status, reply) = raw(del + "Origin: http://" + host() + "\r\nX-Tetrascope: 1\r\n\r\n");
  EXPECT_EQ(status, 200) << reply;
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "mine.vtk"));
}

TEST_F(UploadsTest, WithATokenListingAndDeletingUploadsNeedIt) {
  ServerOptions o = options();
  o.token = "upload-token";
  start(o);
  fs::create_directories(data_dir() / "uploads");
  std::ofstream(data_dir() / "uploads" / "kept.vtk") << "kept";
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads", "GET").status, 401);
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads/kept.vtk", "DELETE").status, 401);
  EXPECT_TRUE(fs::exists(data_dir() / "uploads" / "kept.vtk"));
  const auto list = testing::get_json(base_, "/api/v1/uploads", "upload-token")["uploads"];
  ASSERT_EQ(list.size(), 1u) << list.dump();
  EXPECT_EQ(list[0]["state"], "unused");
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads/kept.vtk", "DELETE", "", "upload-token").status, 200);
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "kept.vtk"));
}

TEST_F(UploadsTest, AReadOnlyReplicaListsUploadsAndRefusesToDeleteThem) {
  fs::create_directories(data_dir() / "uploads");
  std::ofstream(data_dir() / "uploads" / "writers.vtk") << "the writer's";
  ServerOptions o = options();
  o.read_only = true;
  start(o);
  const nlohmann::json upload = listed("writers.vtk");
  ASSERT_FALSE(upload.is_null());
  EXPECT_EQ(upload["bytes"], 12);
  EXPECT_TRUE(upload["modified"].is_number());
  const HttpResult r = call("DELETE", "/api/v1/uploads/writers.vtk");
  EXPECT_EQ(r.status, 403) << r.body;
  EXPECT_NE(r.body.find("read_only"), std::string::npos) << r.body;
  EXPECT_TRUE(fs::exists(data_dir() / "uploads" / "writers.vtk"));
}

}  // namespace
}  // namespace tetrascope::server
