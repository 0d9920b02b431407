// The server against damaged and degenerate datasets and slow clients: one store, however
// damaged or degenerate, and one client, however slow, never stops the service for the others.
// Each test is named after its threat. The real server on an ephemeral loopback port, real
// WebSocket and HTTP clients, stores made by the real `tetrascope preprocess`.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <thread>
#include <utility>

#include <gtest/gtest.h>

#include "cli_run.h"
#include "fixture_writers.h"
#include "rest_helpers.h"
#include "tetrascope/server/client.h"
#include "tetrascope/server/server.h"
#include "tetrascope/storage/store.h"
#include "test_paths.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using tetrascope::testing::scratch_dir;

std::vector<char> read_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
void write_bytes(const fs::path& file, const std::vector<char>& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Runs `tetrascope ARGS`; its exit status (a signal shows as 128 + N, as a shell says it).
int tetrascope(const std::string& args) {
  const int status = std::system((testing::tetrascope_binary().string() + " " + args + " > /dev/null 2>&1").c_str());
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class DamagedDatasetTest : public ::testing::Test {
 protected:
  fs::path data_dir() {
    if (data_.empty()) data_ = scratch_dir(std::string("damaged-") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    return data_;
  }
  void start(ServerOptions o) {
    server_ = std::make_unique<Server>(std::move(o));
    base_ = "http://127.0.0.1:" + std::to_string(server_->port());
    ws_ = "ws://127.0.0.1:" + std::to_string(server_->port()) + "/api/v1/session";
  }
  void start() { start(testing::test_server_options(data_dir())); }
  // A copy of the sample store as dataset `name`.
  void add_sample(const std::string& name) { fs::copy(testing::sample_store(), data_dir() / name, fs::copy_options::recursive); }
  // The sample preprocessed with one variant a segment, as dataset `name`.
  void add_sample_with_variants(const std::string& name) {
    ASSERT_EQ(tetrascope("preprocess " + testing::sample_mesh().string() + " -o " + (data_dir() / name).string() +
                         " --segment-tets 2000 --base-tets 3000 --variants 1 --progress none"),
              0);
    ASSERT_TRUE(fs::exists(data_dir() / name / "variants.bin"));
  }
  // A session that said hello and sized its view.
  std::unique_ptr<SessionClient> session() {
    auto c = std::make_unique<SessionClient>(ws_);
    c->send("hello", {{"version", 1}});
    c->expect("hello.ok");
    c->send("view.resize", {{"width", 160}, {"height", 120}});
    return c;
  }
  static nlohmann::json next_text(SessionClient& c, const std::string& type, std::chrono::milliseconds timeout = 60s) {
    return testing::next_text(c, type, timeout);
  }
  // True when a frame (binary message) arrives within `timeout`.
  static bool frame_arrives(SessionClient& c, std::chrono::milliseconds timeout = 60s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      auto m = c.read(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
      if (!m) return false;
      if (m->binary) return true;
    }
    return false;
  }
  // The server still serves: health answers and a good dataset opens and draws a frame.
  void expect_still_serving(const std::string& good) {
    EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET").status, 200);
    auto c = session();
    c->send("dataset.open", {{"name", good}});
    next_text(*c, "dataset.info");
    EXPECT_TRUE(frame_arrives(*c)) << "no frame of a sound dataset after the damaged one";
  }

  fs::path data_;
  std::unique_ptr<Server> server_;
  std::string base_, ws_;
};

// A store whose variants.bin was cut to half its bytes: dataset.open answers dataset_damaged,
// the camera.set after it no_dataset, and the server goes on serving (it crashed in the frame
// after the failed open: the frame maker kept the dataset with no pipeline).
TEST_F(DamagedDatasetTest, ATruncatedVariantsFileNeverCrashesTheServer) {
  add_sample_with_variants("d");
  add_sample("good");
  const fs::path variants = data_dir() / "d" / "variants.bin";
  std::vector<char> bytes = read_bytes(variants);
  bytes.resize(bytes.size() / 2);
  write_bytes(variants, bytes);
  start();
  auto c = session();
  c->send("dataset.open", {{"name", "d"}});
  const auto refused = next_text(*c, "error");
  EXPECT_EQ(refused["code"], "dataset_damaged") << refused.dump();
  EXPECT_NE(refused["message"].get<std::string>().find("variants.bin"), std::string::npos) << refused.dump();
  c->send("camera.set", {{"eye", {0, 0, 30}}, {"target", {0, 0, 0}}, {"up", {0, 1, 0}}, {"fov", 30}});
  EXPECT_EQ(next_text(*c, "error")["code"], "no_dataset");
  // the list says why it cannot be viewed
  const auto list = testing::get_json(base_, "/api/v1/datasets");
  bool marked = false;
  for (const auto& d : list["datasets"]) marked |= d["name"] == "d" && d["state"].get<std::string>().rfind("damaged", 0) == 0;
  EXPECT_TRUE(marked) << list.dump();
  expect_still_serving("good");
}

// A binary segment hierarchy (preprocess --model binary) serves as the multi-triangulation
// does: dataset.open names the model and frames arrive; the same store with a flipped byte in
// its hierarchy file (dag.bin) is refused with dataset_damaged naming the file, and the server
// goes on serving.
TEST_F(DamagedDatasetTest, ADamagedBinaryHierarchyFileIsRefusedAndASoundOneServes) {
  ASSERT_EQ(tetrascope("preprocess " + testing::sample_mesh().string() + " -o " + (data_dir() / "binary").string() +
                       " --model binary --segment-tets 2000 --base-tets 3000 --vertices off --progress none"),
            0);
  fs::copy(data_dir() / "binary", data_dir() / "flipped", fs::copy_options::recursive);
  std::vector<char> bytes = read_bytes(data_dir() / "flipped" / "dag.bin");
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
  write_bytes(data_dir() / "flipped" / "dag.bin", bytes);
  EXPECT_NE(tetrascope("verify " + (data_dir() / "flipped").string() + " --progress none"), 0) << "verify passes a damaged dag.bin";
  start();
  auto c = session();
  c->send("dataset.open", {{"name", "flipped"}});
  const auto refused = next_text(*c, "error");
  EXPECT_EQ(refused["code"], "dataset_damaged") << refused.dump();
  EXPECT_NE(refused["message"].get<std::string>().find("dag.bin"), std::string::npos) << refused.dump();
  expect_still_serving("binary");
}

// A store whose vertices.bin (the vertex hierarchy the cut refines by) was cut short, and one
// with a flipped byte in it: dataset.open answers dataset_damaged naming the file, and the
// server goes on serving the sample, whose frames come from its own vertex front.
TEST_F(DamagedDatasetTest, ADamagedVerticesFileNeverCrashesTheServer) {
  add_sample("cut-short");
  add_sample("flipped");
  add_sample("good");
  ASSERT_TRUE(fs::exists(data_dir() / "good" / "vertices.bin"));
  std::vector<char> bytes = read_bytes(data_dir() / "cut-short" / "vertices.bin");
  bytes.resize(bytes.size() / 3);
  write_bytes(data_dir() / "cut-short" / "vertices.bin", bytes);
  bytes = read_bytes(data_dir() / "flipped" / "vertices.bin");
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x04);
  write_bytes(data_dir() / "flipped" / "vertices.bin", bytes);
  start();
  for (const std::string name : {"cut-short", "flipped"}) {
    auto c = session();
    c->send("dataset.open", {{"name", name}});
    const auto refused = next_text(*c, "error");
    EXPECT_EQ(refused["code"], "dataset_damaged") << name << ": " << refused.dump();
    EXPECT_NE(refused["message"].get<std::string>().find("vertices.bin"), std::string::npos) << refused.dump();
  }
  expect_still_serving("good");
}

// A store whose boundary_tags.bin (the input's boundary face tags) has a flipped byte, and one
// whose file was cut short: dataset.open and the REST description answer dataset_damaged
// naming the file, and the server goes on serving the sample.
TEST_F(DamagedDatasetTest, ADamagedBoundaryTagsFileNeverCrashesTheServer) {
  testing::TaggedCube cube = testing::tagged_cube();
  const fs::path mesh = scratch_dir("damaged-tags-mesh") / "cube.msh";
  testing::write_gmsh(mesh, cube.mesh, cube.gmsh);
  for (const std::string name : {"flipped", "cut-short"}) {
    ASSERT_EQ(tetrascope("preprocess " + mesh.string() + " -o " + (data_dir() / name).string() + " --progress none"), 0);
    ASSERT_TRUE(fs::exists(data_dir() / name / "boundary_tags.bin"));
  }
  add_sample("good");
  std::vector<char> bytes = read_bytes(data_dir() / "flipped" / "boundary_tags.bin");
  bytes[bytes.size() - 5] = static_cast<char>(bytes[bytes.size() - 5] ^ 0x10);
  write_bytes(data_dir() / "flipped" / "boundary_tags.bin", bytes);
  bytes.resize(bytes.size() / 2);
  write_bytes(data_dir() / "cut-short" / "boundary_tags.bin", bytes);
  start();
  for (const std::string name : {"flipped", "cut-short"}) {
    auto c = session();
    c->send("dataset.open", {{"name", name}});
    const auto refused = next_text(*c, "error");
    EXPECT_EQ(refused["code"], "dataset_damaged") << name << ": " << refused.dump();
    EXPECT_NE(refused["message"].get<std::string>().find("boundary_tags.bin"), std::string::npos) << refused.dump();
    const HttpResult described = http_request(base_ + "/api/v1/datasets/" + name, "GET");
    EXPECT_NE(described.status, 200) << described.body;
    EXPECT_NE(described.body.find("boundary_tags.bin"), std::string::npos) << described.body;
  }
  expect_still_serving("good");
}

// A frame maker whose pipeline could not be made never draws with the pipeline missing: the
// same damaged store opened by two sessions one after the other, with frames asked of both.
TEST_F(DamagedDatasetTest, ADatasetThatFailsToOpenTwiceNeverReachesTheRenderer) {
  add_sample_with_variants("d");
  add_sample("good");
  std::vector<char> bytes = read_bytes(data_dir() / "d" / "variants.bin");
  bytes.resize(bytes.size() - 100);
  write_bytes(data_dir() / "d" / "variants.bin", bytes);
  start();
  for (int round = 0; round < 2; ++round) {
    auto c = session();
    c->send("dataset.open", {{"name", "d"}});
    EXPECT_EQ(next_text(*c, "error")["code"], "dataset_damaged") << "round " << round;
    c->send("camera.set", {{"eye", {0, 0, 30}}, {"target", {0, 0, 0}}, {"up", {0, 1, 0}}, {"fov", 30}});
    c->send("lod.set", {{"budget", 100000}});
  }
  expect_still_serving("good");
}

// A flipped bit inside a finest-level segment (its CRC no longer matches) passes the open,
// which checks the coarsest level; the first frame that maps it closes the dataset for every
// session viewing it, each told dataset_damaged, and the server goes on.
TEST_F(DamagedDatasetTest, ASegmentFailingItsChecksumClosesTheDatasetForEverySession) {
  add_sample("d");
  add_sample("good");
  fs::remove(data_dir() / "d" / "vertices.bin");  // cut through the segments (a vertex front reads none)
  {
    const auto store = storage::Store::open(data_dir() / "d");
    const auto& r = store->record(0);  // a finest-level segment: not in the coarsest cut
    std::vector<char> bytes = read_bytes(data_dir() / "d" / "segments.bin");
    bytes.at(r.offset + r.bytes / 2) ^= 0x10;
    write_bytes(data_dir() / "d" / "segments.bin", bytes);
  }
  start();
  auto a = session();
  auto b = session();
  for (auto* c : {a.get(), b.get()}) {
    c->send("dataset.open", {{"name", "d"}});
    next_text(*c, "dataset.info");
  }
  a->send("lod.set", {{"budget", 10000000}});  // the whole dataset: every segment is mapped
  for (auto* c : {a.get(), b.get()}) {
    const auto told = next_text(*c, "error");
    EXPECT_EQ(told["code"], "dataset_damaged") << told.dump();
    EXPECT_NE(told["message"].get<std::string>().find("checksum"), std::string::npos) << told.dump();
    EXPECT_EQ(told["message"].get<std::string>().find(data_dir().string()), std::string::npos) << "a server path: " << told.dump();
  }
  // opened again: refused until the store is written anew
  a->send("dataset.open", {{"name", "d"}});
  EXPECT_EQ(next_text(*a, "error")["code"], "dataset_damaged");
  expect_still_serving("good");
}

// Errors a session sees name no path on the server (the data folder's absolute path appeared in
// "cannot open 'd': …/d/segments.bin: segment 8: checksum mismatch").
TEST_F(DamagedDatasetTest, ASessionErrorAboutADamagedStoreShowsNoServerPath) {
  add_sample("d");
  {
    const auto store = storage::Store::open(data_dir() / "d");
    const uint32_t last = store->segment_count() - 1;  // the coarsest level: read when opened
    const auto& r = store->record(last);
    std::vector<char> bytes = read_bytes(data_dir() / "d" / "segments.bin");
    bytes.at(r.offset + r.bytes / 2) ^= 0x10;
    write_bytes(data_dir() / "d" / "segments.bin", bytes);
  }
  start();
  auto c = session();
  c->send("dataset.open", {{"name", "d"}});
  const auto told = next_text(*c, "error");
  EXPECT_EQ(told["code"], "dataset_damaged") << told.dump();
  const std::string message = told["message"];
  EXPECT_EQ(message.find(fs::canonical(data_dir()).string()), std::string::npos) << message;
  EXPECT_NE(message.find("segments.bin"), std::string::npos) << message;
}

// Meshes whose bounds collapse to a point (one tet of four equal vertices; a 1 mm grid at 1e7,
// which float32 flattens) preprocess, and opening them neither aborts the server ("eye and
// target coincide") nor any session: a frame comes.
TEST_F(DamagedDatasetTest, ADatasetWhoseBoundsCollapseToAPointOpensAndDraws) {
  const fs::path point = data_dir() / "point.off";
  std::ofstream(point) << "OFF\n4 1 0\n1 1 1\n1 1 1\n1 1 1\n1 1 1\n4 0 1 2 3\n";
  const fs::path far = data_dir() / "far.vtk";
  {
    std::ofstream out(far);
    out << "# vtk DataFile Version 3.0\nfar\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 double\n";
    for (int k = 0; k < 8; ++k) out << 1e7 + 1e-3 * (k & 1) << ' ' << 1e7 + 1e-3 * ((k >> 1) & 1) << ' ' << 1e7 + 1e-3 * ((k >> 2) & 1) << '\n';
    out << "CELLS 5 25\n4 0 1 3 7\n4 0 3 2 7\n4 0 2 6 7\n4 0 6 4 7\n4 0 4 5 7\nCELL_TYPES 5\n10\n10\n10\n10\n10\n";
    out << "POINT_DATA 8\nSCALARS f float 1\nLOOKUP_TABLE default\n0\n1\n2\n3\n4\n5\n6\n7\n";
  }
  add_sample("good");
  for (const auto& [file, name] : {std::pair{point, std::string("point")}, std::pair{far, std::string("far")}}) {
    const int status = tetrascope("preprocess " + file.string() + " -o " + (data_dir() / name).string() + " --progress none");
    EXPECT_LT(status, 128) << name << ": preprocess died of a signal";
  }
  start();
  for (const std::string name : {"point", "far"}) {
    if (!fs::exists(data_dir() / name / "manifest.json")) continue;  // refused with a message: fine too
    auto c = session();
    c->send("dataset.open", {{"name", name}});
    auto m = c->read(60s);
    while (m && m->binary) m = c->read(60s);
    ASSERT_TRUE(m) << name;
    const auto reply = nlohmann::json::parse(m->data);
    if (reply["type"] == "dataset.info") {
      c->send("camera.set", {{"eye", {1, 1, 30}}, {"target", {1, 1, 1}}, {"up", {0, 1, 0}}, {"fov", 30}});
      EXPECT_TRUE(frame_arrives(*c)) << name;
    } else {
      EXPECT_EQ(reply["type"], "error") << reply.dump();
    }
  }
  expect_still_serving("good");
}

// A folder in the data folder that is a symlink to a store elsewhere on the server is neither
// listed, nor answered by GET, nor opened by a session (DELETE refused it already).
TEST_F(DamagedDatasetTest, ASymlinkInTheDataFolderLeadingOutsideIsNotServed) {
  const fs::path outside = scratch_dir("damaged-outside") / "elsewhere";
  fs::copy(testing::sample_store(), outside, fs::copy_options::recursive);
  fs::create_directory_symlink(outside, data_dir() / "link");
  add_sample("good");
  start();
  const auto list = testing::get_json(base_, "/api/v1/datasets");
  for (const auto& d : list["datasets"]) EXPECT_NE(d["name"], "link") << list.dump();
  EXPECT_EQ(http_request(base_ + "/api/v1/datasets/link", "GET").status, 404);
  auto c = session();
  c->send("dataset.open", {{"name", "link"}});
  EXPECT_EQ(next_text(*c, "error")["code"], "not_found");
  expect_still_serving("good");
}

// A name starting with '-' would read as an option of the tetrascope command a job runs: refused
// for uploads and jobs alike.
TEST_F(DamagedDatasetTest, ANameStartingWithADashIsRefused) {
  start();
  const HttpResult upload = http_request(base_ + "/api/v1/uploads?name=-o", "POST", "OFF\n", "", "application/octet-stream");
  EXPECT_EQ(upload.status, 400) << upload.body;
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "-o"));
  const std::string source = testing::upload(base_, testing::sample_mesh(), "disk.vtk");
  const HttpResult job = http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "-force"}}).dump());
  EXPECT_EQ(job.status, 400) << job.body;
}

// An upload that a queued or running job reads is not replaced under it (the job would build the
// new bytes and record their hash): 409, as DELETE already answered, and the bytes stay.
TEST_F(DamagedDatasetTest, ReplacingAnUploadAQueuedJobReadsIsRefused) {
  ServerOptions o = testing::test_server_options(data_dir());
  o.max_running_jobs = 1;
  start(o);
  const std::string first = testing::upload(base_, testing::sample_mesh(), "first.vtk");
  const std::string second = testing::upload(base_, testing::sample_mesh(), "second.vtk");
  const std::vector<char> before = read_bytes(data_dir() / "uploads" / "second.vtk");
  auto submit = [&](const std::string& source, const std::string& name) {
    const HttpResult r = http_request(base_ + "/api/v1/jobs", "POST",
                                      nlohmann::json({{"source", source}, {"name", name}, {"options", {{"variants", 3}}}}).dump());
    EXPECT_EQ(r.status, 202) << r.body;
    return nlohmann::json::parse(r.body).value("id", "");
  };
  const std::string running = submit(first, "a");
  const std::string queued = submit("./" + second, "b");  // another spelling of the same file
  const HttpResult replaced = http_request(base_ + "/api/v1/uploads?name=second.vtk", "POST", "OFF\n4 1 0\n", "", "application/octet-stream");
  const auto state = testing::get_json(base_, "/api/v1/jobs/" + queued)["state"];
  if (state == "queued" || state == "running") {  // (the job did not end between the calls)
    EXPECT_EQ(replaced.status, 409) << replaced.body;
    EXPECT_NE(replaced.body.find(queued), std::string::npos) << replaced.body;
    EXPECT_EQ(read_bytes(data_dir() / "uploads" / "second.vtk"), before) << "the queued job's input changed";
  }
  for (const std::string& id : {queued, running}) http_request(base_ + "/api/v1/jobs/" + id, "DELETE");
  for (const std::string& id : {queued, running})
    testing::wait_job(base_, id, [](const nlohmann::json& j) { return j["state"] != "queued" && j["state"] != "running"; });
  // once the jobs ended, the name may be uploaded again
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads?name=second.vtk", "POST", "OFF\n4 1 0\n", "", "application/octet-stream").status, 201);
}

// The limit of bad messages in a row closes the session on the message that reaches it (the
// 16th by default, as documented), not the one after.
TEST_F(DamagedDatasetTest, TheSessionClosesOnTheBadMessageThatReachesTheLimit) {
  ServerOptions o = testing::test_server_options(data_dir());
  o.limits.max_bad_messages = 5;
  start(o);
  SessionClient c(ws_);
  for (int i = 0; i < 4; ++i) c.send_text("garbage");
  for (int i = 0; i < 4; ++i) EXPECT_EQ(next_text(c, "error", 10s)["code"], "bad_json");
  EXPECT_FALSE(c.closed());
  c.send_text("garbage");
  bool closed = false;
  try {
    for (int i = 0; i < 5; ++i) c.read(2s);
  } catch (const std::runtime_error&) {
    closed = true;
  }
  EXPECT_TRUE(closed);
  EXPECT_EQ(c.close_code(), 1008);
}

// ---- slow clients -------------------------------------------------------------------------------

// A TCP connection from a chosen loopback address (127.0.0.X) that sends a partial header.
class SlowClient {
 public:
  SlowClient(uint16_t port, uint32_t from_host) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in local{};
    local.sin_family = AF_INET;
    local.sin_addr.s_addr = htonl(from_host);
    ::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
      ::close(fd_);
      fd_ = -1;
      return;
    }
    constexpr std::string_view kPartial = "GET /api/v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ";
    ::send(fd_, kPartial.data(), kPartial.size(), MSG_NOSIGNAL);
  }
  ~SlowClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  SlowClient(SlowClient&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}

 private:
  int fd_ = -1;
};

// With --token, clients that hold connections open with partial headers (the slowloris attack)
// no longer keep authorised calls out: one address gets at most max_connections_per_ip, and at
// the cap the connection that has waited longest on its header is closed for a new one.
TEST_F(DamagedDatasetTest, SlowPartialHeadersFromManyClientsNeverLockOutAnAuthorisedCall) {
  ServerOptions o = testing::test_server_options(data_dir());
  o.token = "secret";
  o.max_connections = 24;
  o.max_connections_per_ip = 8;
  start(o);
  std::vector<SlowClient> slow;
  // one address: only 8 of its 20 are taken
  for (int i = 0; i < 20; ++i) slow.emplace_back(server_->port(), INADDR_LOOPBACK + 1);  // 127.0.0.2
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET", "", "secret").status, 200) << "one address held every slot";
  // four more addresses fill the global cap
  for (uint32_t host = 3; host <= 6; ++host)
    for (int i = 0; i < 8; ++i) slow.emplace_back(server_->port(), INADDR_LOOPBACK - 1 + host);
  std::this_thread::sleep_for(1500ms);  // they have waited past the eviction age
  const auto before = std::chrono::steady_clock::now();
  for (int i = 0; i < 5; ++i) EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET", "", "secret").status, 200) << "call " << i << " locked out";
  EXPECT_LT(std::chrono::steady_clock::now() - before, 10s) << "the calls waited for header timeouts";
  const HttpResult metrics = http_request(base_ + "/metrics", "GET", "", "secret");
  EXPECT_NE(metrics.body.find("tetrascope_connections_evicted_total"), std::string::npos);
}

// A server stopped while connections wait on their headers (idle keep-alive, slow clients)
// ends cleanly: their handlers, destroyed with the server, find what they count down still
// there (under ASan a use after free).
TEST_F(DamagedDatasetTest, StoppingTheServerWithConnectionsWaitingOnAHeaderIsClean) {
  start();
  std::vector<SlowClient> waiting;
  for (uint32_t host = 2; host <= 4; ++host) waiting.emplace_back(server_->port(), INADDR_LOOPBACK - 1 + host);
  EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET").status, 200);
  std::this_thread::sleep_for(200ms);
  server_.reset();
  start();  // and the data folder serves again
  EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET").status, 200);
}

}  // namespace
}  // namespace tetrascope::server
