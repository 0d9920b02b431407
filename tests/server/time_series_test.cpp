// Time series through the server: a series store (made by the real `tetrascope preprocess` of
// VTU step files) lists its steps in dataset.info and the REST description, time.set shows a
// step (a play's step, with the next to prefetch, as an interaction frame; a step alone refined
// to a still that differs from step 0's), and a step
// past the last, a time.set on a dataset of one step or a damaged step block get clear errors
// while the server goes on serving. The real server on an ephemeral loopback port, real
// WebSocket and HTTP clients.
#include <chrono>
#include <cmath>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "cli_run.h"
#include "fixture_writers.h"
#include "rest_helpers.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/server/client.h"
#include "tetrascope/server/server.h"
#include "test_paths.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// An 8^3 grid of cubes, 5 tets each, whose "heat" is a bump at x = 0.15 + 0.35 s.
testing::CellMesh heat_step(int s) {
  storage::TetMesh m;
  const int k = 8;
  auto at = [&](int i, int j, int l) { return static_cast<uint32_t>((l * (k + 1) + j) * (k + 1) + i); };
  for (int l = 0; l <= k; ++l)
    for (int j = 0; j <= k; ++j)
      for (int i = 0; i <= k; ++i) {
        m.x.push_back(float(i) / k);
        m.y.push_back(float(j) / k);
        m.z.push_back(float(l) / k);
      }
  const uint32_t five[2][5][4] = {{{0, 1, 2, 5}, {0, 2, 3, 7}, {0, 4, 5, 7}, {2, 5, 6, 7}, {0, 2, 5, 7}}, {{0, 1, 3, 4}, {1, 2, 3, 6}, {1, 4, 5, 6}, {3, 4, 6, 7}, {1, 3, 4, 6}}};
  for (int l = 0; l < k; ++l)
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < k; ++i) {
        const uint32_t c[8] = {at(i, j, l), at(i + 1, j, l), at(i + 1, j + 1, l), at(i, j + 1, l), at(i, j, l + 1), at(i + 1, j, l + 1), at(i + 1, j + 1, l + 1), at(i, j + 1, l + 1)};
        for (const auto& t : five[(i + j + l) % 2]) m.tets.insert(m.tets.end(), {c[t[0]], c[t[1]], c[t[2]], c[t[3]]});
      }
  storage::Attribute heat{{"heat", 1}, {}};
  for (size_t v = 0; v < m.x.size(); ++v) heat.values.push_back(static_cast<float>(std::exp(-20 * std::pow(m.x[v] - 0.15 - 0.35 * s, 2))));
  m.attributes = {heat};
  return testing::from_tets(m);
}

class TimeSeriesServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = testing::scratch_dir(std::string("time-server-") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    const fs::path inputs = testing::scratch_dir(std::string("time-server-inputs-") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::string files;
    for (int s = 0; s < 3; ++s) {
      testing::write_vtu(inputs / ("heat_" + std::to_string(s) + ".vtu"), heat_step(s));
      files += " " + (inputs / ("heat_" + std::to_string(s) + ".vtu")).string();
    }
    const auto r = testing::run_cli("preprocess" + files + " -o " + (data_ / "heat").string() + " --segment-tets 1024 --base-tets 800 --progress none", 300);
    ASSERT_EQ(r.status, 0) << r.out;
    fs::copy(testing::sample_store(), data_ / "disk", fs::copy_options::recursive);
  }
  void start() {
    server_ = std::make_unique<Server>(testing::test_server_options(data_));
    base_ = "http://127.0.0.1:" + std::to_string(server_->port());
    ws_ = "ws://127.0.0.1:" + std::to_string(server_->port()) + "/api/v1/session";
  }
  std::unique_ptr<SessionClient> session(const std::string& dataset, nlohmann::json* info = nullptr) {
    auto c = std::make_unique<SessionClient>(ws_);
    c->send("hello", {{"version", 1}});
    c->expect("hello.ok");
    c->send("view.resize", {{"width", 160}, {"height", 120}});
    c->send("dataset.open", {{"name", dataset}});
    const auto opened = c->expect("dataset.info", 60s);
    if (info) *info = opened;
    return c;
  }
  struct Frame {
    protocol::FrameHeader header;
    std::string image;
  };
  // The next frame answering message `id` or later, a still when `still` (errors fail the test).
  static Frame frame_after(SessionClient& c, uint32_t id, bool still = false) {
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (std::chrono::steady_clock::now() < deadline) {
      auto m = c.read(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
      if (!m) break;
      if (!m->binary) {
        EXPECT_NE(nlohmann::json::parse(m->data)["type"], "error") << m->data;
        continue;
      }
      Frame f{protocol::decode_frame_header(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(m->data.data()), m->data.size()), protocol::Limits{}),
              m->data.substr(protocol::kFrameHeaderBytes)};
      if ((f.header.still || !still) && f.header.message_id >= id) return f;
    }
    ADD_FAILURE() << "no frame for message " << id;
    return {};
  }
  static Frame still_after(SessionClient& c, uint32_t id) { return frame_after(c, id, true); }

  fs::path data_;
  std::unique_ptr<Server> server_;
  std::string base_, ws_;
};

TEST_F(TimeSeriesServerTest, DatasetInfoAndTheRestDescriptionListTheStepsAndTimeSetShowsAStep) {
  start();
  nlohmann::json info;
  auto c = session("heat", &info);
  ASSERT_EQ(info["time_steps"].size(), 3u) << info.dump();
  EXPECT_EQ(info["time_steps"][2]["name"], "heat_2.vtu");
  EXPECT_DOUBLE_EQ(info["time_steps"][1]["time"].get<double>(), 1.0);
  ASSERT_TRUE(info["attributes"][0].contains("series_range"));
  EXPECT_NEAR(info["attributes"][0]["series_range"][1].get<double>(), 1.0, 0.05);
  const auto rest = testing::get_json(base_, "/api/v1/datasets/heat");
  EXPECT_EQ(rest["time_steps"].size(), 3u) << rest.dump();
  const auto list = testing::get_json(base_, "/api/v1/datasets");
  bool listed = false;
  for (const auto& d : list["datasets"]) listed = listed || (d["name"] == "heat" && d["time_steps"].size() == 3);
  EXPECT_TRUE(listed) << list.dump();

  const Frame first = still_after(*c, 0);
  // a play's step (with the next to prefetch): an interaction frame, not refined
  const uint32_t playing = c->send("time.set", {{"step", 1}, {"prefetch", 2}});
  const Frame played = frame_after(*c, playing);
  EXPECT_FALSE(played.header.still || played.header.refining) << "a play's step is not refined";
  const uint32_t id = c->send("time.set", {{"step", 2}});  // a step alone: refined to a still
  const Frame later = still_after(*c, id);
  EXPECT_GT(later.header.tets, 0u);
  EXPECT_NE(first.image, later.image) << "step 2's bump is elsewhere: its still should differ from step 0's";
  const uint32_t back = c->send("time.set", {{"step", 0}});
  EXPECT_EQ(still_after(*c, back).image, first.image) << "step 0 again draws step 0's still";
}

TEST_F(TimeSeriesServerTest, AStepPastTheLastOrOnADatasetOfOneStepIsRefused) {
  start();
  auto c = session("heat");
  c->send("time.set", {{"step", 3}});
  auto refused = testing::next_text(*c, "error");
  EXPECT_EQ(refused["code"], "bad_field") << refused.dump();
  EXPECT_NE(refused["message"].get<std::string>().find("no time step 3 in heat (it has 3)"), std::string::npos) << refused.dump();
  c->send("time.set", {{"step", 1}, {"prefetch", 7}});
  refused = testing::next_text(*c, "error");
  EXPECT_NE(refused["message"].get<std::string>().find("prefetch: no time step 7"), std::string::npos) << refused.dump();
  c->send("time.set", nlohmann::json::object());
  EXPECT_EQ(testing::next_text(*c, "error")["code"], "bad_field");
  c->send("time.set", {{"step", -1}});
  EXPECT_EQ(testing::next_text(*c, "error")["code"], "bad_field");
  auto one = session("disk");
  one->send("time.set", {{"step", 1}});
  refused = testing::next_text(*one, "error");
  EXPECT_NE(refused["message"].get<std::string>().find("no time step 1 in disk (it has 1)"), std::string::npos) << refused.dump();
  const uint32_t id = c->send("time.set", {{"step", 1}});  // the session lives on
  EXPECT_TRUE(still_after(*c, id).header.still);
}

TEST_F(TimeSeriesServerTest, ADamagedStepBlockClosesTheDatasetAndTheServerGoesOnServing) {
  const fs::path steps = data_ / "heat" / "steps.bin";
  std::string bytes;
  {
    std::ifstream in(steps, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 200u);
  bytes[bytes.size() - 20] = static_cast<char>(bytes[bytes.size() - 20] ^ 0x21);  // inside step 2's block
  std::ofstream(steps, std::ios::binary | std::ios::trunc) << bytes;
  start();
  auto c = session("heat");  // the header and index are sound: it opens
  const uint32_t ok = c->send("time.set", {{"step", 1}});
  EXPECT_TRUE(still_after(*c, ok).header.still) << "step 1's block is sound";
  c->send("time.set", {{"step", 2}});
  const auto told = testing::next_text(*c, "error");
  EXPECT_EQ(told["code"], "dataset_damaged") << told.dump();
  EXPECT_NE(told["message"].get<std::string>().find("steps.bin: step 2: block checksum mismatch"), std::string::npos) << told.dump();
  EXPECT_EQ(told["message"].get<std::string>().find(data_.string()), std::string::npos) << "a server path: " << told.dump();
  auto d = session("disk");  // still serving
  EXPECT_TRUE(still_after(*d, 0).header.still);
}

}  // namespace
}  // namespace tetrascope::server
