#include "view.h"

#include <atomic>
#include <chrono>
#include <cmath>

namespace tetrascope::server {
namespace {

std::atomic<uint64_t> next_generation{1};

double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

lod::Camera opening_camera(const storage::Bounds& bounds) { return lod::parse_camera("azimuth=30,elevation=20,distance=1.95,fov=30", bounds); }

RenderedFrame ViewRenderer::render(const ViewState& state, bool still, Worker& worker, uint32_t frame_number) {
  const auto start = std::chrono::steady_clock::now();
  const Dataset& d = *state.dataset;
  if (dataset_ != state.dataset) {
    dataset_ = state.dataset;
    cut_ = std::make_unique<lod::Cut>(*d.dag);
    scene_.reset();
  }
  const auto& manifest = d.store->manifest();
  lod::TransferFunction tf = state.tf;
  if (!tf.attribute.empty() || !manifest.attributes.empty()) {
    const std::string name = tf.attribute.empty() ? manifest.attributes.front().name : tf.attribute;
    auto a = std::find_if(manifest.attributes.begin(), manifest.attributes.end(), [&](const auto& x) { return x.name == name; });
    if (a == manifest.attributes.end()) throw std::invalid_argument("no attribute '" + name + "' in " + d.name);
    tf.attribute = name;
    // colours stay put while the cut changes: the range is the dataset's, not the cut's
    if (!tf.range) tf.range = std::array<double, 2>{a->components == 1 ? a->min : 0, a->max > a->min ? a->max : a->min + 1};
  }
  if (!renderer::known_colormap(tf.colormap)) throw std::invalid_argument("unknown colormap '" + tf.colormap + "'");

  renderer::RenderSettings settings;
  const double scale = still ? 1.0 : state.interaction_scale;
  settings.width = std::max<uint32_t>(16, static_cast<uint32_t>(std::lround(state.width * scale)));
  settings.height = std::max<uint32_t>(16, static_cast<uint32_t>(std::lround(state.height * scale)));
  settings.camera = state.camera_set ? state.camera : opening_camera(manifest.bounds);
  settings.camera.aspect = double(settings.width) / settings.height;
  settings.dvr = state.dvr;
  settings.iso = state.iso;
  settings.surface = state.surface;
  settings.wireframe = state.wireframe;
  settings.box = state.box;
  settings.tf = tf;
  settings.iso_opacity = state.iso_opacity;
  settings.isovalues = state.isovalues;
  if (settings.iso && settings.isovalues.empty()) settings.isovalues = {0.5 * ((*tf.range)[0] + (*tf.range)[1])};

  lod::CutCriteria criteria = lod::criteria_for(*d.store, *d.dag, tf, settings.iso ? std::span<const double>(settings.isovalues) : std::span<const double>());
  lod::set_view(criteria, settings.camera);
  RenderedFrame frame;
  auto step = std::chrono::steady_clock::now();
  const auto changes = cut_->update(criteria, still ? state.budget : state.interaction_budget);
  frame.cut_ms = ms_since(step);
  const bool cut_changed = !changes.added.empty() || !changes.removed.empty();
  step = std::chrono::steady_clock::now();
  if (!scene_ || cut_changed || attribute_ != tf.attribute || second_ != state.color_by) {
    const auto mesh = lod::assemble_cut(*d.store, *d.cache, *cut_, false).mesh;
    scene_ = std::make_shared<const renderer::SceneMesh>(renderer::SceneMesh::from(mesh, tf.attribute, state.color_by));
    attribute_ = tf.attribute;
    second_ = state.color_by;
    scene_generation_ = next_generation++;
  }
  frame.assemble_ms = ms_since(step);
  settings.use_iso_color_attribute = !state.color_by.empty();
  step = std::chrono::steady_clock::now();
  if (worker.scene_generation != scene_generation_) {
    worker.renderer->set_mesh(*scene_);
    worker.scene_generation = scene_generation_;
  }
  frame.upload_ms = ms_since(step);
  step = std::chrono::steady_clock::now();
  const renderer::Image image = worker.renderer->render(settings);
  frame.draw_ms = ms_since(step);
  const double render_ms = ms_since(start);
  const auto encode_start = std::chrono::steady_clock::now();
  const bool png = still && state.png_stills;
  std::vector<uint8_t> payload = png ? renderer::encode_png(image) : renderer::encode_jpeg(image, still ? state.still_quality : state.interaction_quality);
  frame.header.frame_number = frame_number;
  frame.header.message_id = state.message_id;
  frame.header.width = image.width;
  frame.header.height = image.height;
  frame.header.codec = png ? protocol::Codec::kPng : protocol::Codec::kJpeg;
  frame.header.still = still;
  frame.header.tets = scene_->tets.size() / 4;
  frame.header.render_ms = static_cast<float>(render_ms);
  frame.header.encode_ms = static_cast<float>(ms_since(encode_start));
  frame.header.payload_bytes = static_cast<uint32_t>(payload.size());
  const auto header = protocol::encode_frame_header(frame.header);
  frame.bytes.reserve(header.size() + payload.size());
  frame.bytes.insert(frame.bytes.end(), header.begin(), header.end());
  frame.bytes.insert(frame.bytes.end(), payload.begin(), payload.end());
  return frame;
}

}  // namespace tetrascope::server
