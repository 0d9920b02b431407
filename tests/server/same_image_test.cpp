// One frame pipeline: `tetrascope render` (a process) and a real server session (a WebSocket
// client) render the same store, camera, transfer function, mode, isovalues, budget and size;
// the session sends a PNG still, so the two images must agree to within 45 dB (they are
// expected to be equal: same cut, same scene, same renderer).
#include <png.h>

#include <chrono>
#include <fstream>

#include <gtest/gtest.h>

#include "tetrascope/renderer/render.h"
#include "tetrascope/server/client.h"
#include "tetrascope/server/server.h"
#include "test_paths.h"

namespace tetrascope::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using tetrascope::testing::scratch_dir;
using tetrascope::testing::tetrascope_binary;

constexpr double kMinPsnrDb = 45;

renderer::Image decode_png(const std::string& bytes) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  renderer::Image image;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size())) return image;
  png.format = PNG_FORMAT_RGBA;
  image.rgba.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr)) return {};
  image.width = png.width;
  image.height = png.height;
  return image;
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

int run(const std::string& arguments) { return std::system((tetrascope_binary().string() + " " + arguments + " > /dev/null").c_str()); }

// The view both sides render.
struct View {
  std::string mode;
  std::vector<double> isovalues;
  nlohmann::json tf;             // null: none given
  std::optional<nlohmann::json> camera;  // camera.set's fields; none: the default view
  uint64_t budget = 0;
  uint32_t width = 0, height = 0;
  std::string backend = "gl";    // render --backend, ServerOptions::backend
  std::vector<uint32_t> hidden_regions{};  // regions.set, render --hide-regions
  std::string component{};       // tf.set's "component", render --component; empty: none given
};

renderer::Image render_with_cli(const fs::path& store, const View& v, const fs::path& dir) {
  std::string arguments = "render " + store.string() + " -o " + (dir / "cli.png").string() + " --mode " + v.mode + " --budget " + std::to_string(v.budget) +
                          " --size " + std::to_string(v.width) + "x" + std::to_string(v.height) + " --backend " + v.backend;
  if (!v.isovalues.empty()) {
    std::string list;
    for (double value : v.isovalues) {
      if (!list.empty()) list += ',';
      list += nlohmann::json(value).dump();
    }
    arguments += " --iso " + list;
  }
  if (!v.tf.is_null()) {
    std::ofstream(dir / "tf.json") << v.tf.dump();
    arguments += " --tf " + (dir / "tf.json").string();
  }
  if (v.camera) {
    const auto& c = *v.camera;
    auto triple = [](const nlohmann::json& a) { return a[0].dump() + "," + a[1].dump() + "," + a[2].dump(); };
    arguments += " --camera eye=" + triple(c["eye"]) + ",target=" + triple(c["target"]) + ",up=" + triple(c["up"]) + ",fov=" + c["fov"].dump();
  }
  if (!v.component.empty()) arguments += " --component " + v.component;
  if (!v.hidden_regions.empty()) {
    std::string list;
    for (uint32_t id : v.hidden_regions) {
      if (!list.empty()) list += ',';
      list += std::to_string(id);
    }
    arguments += " --hide-regions " + list;
  }
  EXPECT_EQ(run(arguments), 0) << arguments;
  return decode_png(read_file(dir / "cli.png"));
}

renderer::Image render_with_session(const std::string& url, const View& v) {
  SessionClient c(url);
  c.send("hello", {{"version", 1}});
  c.expect("hello.ok");
  c.send("view.resize", {{"width", v.width}, {"height", v.height}});
  c.send("quality.set", {{"still_codec", "png"}});
  c.send("mode.set", {{"mode", v.mode}});
  c.send("lod.set", {{"budget", v.budget}});
  uint32_t last = c.send("dataset.open", {{"name", "disk"}});
  c.expect("dataset.info", 60s);
  // after dataset.open, which resets the isovalues, transfer function and camera
  if (!v.isovalues.empty()) last = c.send("iso.set", {{"values", v.isovalues}});
  if (!v.tf.is_null()) {
    nlohmann::json tf = v.tf;
    if (!v.component.empty()) tf["component"] = v.component;
    last = c.send("tf.set", tf);
  }
  if (!v.hidden_regions.empty()) last = c.send("regions.set", {{"hidden", v.hidden_regions}});
  if (v.camera) {
    nlohmann::json camera = *v.camera;
    camera["interacting"] = false;
    last = c.send("camera.set", camera);
  }
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  while (std::chrono::steady_clock::now() < deadline) {
    auto m = c.read(60s);
    if (!m) break;
    if (!m->binary) {
      EXPECT_EQ(nlohmann::json::parse(m->data)["type"], "error_never") << m->data;
      continue;
    }
    const auto* bytes = reinterpret_cast<const uint8_t*>(m->data.data());
    const protocol::FrameHeader h = protocol::decode_frame_header(std::span<const uint8_t>(bytes, m->data.size()), protocol::Limits{});
    if (!h.still || h.message_id < last) continue;  // a frame of an earlier state
    EXPECT_EQ(h.codec, protocol::Codec::kPng);
    return decode_png(m->data.substr(protocol::kFrameHeaderBytes));
  }
  ADD_FAILURE() << "no still frame of the whole view";
  return {};
}

class SameImage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new fs::path(scratch_dir("same-image"));
    const fs::path store = *data_ / "disk";
    ASSERT_EQ(run("preprocess " + tetrascope::testing::sample_mesh().string() + " -o " + store.string() + " --segment-tets 2000 --base-tets 3000 --progress none"), 0);
  }
  static void TearDownTestSuite() { delete data_; }

  void expect_same_image(const View& view) {
    ServerOptions o;
    o.data_dir = *data_;
    o.web_root = tetrascope::testing::source_dir() / "web-client";
    o.protocol_root = tetrascope::testing::source_dir() / "protocol";
    o.port = 0;
    o.render_workers = 1;
    o.cache_bytes = 256ull << 20;
    o.backend = view.backend;
    Server server(o);
    // the health says who draws volumes
    const HttpResult health = http_request("http://127.0.0.1:" + std::to_string(server.port()) + "/api/v1/health", "GET");
    EXPECT_EQ(nlohmann::json::parse(health.body)["backend"], view.backend) << health.body;
    const renderer::Image session = render_with_session("ws://127.0.0.1:" + std::to_string(server.port()) + "/api/v1/session", view);
    const renderer::Image cli = render_with_cli(*data_ / "disk", view, scratch_dir(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    ASSERT_EQ(cli.width, view.width);
    ASSERT_EQ(cli.height, view.height);
    ASSERT_EQ(session.width, cli.width);
    ASSERT_EQ(session.height, cli.height);
    const double db = renderer::psnr(cli, session);
    EXPECT_GE(db, kMinPsnrDb);
    EXPECT_TRUE(cli.rgba == session.rgba) << "PSNR " << db << " dB";
  }

  static fs::path* data_;
};
fs::path* SameImage::data_ = nullptr;

// The session's first still after dataset.open comes from a fresh cut, as the CLI's does: the
// budget may limit the cut.
TEST_F(SameImage, ServerSessionAndCliRenderTheDefaultViewAlike) {
  // the default camera, transfer function and isovalue (mid-range of the whole dataset)
  expect_same_image({.mode = "dvr+iso", .isovalues = {}, .tf = nullptr, .camera = std::nullopt, .budget = 20000, .width = 200, .height = 150});
}

// Later stills come from the session's cut updated from its earlier views; with a budget that
// does not limit it, the cut depends on the view alone.

TEST_F(SameImage, ServerSessionAndCliRenderAGivenCameraAndTransferFunctionAlike) {
  const nlohmann::json tf = {{"attribute", "Temp"}, {"colormap", "plasma"}, {"range", {300, 900}}, {"opacity", {{300, 0}, {900, 0.8}}}};
  const nlohmann::json camera = {{"eye", {20.0, -25.0, 15.0}}, {"target", {0.0, 0.0, 5.0}}, {"up", {0.0, 0.0, 1.0}}, {"fov", 35}};
  expect_same_image({.mode = "dvr+iso", .isovalues = {450, 700}, .tf = tf, .camera = camera, .budget = 100000, .width = 160, .height = 160});
}

// Boundary regions hidden in a session (regions.set) and by render --hide-regions: the same
// image from a cut the budget limits (its simplified faces classified alike).
TEST_F(SameImage, ServerSessionAndCliHideTheSameBoundaryRegions) {
  expect_same_image({.mode = "surface", .isovalues = {}, .tf = nullptr, .camera = std::nullopt, .budget = 20000, .width = 200, .height = 150, .hidden_regions = {0, 2}});
}

// One component of a vector (tf.set "component", render --component): both colour it over the
// component's range over the dataset (no range given) and draw the same image.
TEST_F(SameImage, ServerSessionAndCliColourByTheSameVectorComponent) {
  const nlohmann::json tf = {{"attribute", "Velocity"}, {"colormap", "cool-warm"}, {"opacity", {{-5, 0.6}, {0, 0.02}, {5, 0.6}}}};
  expect_same_image({.mode = "dvr+surface", .isovalues = {}, .tf = tf, .camera = std::nullopt, .budget = 20000, .width = 200, .height = 150, .component = "x"});
}

// The CPU ray caster draws the session's frames as it draws render --backend cpu's.
TEST_F(SameImage, ServerSessionAndCliRenderAlikeWithTheCpuRayCaster) {
  const nlohmann::json tf = {{"attribute", "Temp"}, {"colormap", "viridis"}, {"range", {300, 900}}, {"opacity", {{300, 0.05}, {900, 0.7}}}};
  const nlohmann::json camera = {{"eye", {18.0, -22.0, 12.0}}, {"target", {0.0, 0.0, 5.0}}, {"up", {0.0, 0.0, 1.0}}, {"fov", 40}};
  expect_same_image({.mode = "dvr+iso", .isovalues = {500}, .tf = tf, .camera = camera, .budget = 100000, .width = 160, .height = 120, .backend = "cpu"});
}

}  // namespace
}  // namespace tetrascope::server
