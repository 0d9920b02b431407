// The real server on an ephemeral loopback port, driven by a real WebSocket client (Beast)
// and HTTP requests: frames, latest-wins, stills, hostile messages, boundary regions, limits, auth, path
// traversal, uploads and the job lifecycle, a restart, and a 4-client load test.
#include <signal.h>
#include <turbojpeg.h>

#include <chrono>
#include <fstream>
#include <map>
#include <thread>

#include <gtest/gtest.h>

#include "rest_helpers.h"
#include "tetrascope/server/client.h"
#include "tetrascope/server/loadtest.h"
#include "tetrascope/server/server.h"
#include "tetrascope/storage/mesh_stream.h"
#include "cli_run.h"
#include "fixture_writers.h"
#include "mesh_checks.h"
#include "test_paths.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using tetrascope::testing::scratch_dir;
using tetrascope::testing::shared_data;
using tetrascope::testing::source_dir;
using tetrascope::testing::tetrascope_binary;

ServerOptions options_for(const fs::path& data) {
  ServerOptions o = tetrascope::testing::test_server_options(data);
  o.cache_bytes = 256ull << 20;
  o.still_budget = 100000;
  o.interaction_budget = 5000;
  o.max_fps = 60;
  return o;
}

class ServerTest : public ::testing::Test {
 protected:
  void start(ServerOptions o) {
    server_ = std::make_unique<Server>(o);
    base_ = "http://127.0.0.1:" + std::to_string(server_->port());
    ws_ = "ws://127.0.0.1:" + std::to_string(server_->port()) + "/api/v1/session";
  }
  void start() { start(options_for(data_dir())); }
  fs::path data_dir() {
    if (data_.empty()) {
      data_ = scratch_dir(::testing::UnitTest::GetInstance()->current_test_info()->name());
      fs::copy(testing::sample_store(), data_ / "disk", fs::copy_options::recursive);
    }
    return data_;
  }
  // hello, view.resize, dataset.open; returns dataset.info
  nlohmann::json open(SessionClient& c, uint32_t width = 320, uint32_t height = 240) {
    c.send("hello", {{"version", 1}});
    c.expect("hello.ok");
    c.send("view.resize", {{"width", width}, {"height", height}});
    c.send("dataset.open", {{"name", "disk"}});
    return c.expect("dataset.info", 60s);
  }
  struct Frame {
    protocol::FrameHeader header;
    std::string jpeg;
  };
  static Frame next_frame(SessionClient& c, std::chrono::milliseconds timeout = 60s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      auto m = c.read(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
      if (!m) break;
      if (!m->binary) {
        auto j = nlohmann::json::parse(m->data);
        EXPECT_NE(j["type"], "error") << m->data;
        continue;
      }
      Frame f;
      f.header = protocol::decode_frame_header(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(m->data.data()), m->data.size()), protocol::Limits{});
      f.jpeg = m->data.substr(protocol::kFrameHeaderBytes);
      return f;
    }
    ADD_FAILURE() << "no frame within the timeout";
    return {};
  }
  static Frame next_still(SessionClient& c) {
    for (;;) {
      Frame f = next_frame(c);
      if (f.header.still || f.header.width == 0) return f;
    }
  }
  static nlohmann::json camera(double azimuth, bool interacting = true) {
    return {{"eye", {30 * std::cos(azimuth), 30 * std::sin(azimuth), 5.0}}, {"target", {0, 0, 0}}, {"up", {0, 0, 1}}, {"fov", 30}, {"interacting", interacting}};
  }
  nlohmann::json get_json(const std::string& path, const std::string& token = "") { return testing::get_json(base_, path, token); }
  nlohmann::json wait_job(const std::string& id, const std::function<bool(const nlohmann::json&)>& until, std::chrono::seconds timeout = 300s) {
    return testing::wait_job(base_, id, until, timeout);
  }
  std::string upload(const fs::path& file, const std::string& name) { return testing::upload(base_, file, name); }

  fs::path data_;
  std::unique_ptr<Server> server_;
  std::string base_, ws_;
};

TEST_F(ServerTest, FramesArriveAndDecode) {
  start();
  SessionClient c(ws_);
  const auto info = open(c);
  EXPECT_EQ(info["name"], "disk");
  EXPECT_EQ(info["tets"], 44832);
  ASSERT_FALSE(info["attributes"].empty());
  EXPECT_EQ(info["attributes"][0]["histogram"].size(), 64u);
  const Frame f = next_still(c);
  EXPECT_TRUE(f.header.still);
  EXPECT_EQ(f.header.width, 320u);
  EXPECT_EQ(f.header.height, 240u);
  EXPECT_EQ(f.header.tets, 44832u);  // the whole mesh fits the still budget
  // the payload is a JPEG of that size
  tjhandle tj = tjInitDecompress();
  int w = 0, h = 0, sub = 0, space = 0;
  ASSERT_EQ(tjDecompressHeader3(tj, reinterpret_cast<const unsigned char*>(f.jpeg.data()), f.jpeg.size(), &w, &h, &sub, &space), 0);
  std::vector<unsigned char> rgb(size_t(w) * h * 3);
  ASSERT_EQ(tjDecompress2(tj, reinterpret_cast<const unsigned char*>(f.jpeg.data()), f.jpeg.size(), rgb.data(), w, 0, h, TJPF_RGB, 0), 0);
  tjDestroy(tj);
  EXPECT_EQ(w, 320);
  EXPECT_EQ(h, 240);
  // not a blank image: the volume covers part of the view with colours unlike the background
  size_t lit = 0;
  for (size_t i = 0; i < rgb.size(); i += 3)
    if (std::abs(int(rgb[i + 1]) - 26) > 30) ++lit;
  EXPECT_GT(lit, rgb.size() / 3 / 10);
}

// Threat: the server stopped (SIGTERM, a replica taken down) while its sessions render. A
// render worker's task submits the session's next paced frame to the pool; the pool used to
// be let go of before its workers were joined, so that submit met a null pool and the
// process died (seen in the replicas test's killed replica). Several rounds: the window is
// narrow.
TEST_F(ServerTest, StoppingWhileSessionsRenderDoesNotCrash) {
  for (int round = 0; round < 6; ++round) {
    ServerOptions o = options_for(data_dir());
    o.render_workers = 2;
    start(o);
    std::vector<std::unique_ptr<SessionClient>> clients;
    for (int k = 0; k < 3; ++k) {
      clients.push_back(std::make_unique<SessionClient>(ws_));
      open(*clients.back());
    }
    next_frame(*clients.front());
    for (int i = 0; i < 40; ++i)
      for (auto& c : clients) c->send("camera.set", camera(0.05 * i + round));
    std::this_thread::sleep_for(std::chrono::milliseconds(20 * round));
    const auto started = std::chrono::steady_clock::now();
    server_.reset();  // stops, joins the io threads and the render workers
    EXPECT_LT(std::chrono::steady_clock::now() - started, 30s) << "round " << round;
  }
}

TEST_F(ServerTest, LatestWinsUnderABurstAndAStillFollows) {
  start();
  SessionClient c(ws_);
  open(c);
  next_still(c);
  uint32_t last = 0;
  for (int i = 0; i < 60; ++i) last = c.send("camera.set", camera(0.02 * i));
  std::vector<Frame> frames;
  for (;;) {
    Frame f = next_frame(c);
    ASSERT_GT(f.header.width, 0u);
    frames.push_back(f);
    if (f.header.still) break;
  }
  // the burst rendered far fewer times than it had messages, and the still shows the last one
  size_t interaction = 0;
  for (const auto& f : frames) interaction += !f.header.still && !f.header.refining;
  EXPECT_LT(interaction, 20u);
  EXPECT_EQ(frames.back().header.message_id, last);
  EXPECT_EQ(frames.back().header.width, 320u);
  // interaction frames are smaller (interaction_scale) and cheaper (interaction budget)
  if (interaction > 0) {
    EXPECT_EQ(frames.front().header.width, static_cast<uint32_t>(std::lround(320 * ServerOptions{}.interaction_scale)));
    EXPECT_LT(frames.front().header.tets, frames.back().header.tets);
  }
  // frame numbers increase
  for (size_t i = 1; i < frames.size(); ++i) EXPECT_GT(frames[i].header.frame_number, frames[i - 1].header.frame_number);
}

TEST_F(ServerTest, ACameraJumpRendersAStillAtOnce) {
  start();
  SessionClient c(ws_);
  open(c);
  next_still(c);
  const uint32_t id = c.send("camera.set", camera(1.0, false));
  // refinement starts at once (no still_delay): the first step, or the still itself
  const Frame f = next_frame(c);
  EXPECT_TRUE(f.header.still || f.header.refining);
  EXPECT_EQ(f.header.message_id, id);
  const Frame still = f.header.still ? f : next_still(c);
  EXPECT_EQ(still.header.message_id, id);
}

std::string error_code_of(SessionClient& c, uint32_t* id = nullptr) {
  const auto j = c.expect("error");
  if (id) *id = j["id"].is_null() ? 0 : j["id"].get<uint32_t>();
  EXPECT_FALSE(j["message"].get<std::string>().empty());
  return j["code"];
}

TEST_F(ServerTest, BadOversizedAndOutOfOrderMessagesGetErrorsAndTheSessionLivesOn) {
  start();
  SessionClient c(ws_);
  c.send_text(R"({"type":"ping","id":1})");
  EXPECT_EQ(error_code_of(c), "hello_first");
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send_text("{not json");
  EXPECT_EQ(error_code_of(c), "bad_json");
  c.send_text(R"({"type":"ping","id":2,"pad":")" + std::string(70000, 'x') + "\"}");
  EXPECT_EQ(error_code_of(c), "too_large");
  c.send_binary("\x01\x02\x03");
  EXPECT_EQ(error_code_of(c), "binary_message");
  uint32_t id = 0;
  c.send_text(R"({"type":"camera.explode","id":7})");
  EXPECT_EQ(error_code_of(c, &id), "unknown_type");
  EXPECT_EQ(id, 7u);
  c.send("camera.set", camera(0));  // before dataset.open
  EXPECT_EQ(error_code_of(c), "no_dataset");
  c.send("dataset.open", {{"name", "nonexistent"}});
  EXPECT_EQ(error_code_of(c), "not_found");
  c.send("dataset.open", {{"name", "../disk"}});
  EXPECT_EQ(error_code_of(c), "not_found");
  c.send("view.resize", {{"width", 4097}, {"height", 100}});
  EXPECT_EQ(error_code_of(c), "bad_field");
  open(c);
  c.send("tf.set", {{"attribute", "no_such_field"}});
  EXPECT_EQ(error_code_of(c), "not_found");
  c.send("tf.set", {{"colormap", "rainbow-unicorn"}});
  EXPECT_EQ(error_code_of(c), "bad_field");
  // still alive: pings answer and frames come
  const uint32_t ping = c.send("ping");
  EXPECT_EQ(c.expect("pong")["id"], ping);
  EXPECT_TRUE(next_still(c).header.still);
  EXPECT_FALSE(c.closed());
}

TEST_F(ServerTest, StreamLinesOnAScalarOrMissingFieldAreRefusedAndLinesChangeTheFrame) {
  start();
  SessionClient c(ws_);
  open(c);
  const Frame plain = next_still(c);
  c.send("lines.set", {{"field", "Temp"}});
  EXPECT_EQ(error_code_of(c), "bad_field") << "a scalar field";
  c.send("lines.set", {{"field", "Nope"}});
  EXPECT_EQ(error_code_of(c), "not_found") << "a field the dataset lacks";
  c.send("lines.set", {{"seeds", "dense"}, {"count", 65}});
  EXPECT_EQ(error_code_of(c), "bad_field") << "dense seeding past its limit";
  // the still that answers message `id` (stills of earlier messages may come first)
  auto still_for = [&](uint32_t id) {
    for (;;) {
      Frame f = next_still(c);
      if (f.header.width == 0 || f.header.message_id >= id) return f;
    }
  };
  c.send("lines.set", {{"field", "Velocity"}, {"seeds", {{0, -5, 2}, {0, 5, 2}}}, {"count", 40}});
  const Frame lines = still_for(c.send("mode.set", {{"mode", "dvr+lines"}}));
  EXPECT_TRUE(lines.jpeg != plain.jpeg) << "the lines show";
  const Frame selected = still_for(c.send("lines.set", {{"select", {{"lines", {0, 1, 2}}}}}));
  EXPECT_TRUE(selected.jpeg != lines.jpeg) << "the others are ghosted";
  c.send("mode.set", {{"mode", "points"}});
  const Frame points = still_for(c.send("points.set", {{"values", {400, 600}}}));
  EXPECT_TRUE(points.jpeg != plain.jpeg);
  EXPECT_FALSE(c.closed());
}

// A vector drawn by one component (tf.set "component"): dataset.info gives each component's
// range over the dataset (the X range of the mesh's own values, unlike the magnitude's) and
// histogram; the X component draws another image than the magnitude; a component of a scalar
// or an unknown one is refused and the session lives on.
// A tensor dataset viewed as tubes and diffusion surfaces (§7.4.2): a box whose diffusion
// tensor is linear along x below z = 0.5 and planar (normal z) above, preprocessed by the real
// `tetrascope preprocess`; mode.set "tensors" changes the image, tensors.set recolours it and
// changes the seeding, a field that is no tensor or absent is refused, the session lives on.
TEST_F(ServerTest, TensorsShowAsTubesAndSurfacesAndBadTensorRequestsAreRefused) {
  const fs::path mesh_file = scratch_dir("tensor-mesh") / "layers.vtk";
  {
    testing::CellMesh m = testing::from_tets(testing::kuhn_box(8, 0.2, [](float x, float, float) { return x; }));
    storage::Attribute d{{"D", 9, storage::AttributeKind::kTensor}, {}};
    for (size_t v = 0; v < m.x.size(); ++v) {
      const float medium = m.z[v] < 0.5f ? 0.15f : 0.9f;
      for (float c : {1.f, 0.f, 0.f, 0.f, medium, 0.f, 0.f, 0.f, 0.05f}) d.values.push_back(c);
    }
    m.attributes.push_back(d);
    testing::write_vtk_legacy(mesh_file, m);
  }
  ASSERT_EQ(testing::run_cli("preprocess " + mesh_file.string() + " -o " + (data_dir() / "layers").string() + " --progress none").status, 0);
  start();
  SessionClient c(ws_);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send("view.resize", {{"width", 240}, {"height", 200}});
  c.send("dataset.open", {{"name", "layers"}});
  const auto info = c.expect("dataset.info", 60s);
  bool has_tensor = false;
  for (const auto& a : info["attributes"]) has_tensor |= a["name"] == "D" && a["kind"] == "tensor";
  ASSERT_TRUE(has_tensor) << info.dump();
  auto still_for = [&](uint32_t id) {
    for (;;) {
      Frame f = next_still(c);
      if (f.header.width == 0 || f.header.message_id >= id) return f;
    }
  };
  const Frame plain = still_for(c.send("mode.set", {{"mode", "slice"}}));
  const Frame classes = still_for(c.send("mode.set", {{"mode", "tensors"}}));
  EXPECT_TRUE(classes.jpeg != plain.jpeg) << "the tubes and surfaces show";
  EXPECT_GT(classes.jpeg.size(), plain.jpeg.size() + 1000) << "more than an empty background";
  const Frame by_fa = still_for(c.send("tensors.set", {{"color", "fa"}}));
  EXPECT_TRUE(by_fa.jpeg != classes.jpeg) << "coloured by fractional anisotropy";
  const Frame no_surfaces = still_for(c.send("tensors.set", {{"surface_density", 0}, {"density", 4}}));
  EXPECT_TRUE(no_surfaces.jpeg != by_fa.jpeg) << "fewer tubes, no surfaces";
  c.send("tensors.set", {{"field", "nope"}});
  EXPECT_EQ(error_code_of(c), "not_found") << "a field the dataset lacks";
  c.send("tensors.set", {{"field", "D.fa"}});
  EXPECT_EQ(error_code_of(c), "bad_field") << "a derived scalar is not a tensor";
  c.send("tensors.set", {{"density", 33}});
  EXPECT_EQ(error_code_of(c), "bad_field") << "seeding past its limit";
  c.send("tensors.set", {{"color", "purple"}});
  EXPECT_EQ(error_code_of(c), "bad_field");
  const Frame again = still_for(c.send("tensors.set", {{"field", "D"}, {"color", "class"}, {"size", 3}}));
  EXPECT_GT(again.header.width, 0u);
  EXPECT_FALSE(c.closed());
  // the load test's sessions draw the tensor's points (loadtest --mode) without an error
  LoadtestOptions o;
  o.url = ws_;
  o.dataset = "layers";
  o.duration_s = 2;
  o.width = 240;
  o.height = 200;
  o.mode = "slice+tensors";
  const nlohmann::json r = run_loadtest(o);
  EXPECT_EQ(r["errors"], 0) << r.dump();
  EXPECT_GT(r["frames"].get<uint64_t>(), 0u) << r.dump();
  o.mode = "dvr+glyphs";
  EXPECT_THROW(run_loadtest(o), std::invalid_argument);
}

TEST_F(ServerTest, AVectorComponentHasItsOwnRangeAndImage) {
  const storage::TetMesh mesh = storage::load_mesh(testing::sample_mesh());
  const storage::Attribute* velocity = mesh.find_attribute("Velocity");
  ASSERT_NE(velocity, nullptr);
  double lo = INFINITY, hi = -INFINITY;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    lo = std::min<double>(lo, velocity->values[3 * v]);
    hi = std::max<double>(hi, velocity->values[3 * v]);
  }
  start();
  SessionClient c(ws_);
  const auto info = open(c);
  nlohmann::json v;
  for (const auto& a : info["attributes"])
    if (a["name"] == "Velocity") v = a;
  ASSERT_TRUE(v.is_object()) << info.dump();
  ASSERT_EQ(v["component_ranges"].size(), 3u) << v.dump();
  EXPECT_EQ(v["component_ranges"][0][0].get<double>(), lo);
  EXPECT_EQ(v["component_ranges"][0][1].get<double>(), hi);
  EXPECT_NE(v["component_ranges"][0], v["range"]) << "the X range is the magnitude's";
  ASSERT_EQ(v["component_histograms"].size(), 3u);
  EXPECT_EQ(v["component_histograms"][0].size(), 64u);
  EXPECT_NE(v["component_histograms"][0], v["histogram"]);
  for (const auto& a : info["attributes"]) {
    if (a["components"] == 1) {
      EXPECT_FALSE(a.contains("component_ranges")) << a.dump();
    }
  }

  auto still_for = [&](uint32_t id) {
    for (;;) {
      Frame f = next_still(c);
      if (f.header.width == 0 || f.header.message_id >= id) return f;
    }
  };
  const Frame magnitude = still_for(c.send("tf.set", {{"attribute", "Velocity"}}));
  const Frame x = still_for(c.send("tf.set", {{"attribute", "Velocity"}, {"component", "x"}}));
  EXPECT_TRUE(x.jpeg != magnitude.jpeg) << "the X component drew the magnitude's image";
  c.send("tf.set", {{"attribute", "Temp"}, {"component", "x"}});
  EXPECT_EQ(error_code_of(c), "bad_field") << "a scalar has no X component";
  c.send("tf.set", {{"attribute", "Velocity"}, {"component", "w"}});
  EXPECT_EQ(error_code_of(c), "bad_field") << "no component w";
  EXPECT_FALSE(c.closed());
}

// Pixels of a JPEG frame unlike the background (its green channel, 26, off by more than 30).
size_t lit_pixels(const std::string& jpeg) {
  tjhandle tj = tjInitDecompress();
  int w = 0, h = 0, sub = 0, space = 0;
  std::vector<unsigned char> rgb;
  if (tjDecompressHeader3(tj, reinterpret_cast<const unsigned char*>(jpeg.data()), jpeg.size(), &w, &h, &sub, &space) == 0) {
    rgb.resize(size_t(w) * h * 3);
    if (tjDecompress2(tj, reinterpret_cast<const unsigned char*>(jpeg.data()), jpeg.size(), rgb.data(), w, 0, h, TJPF_RGB, 0) != 0) rgb.clear();
  }
  tjDestroy(tj);
  size_t lit = 0;
  for (size_t i = 0; i < rgb.size(); i += 3)
    if (std::abs(int(rgb[i + 1]) - 26) > 30) ++lit;
  return lit;
}

// Boundary regions: dataset.info lists them; in surface mode hiding one changes the still,
// hiding them all leaves the background, and showing them again gives the first image back.
TEST_F(ServerTest, HiddenBoundaryRegionsChangeTheSurfaceImage) {
  start();
  SessionClient c(ws_);
  const auto info = open(c);
  const auto& regions = info["regions"];
  ASSERT_GE(regions.size(), 2u) << info.dump();
  for (size_t i = 0; i < regions.size(); ++i) {
    EXPECT_EQ(regions[i]["id"], i);
    EXPECT_GT(regions[i]["triangles"].get<uint64_t>(), 0u);
  }
  EXPECT_TRUE(regions[0]["touches_domain_box"].get<bool>()) << "the largest region of a closed domain lies on its box";
  auto still_for = [&](uint32_t id) {
    for (;;) {
      Frame f = next_still(c);
      if (f.header.width == 0 || f.header.message_id >= id) return f;
    }
  };
  const Frame all = still_for(c.send("mode.set", {{"mode", "surface"}}));
  const Frame one_hidden = still_for(c.send("regions.set", {{"hidden", {0}}}));
  EXPECT_TRUE(one_hidden.jpeg != all.jpeg) << "region 0 is gone";
  nlohmann::json every = nlohmann::json::array();
  for (size_t i = 0; i < regions.size(); ++i) every.push_back(i);
  const Frame none_shown = still_for(c.send("regions.set", {{"hidden", every}}));
  EXPECT_GT(lit_pixels(all.jpeg), 320u * 240 / 10) << "the boundary covers the view's middle";
  EXPECT_LT(lit_pixels(none_shown.jpeg), 320u * 240 / 1000) << "every region hidden: the background";
  const Frame again = still_for(c.send("regions.set", {{"hidden", nlohmann::json::array()}}));
  EXPECT_TRUE(again.jpeg == all.jpeg) << "every region shown again";
  // the volume ignores them: the boundary's regions are the surface's
  const Frame volume = still_for(c.send("mode.set", {{"mode", "dvr"}}));
  const Frame volume_hidden = still_for(c.send("regions.set", {{"hidden", every}}));
  EXPECT_TRUE(volume.jpeg == volume_hidden.jpeg);
  EXPECT_FALSE(c.closed());
}

// A store of a mesh whose boundary faces carry Gmsh physical surfaces: the REST description and
// dataset.info list one region a tag, named as the input names it (the untagged side as
// "untagged"), with its triangles and "input tags" as their source; hiding one by its id
// changes the surface.
TEST_F(ServerTest, RegionsOfATaggedStoreComeFromTheInputsTags) {
  testing::TaggedCube cube = testing::tagged_cube();
  const fs::path mesh = scratch_dir("server-tagged-mesh") / "cube.msh";
  testing::write_gmsh(mesh, cube.mesh, cube.gmsh);
  ASSERT_EQ(testing::run_cli("preprocess " + mesh.string() + " -o " + (data_dir() / "cube").string() + " --progress none").status, 0);
  start();
  const HttpResult described = http_request(base_ + "/api/v1/datasets/cube", "GET");
  ASSERT_EQ(described.status, 200) << described.body;
  const auto info = nlohmann::json::parse(described.body);
  EXPECT_EQ(info["regions_source"], "input tags");
  std::map<std::string, uint64_t> triangles;
  for (const auto& r : info["regions"]) {
    EXPECT_EQ(r["source"], "input tags") << r.dump();
    triangles[r["name"].get<std::string>()] = r["triangles"].get<uint64_t>();
  }
  EXPECT_EQ(triangles, (std::map<std::string, uint64_t>{{"inlet", 8}, {"outlet", 8}, {"walls", 16}, {"physical 7", 8}, {"untagged", 8}}))
      << info["regions"].dump();
  SessionClient c(ws_);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send("view.resize", {{"width", 160}, {"height", 120}});
  c.send("dataset.open", {{"name", "cube"}});
  const auto opened = c.expect("dataset.info", 60s);
  ASSERT_EQ(opened["regions"], info["regions"]) << "the session hears what REST says";
  uint32_t walls = 0;
  for (const auto& r : opened["regions"])
    if (r["name"] == "walls") walls = r["id"];
  auto still_for = [&](uint32_t id) {
    for (;;) {
      Frame f = next_still(c);
      if (f.header.width == 0 || f.header.message_id >= id) return f;
    }
  };
  const Frame all = still_for(c.send("mode.set", {{"mode", "surface"}}));
  const Frame walls_hidden = still_for(c.send("regions.set", {{"hidden", {walls}}}));
  EXPECT_TRUE(walls_hidden.jpeg != all.jpeg) << "the walls are gone";
  EXPECT_FALSE(c.closed());
}

// Threat: a client naming regions the dataset does not have (an id past its count) or a list
// of thousands: refused with bad_field saying why, nothing hidden, the session lives on.
TEST_F(ServerTest, ARegionIdPastTheDatasetOrAHugeHiddenListIsRefused) {
  start();
  SessionClient c(ws_);
  const auto info = open(c);
  const size_t count = info["regions"].size();
  ASSERT_GT(count, 0u);
  c.send("regions.set", {{"hidden", {count}}});
  auto j = c.expect("error");
  EXPECT_EQ(j["code"], "bad_field");
  EXPECT_NE(j["message"].get<std::string>().find("no region " + std::to_string(count)), std::string::npos) << j.dump();
  c.send("regions.set", {{"hidden", {0, 1023}}});
  EXPECT_EQ(error_code_of(c), "bad_field") << "the largest id the protocol takes, past the dataset's";
  c.send("regions.set", {{"hidden", std::vector<uint32_t>(5000, 0)}});
  j = c.expect("error");
  EXPECT_EQ(j["code"], "bad_field");
  EXPECT_NE(j["message"].get<std::string>().find("more than 1024"), std::string::npos) << j.dump();
  c.send("regions.set", {{"hidden", {uint64_t{1} << 40}}});
  EXPECT_EQ(error_code_of(c), "bad_field");
  c.send("regions.set", {{"hidden", {-1}}});
  EXPECT_EQ(error_code_of(c), "bad_field");
  // nothing was hidden: the surface still shows
  const uint32_t id = c.send("mode.set", {{"mode", "surface"}});
  Frame f = next_still(c);
  while (f.header.width != 0 && f.header.message_id < id) f = next_still(c);
  EXPECT_GT(lit_pixels(f.jpeg), 320u * 240 / 10);
  EXPECT_FALSE(c.closed());
}

// The viewer's dash animation: a lines.set with only dash_phase is answered by an
// interaction frame (cheap), and the dashes move (the still after it differs).
TEST_F(ServerTest, ADashPhaseStepIsAnsweredWithAnInteractionFrameAndMovesTheDashes) {
  start();
  SessionClient c(ws_);
  open(c);
  next_still(c);
  auto frame_for = [&](uint32_t id, bool still) {
    for (;;) {
      Frame f = still ? next_still(c) : next_frame(c);
      if (f.header.width == 0 || f.header.message_id >= id) return f;
    }
  };
  c.send("lines.set", {{"seeds", {{0, -5, 2}, {0, 5, 2}}}, {"count", 30}, {"flow", "dashes"}, {"halos", false}});
  const Frame dashes = frame_for(c.send("mode.set", {{"mode", "lines"}}), true);
  const uint32_t step = c.send("lines.set", {{"dash_phase", 0.5}});
  const Frame interaction = frame_for(step, false);
  EXPECT_FALSE(interaction.header.still) << "an animation step is not refined at once";
  EXPECT_FALSE(interaction.header.refining);
  const Frame moved = frame_for(step, true);
  EXPECT_EQ(moved.header.message_id, step);
  EXPECT_TRUE(moved.jpeg != dashes.jpeg) << "the dashes moved";
  // a lines.set with more than the phase is a still as before
  const uint32_t style = c.send("lines.set", {{"dash_phase", 0}, {"ghost_opacity", 0.3}});
  const Frame back = frame_for(style, false);
  EXPECT_TRUE(back.header.still || back.header.refining);
  EXPECT_FALSE(c.closed());
}

TEST_F(ServerTest, AClientThatKeepsSendingGarbageIsClosedWithPolicyViolation) {
  auto o = options_for(data_dir());
  o.limits.max_bad_messages = 5;
  start(o);
  SessionClient c(ws_);
  for (int i = 0; i < 6; ++i) c.send_text("garbage");
  bool closed = false;
  try {
    for (int i = 0; i < 20; ++i) c.read(2s);
  } catch (const std::runtime_error&) {
    closed = true;
  }
  EXPECT_TRUE(closed);
  EXPECT_EQ(c.close_code(), 1008);
}

TEST_F(ServerTest, MessagesPerSecondAreLimited) {
  auto o = options_for(data_dir());
  o.limits.max_messages_per_second = 20;
  o.limits.max_bad_messages = 100;
  start(o);
  SessionClient c(ws_);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  for (int i = 0; i < 29; ++i) c.send("ping");  // with hello: 30 in well under a second
  int pongs = 0, limited = 0;
  while (pongs + limited < 29) {
    auto m = c.read(5s);
    ASSERT_TRUE(m.has_value());
    const auto j = nlohmann::json::parse(m->data);
    if (j["type"] == "pong") ++pongs;
    else if (j["type"] == "error" && j["code"] == "rate_limited") ++limited;
  }
  EXPECT_EQ(pongs, 19);  // at the limit
  EXPECT_EQ(limited, 10);  // past it
}

TEST_F(ServerTest, SessionsPerServerAreLimited) {
  auto o = options_for(data_dir());
  o.limits.max_sessions = 2;
  start(o);
  SessionClient a(ws_), b(ws_);
  a.send("ping");  // sessions exist once accepted
  EXPECT_THROW(SessionClient c(ws_), std::runtime_error);
  b.close();
  std::this_thread::sleep_for(300ms);
  EXPECT_NO_THROW(SessionClient d(ws_));
}

TEST_F(ServerTest, ATokenIsRequiredWhenSet) {
  auto o = options_for(data_dir());
  o.token = "s3cret-token";
  start(o);
  EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET").status, 401);
  EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET", "", "wrong-token!").status, 401);
  EXPECT_EQ(http_request(base_ + "/api/v1/health", "GET", "", "s3cret-token").status, 200);
  EXPECT_EQ(http_request(base_ + "/api/v1/datasets?token=s3cret-token", "GET").status, 200);
  EXPECT_EQ(http_request(base_ + "/metrics", "GET").status, 401);
  EXPECT_THROW(SessionClient c(ws_), std::runtime_error);
  EXPECT_THROW(SessionClient c(ws_ + "?token=nope"), std::runtime_error);
  SessionClient ok(ws_, "s3cret-token");
  open(ok);
  SessionClient by_query(ws_ + "?token=s3cret-token");
  by_query.send("hello", {{"version", 1}});
  by_query.expect("hello.ok");
  // binding beyond loopback needs a token
  auto open_bind = options_for(data_dir());
  open_bind.bind = "0.0.0.0";
  EXPECT_THROW(Server s(open_bind), std::invalid_argument);
}

TEST_F(ServerTest, PathsOutsideTheDataFolderAreRefused) {
  start();
  const fs::path outside = scratch_dir("server-outside");
  std::ofstream(outside / "secret.vtk") << "# vtk DataFile Version 3.0\n";
  fs::create_directories(data_dir() / "uploads");
  fs::create_symlink(outside / "secret.vtk", data_dir() / "uploads" / "link.vtk");
  for (const std::string source : {"../secret.vtk", "/etc/passwd", "uploads/../../secret.vtk", "uploads/link.vtk"}) {
    const HttpResult r = http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "x"}}).dump());
    EXPECT_EQ(r.status, 403) << source << ": " << r.body;
  }
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads?name=../evil.vtk", "POST", "data").status, 400);
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads?name=.hidden", "POST", "data").status, 400);
  EXPECT_EQ(http_request(base_ + "/../../etc/passwd", "GET").status, 404);
  EXPECT_EQ(http_request(base_ + "/%2e%2e/CMakeLists.txt", "GET").status, 404);
  EXPECT_EQ(http_request(base_ + "/protocol/../CMakeLists.txt", "GET").status, 404);
  EXPECT_EQ(http_request(base_ + "/api/v1/datasets/..%2F..%2Fetc", "GET").status, 404);
  EXPECT_FALSE(fs::exists(data_dir() / "x"));
  // what is inside is served
  EXPECT_EQ(http_request(base_ + "/", "GET").status, 200);
  EXPECT_EQ(http_request(base_ + "/protocol/js/codec.js", "GET").status, 200);
  const HttpResult api = http_request(base_ + "/api/v1/openapi.yaml", "GET");
  EXPECT_EQ(api.status, 200);
  EXPECT_NE(api.body.find("openapi:"), std::string::npos);
}

TEST_F(ServerTest, UploadsPastTheLimitAreRefusedAndLeaveNothing) {
  auto o = options_for(data_dir());
  o.max_upload_bytes = 1000;
  start(o);
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads?name=big.vtk", "POST", std::string(5000, 'x'), "", "application/octet-stream").status, 413);
  EXPECT_EQ(http_request(base_ + "/api/v1/uploads?name=ok.vtk", "POST", std::string(1000, 'x'), "", "application/octet-stream").status, 201);
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / "big.vtk"));
  EXPECT_FALSE(fs::exists(data_dir() / "uploads" / ".big.vtk.part"));
  EXPECT_EQ(fs::file_size(data_dir() / "uploads" / "ok.vtk"), 1000u);
  // a REST body past its limit
  o.max_request_body_bytes = 100;
  server_.reset();
  start(o);
  EXPECT_EQ(http_request(base_ + "/api/v1/jobs", "POST", std::string(200, ' ')).status, 413);
}

TEST_F(ServerTest, AJobTurnsAnUploadIntoADatasetThatOpensAndRenders) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to the checkout";
  start();
  const std::string source = upload(shared_data() / "fea_bracket.vtk", "fea_bracket.vtk");
  EXPECT_EQ(source, "uploads/fea_bracket.vtk");
  HttpResult r = http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "bracket"}, {"options", {{"base_tets", 5000}, {"memory_mb", 1}, {"variants", 2}}}}).dump());
  ASSERT_EQ(r.status, 202) << r.body;  // memory_mb 1: the input's tets go through a spill file; variants 2: variants.bin, which the session's cut reads
  const std::string id = nlohmann::json::parse(r.body)["id"];
  // a second job for the same name is refused while the first runs
  EXPECT_EQ(http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "bracket"}}).dump()).status, 409);
  const auto job = wait_job(id, [](const nlohmann::json& j) { return j["state"] != "queued" && j["state"] != "running"; });
  ASSERT_EQ(job["state"], "done") << job.dump();
  EXPECT_EQ(job["percent"], 100.0);
  const auto datasets = get_json("/api/v1/datasets")["datasets"];
  bool listed = false;
  for (const auto& d : datasets)
    if (d["name"] == "bracket") listed = d["state"] == "ready";
  EXPECT_TRUE(listed) << datasets.dump();
  EXPECT_TRUE(fs::exists(data_dir() / "bracket" / "variants.bin"));
  SessionClient c(ws_);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send("view.resize", {{"width", 200}, {"height", 150}});
  c.send("dataset.open", {{"name", "bracket"}});
  EXPECT_GT(c.expect("dataset.info", 60s)["tets"].get<uint64_t>(), 10000u);
  const Frame f = next_still(c);
  EXPECT_EQ(f.header.width, 200u);
  EXPECT_GT(f.header.tets, 0u);
  // bad job requests
  EXPECT_EQ(http_request(base_ + "/api/v1/jobs", "POST", "{nope").status, 400);
  EXPECT_EQ(http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "bracket"}}).dump()).status, 409);  // exists
  EXPECT_EQ(http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", "uploads/none.vtk"}, {"name", "n"}}).dump()).status, 404);
  EXPECT_EQ(http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "n"}, {"options", {{"rm_rf", 1}}}}).dump()).status, 400);
  EXPECT_EQ(http_request(base_ + "/api/v1/jobs/nonexistent", "GET").status, 404);
}

// A Gmsh file holding three time steps, submitted with options.all_steps, becomes a dataset of
// three steps (without it, of its last step alone); all_steps takes true or false only.
TEST_F(ServerTest, AJobWithAllStepsMakesADatasetOfEveryTimeStep) {
  start();
  namespace t = tetrascope::testing;
  const storage::TetMesh box = t::kuhn_box(6, 0.2, [](double, double, double) { return 0.0; });
  t::CellMesh mesh = t::from_tets(box);
  mesh.attributes.clear();
  const fs::path file = scratch_dir("server_steps") / "steps.msh";
  t::write_gmsh(file, mesh);
  std::string text = t::read_file(file);
  for (int s = 0; s < 3; ++s) {
    std::vector<std::pair<size_t, std::vector<double>>> rows;
    for (size_t v = 0; v < box.vertex_count(); ++v) rows.push_back({v + 1, {box.x[v] + s}});
    text += t::gmsh_data_section("NodeData", "temp", s, 0.5 * s, 1, rows);
  }
  t::write_file(file, text);
  const std::string source = upload(file, "steps.msh");
  auto submit = [&](const std::string& name, const nlohmann::json& all_steps) {
    return http_request(base_ + "/api/v1/jobs", "POST",
                        nlohmann::json({{"source", source}, {"name", name}, {"options", {{"all_steps", all_steps}, {"base_tets", 300}, {"segment_tets", 512}}}}).dump());
  };
  EXPECT_EQ(submit("bad", 1).status, 400);
  EXPECT_EQ(submit("bad", "yes").status, 400);
  for (const auto& [name, all] : {std::pair<std::string, bool>{"every", true}, {"last", false}}) {
    const HttpResult r = submit(name, all);
    ASSERT_EQ(r.status, 202) << r.body;
    const auto job = wait_job(nlohmann::json::parse(r.body)["id"], [](const nlohmann::json& j) { return j["state"] != "queued" && j["state"] != "running"; });
    ASSERT_EQ(job["state"], "done") << job.dump();
  }
  const auto datasets = get_json("/api/v1/datasets")["datasets"];  // a copy: the reply is a temporary
  std::map<std::string, size_t> steps;
  for (const auto& d : datasets) steps[d["name"].get<std::string>()] = d["time_steps"].size();
  EXPECT_EQ(steps["every"], 3u) << datasets.dump();
  EXPECT_EQ(steps["last"], 0u) << "a dataset of one step lists none";
}

TEST_F(ServerTest, AJobKilledMidwayIsReportedFailedAndLeavesNoHalfStore) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to the checkout";
  start();
  const std::string source = upload(shared_data() / "nasa_oxygen_post.vtk", "oxygen.vtk");
  HttpResult r = http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "oxygen"}}).dump());
  ASSERT_EQ(r.status, 202) << r.body;
  const std::string id = nlohmann::json::parse(r.body)["id"];
  const auto running = wait_job(id, [](const nlohmann::json& j) { return !j["pid"].is_null() || j["state"] != "running"; }, 60s);
  ASSERT_EQ(running["state"], "running") << running.dump();
  std::this_thread::sleep_for(300ms);  // into its work
  ASSERT_EQ(::kill(running["pid"].get<int>(), SIGKILL), 0);
  const auto job = wait_job(id, [](const nlohmann::json& j) { return j["state"] != "running"; });
  EXPECT_EQ(job["state"], "failed");
  EXPECT_NE(job["error"].get<std::string>().find("signal 9"), std::string::npos) << job.dump();
  EXPECT_FALSE(fs::exists(data_dir() / "oxygen"));
  EXPECT_FALSE(fs::exists(data_dir() / ".jobs" / id / "out"));
  const auto datasets = get_json("/api/v1/datasets")["datasets"];  // a copy: the reply is a temporary
  for (const auto& d : datasets) EXPECT_NE(d["name"], "oxygen");
  // the server carries on
  EXPECT_EQ(get_json("/api/v1/health")["status"], "ok");
}

TEST_F(ServerTest, JobsAreReportedCorrectlyAfterARestart) {
  if (shared_data().empty()) GTEST_SKIP() << "../shared/data is not next to the checkout";
  start();
  const std::string source = upload(shared_data() / "nasa_oxygen_post.vtk", "oxygen.vtk");
  const std::string small = upload(tetrascope::testing::sample_mesh(), "small.vtk");
  HttpResult done = http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", small}, {"name", "small"}}).dump());
  ASSERT_EQ(done.status, 202) << done.body;
  const std::string done_id = nlohmann::json::parse(done.body)["id"];
  wait_job(done_id, [](const nlohmann::json& j) { return j["state"] == "done"; });
  HttpResult r = http_request(base_ + "/api/v1/jobs", "POST", nlohmann::json({{"source", source}, {"name", "oxygen"}}).dump());
  ASSERT_EQ(r.status, 202) << r.body;
  const std::string id = nlohmann::json::parse(r.body)["id"];
  wait_job(id, [](const nlohmann::json& j) { return !j["pid"].is_null(); }, 60s);
  server_.reset();  // the server stops while the job runs
  fs::create_directories(data_dir() / ".jobs" / "damaged");
  std::ofstream(data_dir() / ".jobs" / "damaged" / "job.json") << "{\"id\": 7, \"state\": [";
  start();
  const auto job = get_json("/api/v1/jobs/" + id);
  ASSERT_EQ(job["state"], "failed") << job.dump();
  EXPECT_NE(job["error"].get<std::string>().find("server stopped"), std::string::npos);
  EXPECT_EQ(get_json("/api/v1/jobs/" + done_id)["state"], "done");
  EXPECT_FALSE(fs::exists(data_dir() / "oxygen"));
  EXPECT_TRUE(fs::exists(data_dir() / "small" / "manifest.json"));
}

TEST_F(ServerTest, MetricsCountSessionsAndFrames) {
  start();
  {
    SessionClient c(ws_);
    open(c);
    next_still(c);
  }
  const HttpResult m = http_request(base_ + "/metrics", "GET");
  EXPECT_EQ(m.status, 200);
  EXPECT_NE(m.body.find("tetrascope_sessions_total 1"), std::string::npos) << m.body;
  EXPECT_NE(m.body.find("tetrascope_frames_total{kind=\"still\"} "), std::string::npos);
  EXPECT_EQ(m.body.find("tetrascope_frames_total{kind=\"still\"} 0\n"), std::string::npos);
  EXPECT_NE(m.body.find("tetrascope_render_ms_bucket{le=\"+Inf\"}"), std::string::npos);
  EXPECT_NE(m.body.find("tetrascope_cache_misses_total"), std::string::npos);
  EXPECT_NE(m.body.find("tetrascope_jobs{state=\"running\"} 0"), std::string::npos);
}

TEST_F(ServerTest, LoadtestWithFourClientsHasNoErrorsAndEveryClientGetsFrames) {
  start();
  LoadtestOptions o;
  o.url = ws_;
  o.dataset = "disk";
  o.clients = 4;
  o.duration_s = 10;
  o.width = 320;
  o.height = 240;
  const nlohmann::json r = run_loadtest(o);
  EXPECT_EQ(r["errors"], 0) << r.dump();
  EXPECT_EQ(r["clients_without_frames"], 0) << r.dump();
  EXPECT_GT(r["latency_ms"]["samples"].get<uint64_t>(), 4u);
  for (const auto& c : r["per_client"]) EXPECT_GT(c["frames"].get<uint64_t>(), 0u);
  // out of bounds
  o.clients = 65;
  EXPECT_THROW(run_loadtest(o), std::invalid_argument);
  o.clients = 1;
  o.url = "ws://example.com:80/api/v1/session";
  EXPECT_THROW(run_loadtest(o), std::invalid_argument);
}

}  // namespace
}  // namespace tetrascope::server
