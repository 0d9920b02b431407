#include "tetrascope/renderer/view_frame.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>

#include "tetrascope/lod/dag.h"

namespace tetrascope::renderer {
namespace {

std::atomic<uint64_t> next_scene_generation{1};

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

const storage::StoreAttribute* find_attribute(const storage::StoreManifest& manifest, const std::string& name) {
  auto it = std::find_if(manifest.attributes.begin(), manifest.attributes.end(), [&](const auto& a) { return a.name == name; });
  return it == manifest.attributes.end() ? nullptr : &*it;
}

}  // namespace

ViewPipeline::ViewPipeline(const storage::Store& store, const lod::Dag& dag, storage::SegmentCache& cache)
    : store_(&store), dag_(&dag), cache_(&cache), cut_(std::make_unique<lod::Cut>(dag)), bounds_(store.manifest().bounds) {}

ViewPipeline::ViewPipeline(storage::TetMesh mesh) : mesh_(std::move(mesh)), bounds_(storage::compute_bounds(*mesh_)) {}

ViewPipeline::~ViewPipeline() = default;

// The attribute defaults to the dataset's first; its colour range to the attribute's over the
// whole dataset, so colours stay put while the cut changes.
void ViewPipeline::resolve_attribute(lod::TransferFunction& tf) const {
  if (!store_) return;  // a whole mesh: SceneMesh::from picks and ranges the attribute
  const auto& manifest = store_->manifest();
  if (tf.attribute.empty() && manifest.attributes.empty()) return;
  const std::string name = tf.attribute.empty() ? manifest.attributes.front().name : tf.attribute;
  const storage::StoreAttribute* a = find_attribute(manifest, name);
  if (!a) {
    std::string names;
    for (const auto& known : manifest.attributes) names += (names.empty() ? "" : ", ") + known.name;
    throw std::invalid_argument("no attribute '" + name + "' in the dataset (it has: " + names + ")");
  }
  tf.attribute = name;
  if (!tf.range) tf.range = std::array<double, 2>{a->components == 1 ? a->min : 0, a->max > a->min ? a->max : a->min + 1};
}

void ViewPipeline::rebuild_scene(const storage::TetMesh& mesh, const std::string& attribute, const std::string& iso_color_attribute) {
  scene_ = std::make_unique<const SceneMesh>(SceneMesh::from(mesh, attribute, iso_color_attribute));
  attribute_ = attribute;
  iso_color_attribute_ = iso_color_attribute;
  scene_generation_ = next_scene_generation++;
}

RenderSettings ViewPipeline::update(const ViewRequest& request, ViewTimings* timings) {
  RenderSettings s;
  s.dvr = request.dvr;
  s.iso = request.iso;
  s.surface = request.surface;
  s.wireframe = request.wireframe;
  s.box = request.box;
  s.width = request.width;
  s.height = request.height;
  s.tf = request.tf;
  s.unit_distance = request.unit_distance;
  s.volume = request.volume;
  s.iso_opacity = request.iso_opacity;
  s.isovalues = request.isovalues;
  s.use_iso_color_attribute = !request.iso_color_attribute.empty();
  resolve_attribute(s.tf);

  s.camera = request.camera ? *request.camera : lod::default_camera(bounds_);
  s.camera.aspect = double(s.width) / s.height;
  ViewTimings local;
  ViewTimings& t = timings ? *timings : local;
  if (store_) {
    if (s.iso && s.isovalues.empty() && s.tf.range) s.isovalues = {0.5 * ((*s.tf.range)[0] + (*s.tf.range)[1])};
    lod::CutCriteria criteria = lod::criteria_for(*store_, *dag_, s.tf, s.iso ? std::span<const double>(s.isovalues) : std::span<const double>());
    lod::set_view(criteria, s.camera);
    auto start = Clock::now();
    const auto changes = cut_->update(criteria, request.budget);
    cut_estimated_error_ = changes.estimated_error;
    t.cut_ms = ms_since(start);
    start = Clock::now();
    if (!scene_ || !changes.added.empty() || !changes.removed.empty() || attribute_ != s.tf.attribute || iso_color_attribute_ != request.iso_color_attribute)
      rebuild_scene(lod::assemble_cut(*store_, *cache_, *cut_, false).mesh, s.tf.attribute, request.iso_color_attribute);
    t.assemble_ms = ms_since(start);
    return s;
  }
  const auto start = Clock::now();
  if (!scene_ || attribute_ != s.tf.attribute || iso_color_attribute_ != request.iso_color_attribute) rebuild_scene(*mesh_, s.tf.attribute, request.iso_color_attribute);
  t.assemble_ms = ms_since(start);
  s.tf.attribute = scene_->attribute;
  if (s.iso && s.isovalues.empty()) s.isovalues = {0.5 * (scene_->value_min + scene_->value_max)};
  return s;
}

Image ViewPipeline::draw(const RenderSettings& settings, Renderer& renderer, uint64_t& held_generation, ViewTimings* timings) {
  ViewTimings local;
  ViewTimings& t = timings ? *timings : local;
  auto start = Clock::now();
  if (held_generation != scene_generation_) {
    renderer.set_mesh(*scene_);
    held_generation = scene_generation_;
  }
  t.upload_ms = ms_since(start);
  start = Clock::now();
  Image image = renderer.render(settings, &t.draw);
  t.draw_ms = ms_since(start);
  return image;
}

ViewFrame ViewPipeline::render(const ViewRequest& request, Renderer& renderer, uint64_t& held_generation) {
  ViewFrame frame;
  frame.settings = update(request, &frame.timings);
  frame.image = draw(frame.settings, renderer, held_generation, &frame.timings);
  frame.tets = scene_->tets.size() / 4;
  return frame;
}

}  // namespace tetrascope::renderer
