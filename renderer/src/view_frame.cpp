#include "tetrascope/renderer/view_frame.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/field/streamlines.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/renderer/ray_caster.h"
#include "tetrascope/storage/time_steps.h"

namespace tetrascope::renderer {
namespace {

std::atomic<uint64_t> next_scene_generation{1};
constexpr const char* kDefaultSeeds = "dense:12";

// What the traced lines depend on (the selection and style do not).
bool same_trace(const LineRequest& a, const LineRequest& b) { return a.field == b.field && a.seeds == b.seeds && a.max_steps == b.max_steps; }
bool same_selection(const LineRequest& a, const LineRequest& b) { return a.selected == b.selected && a.select_box == b.select_box && a.select_pixel == b.select_pixel; }

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

const storage::StoreAttribute* find_attribute(const storage::StoreManifest& manifest, const std::string& name) {
  auto it = std::find_if(manifest.attributes.begin(), manifest.attributes.end(), [&](const auto& a) { return a.name == name; });
  return it == manifest.attributes.end() ? nullptr : &*it;
}

// Whether the volume shows anything: drawn, with some opacity. Where it shows nothing the cut
// is not weighted by its opacity (that would rank everything as unseen and leave a slice, the
// boundary or the lines at the coarsest level): every part then counts by its error and its
// share of the view, and slices first.
bool volume_shown(const RenderSettings& s) {
  if (!s.dvr) return false;
  if (s.tf.opacity.empty()) return true;  // the default ramp
  return std::any_of(s.tf.opacity.begin(), s.tf.opacity.end(), [](const auto& point) { return point[1] > 0; });
}

// The vertex hierarchy records attributes by name and components: their kinds (a tensor, a
// scalar derived from one) come from the store's manifest, for the tensor passes.
void with_kinds(storage::TetMesh& mesh, const storage::StoreManifest& manifest) {
  for (storage::Attribute& a : mesh.attributes)
    if (const storage::StoreAttribute* m = find_attribute(manifest, a.info.name); m && m->components == a.info.components) {
      a.info.kind = m->kind;
      a.info.positive_semidefinite = m->positive_semidefinite;
      a.info.derived_from = m->derived_from;
    }
}

}  // namespace

ViewPipeline::ViewPipeline(const storage::Store& store, const lod::Dag& dag, storage::SegmentCache& cache, std::shared_ptr<const lod::VertexHierarchy> vertices)
    : store_(&store), dag_(&dag), cache_(&cache), cut_(std::make_unique<lod::Cut>(dag)), vertices_(std::move(vertices)), bounds_(store.manifest().bounds) {
  variants_ = lod::Variants::open(store, dag);  // null without variants.bin
  cut_->attach_variants(variants_.get());
  if (vertices_) front_ = std::make_unique<lod::VertexFront>(*vertices_);
}

void ViewPipeline::update_front(const ViewRequest& request, RenderSettings& s, ViewTimings& t, bool trace) {
  lod::FrontCriteria criteria = lod::front_criteria(*vertices_, s.tf, s.iso ? std::span<const double>(s.isovalues) : std::span<const double>());
  if (!s.iso && !volume_shown(s)) criteria.opacity.clear();
  criteria.camera = s.camera;
  criteria.clip = request.clip.half_spaces();
  criteria.slices = request.slices.planes;
  criteria.unit_distance = s.unit_distance;
  auto start = Clock::now();
  const lod::FrontChanges changes = front_->update(criteria, request.budget, request.moving ? lod::FrontSearch::run_time : lod::FrontSearch::best);
  cut_estimated_error_ = changes.estimated_error;
  cut_budget_ = CutBudget{request.budget, changes.tets, changes.budget_limited, changes.over_budget, changes.complete, changes.forced_tets, changes.unseen_tets, changes.refused, changes.run_time_valid};
  t.cut_ms = ms_since(start);
  start = Clock::now();
  std::optional<storage::TetMesh> mesh;
  if (!scene_ || !scene_from_front_ || scene_stale_ || step_changed_ || changes.changed || attribute_ != s.tf.attribute || component_ != s.tf.component || iso_color_attribute_ != request.iso_color_attribute) {
    mesh = front_->mesh(nullptr, step_values_ ? step_values_->data() : nullptr);
    rebuild_scene(*mesh, s.tf, request.iso_color_attribute);
    step_changed_ = false;
    scene_from_front_ = true;
    scene_stale_ = false;
    assembled_clip_.clear();
  }
  t.assemble_ms = ms_since(start);
  update_clip(request.clip, t);
  classify_regions(request, t);
  if ((trace || tensors_stale(request)) && !mesh) mesh = front_->mesh(nullptr, step_values_ ? step_values_->data() : nullptr);
  if (mesh) with_kinds(*mesh, store_->manifest());
  if (trace) trace_lines(*mesh, request.line);
  if (request.lines) apply_lines(request.line, s);
  update_tensors(mesh ? *mesh : storage::TetMesh{}, request, s);
}

void ViewPipeline::set_step(uint32_t step, storage::SegmentCache& cache, std::shared_ptr<const std::vector<float>> values) {
  if (!store_) throw std::invalid_argument("time steps are those of a store");
  if (front_ && values && values->size() < size_t{vertices_->vertex_count()} * vertices_->value_floats)
    throw storage::TimeStepsError(store_->path().string() + ": step " + std::to_string(step) + " has values for fewer vertices than vertices.bin holds");
  if (step == step_ && &cache == cache_) return;
  step_ = step;
  cache_ = &cache;
  step_values_ = std::move(values);
  step_changed_ = true;
  traced_.reset();  // the lines follow the step's field
}

ViewPipeline::ViewPipeline(storage::TetMesh mesh) : mesh_(std::move(mesh)), bounds_(storage::compute_bounds(*mesh_)) {}

ViewPipeline::~ViewPipeline() = default;

// The attribute defaults to the dataset's first; its colour range to the attribute's (or the
// chosen component's) over the whole dataset, so colours stay put while the cut changes.
void ViewPipeline::resolve_attribute(view::TransferFunction& tf) const {
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
  if (tf.component != view::kMagnitude) {
    if (a->components < 2 || tf.component < 0 || uint32_t(tf.component) >= std::min(a->components, uint32_t(view::kComponentNames.size())))
      throw std::invalid_argument("attribute '" + name + "' has " + std::to_string(a->components) + " component" + (a->components == 1 ? "" : "s") + ": no component " +
                                  (tf.component >= 0 && tf.component < 3 ? std::string(view::kComponentNames[size_t(tf.component)]) : std::to_string(tf.component)));
    const std::array<double, 2> r = storage::component_range(*a, uint32_t(tf.component));
    if (!tf.range) tf.range = std::array<double, 2>{r[0], r[1] > r[0] ? r[1] : r[0] + 1};
    return;
  }
  // a time series: the range over every step, so that colours stay put while the steps play
  const std::array<double, 2> r = storage::series_range(manifest, static_cast<size_t>(a - manifest.attributes.data()));
  if (!tf.range) tf.range = std::array<double, 2>{a->components == 1 ? r[0] : 0, r[1] > r[0] ? r[1] : r[0] + 1};
}

void ViewPipeline::rebuild_scene(const storage::TetMesh& mesh, const view::TransferFunction& tf, const std::string& iso_color_attribute) {
  const std::string& attribute = tf.attribute;
  SceneMesh scene = SceneMesh::from(mesh, attribute, iso_color_attribute, tf.component);
  // isosurfaces coloured by an attribute over its range over the whole dataset, as with the
  // stream lines: the same value the same colour whatever the cut
  if (const storage::StoreAttribute* a = store_ && !iso_color_attribute.empty() ? find_attribute(store_->manifest(), iso_color_attribute) : nullptr; a && a->max > a->min) {
    scene.iso_color_min = a->components == 1 ? a->min : std::max(0.0, a->min);
    scene.iso_color_max = a->max;
  }
  scene_ = std::make_unique<SceneMesh>(std::move(scene));
  attribute_ = attribute;
  component_ = tf.component;
  iso_color_attribute_ = iso_color_attribute;
  scene_generation_ = next_scene_generation++;
}

// The field defaults to the mesh's first 3-component attribute. Throws std::invalid_argument
// for a field the mesh lacks or that is not a vector, and for bad seeds.
void ViewPipeline::trace_lines(const storage::TetMesh& mesh, const LineRequest& request) {
  std::string field = request.field;
  if (field.empty()) {
    for (const auto& a : mesh.attributes)
      if (a.info.components == 3) {
        field = a.info.name;
        break;
      }
    if (field.empty()) throw std::invalid_argument("the dataset has no vector field to trace stream lines in");
  }
  const lod::SeedSpec seeds = lod::parse_seeds(request.seeds.empty() ? kDefaultSeeds : request.seeds);
  const std::vector<uint32_t> opposite = pair_faces(mesh.tets).opposite;
  const lod::StreamlineTracer tracer(mesh, opposite, field);
  lod::StreamlineOptions options;
  options.max_steps = request.max_steps;
  LineSet set = line_set_from(tracer.trace(seeds, options), field);
  // coloured over the field's magnitude range over the whole dataset, as the store records it:
  // the same speed the same colour on every trace, and the range a legend can state
  if (const storage::StoreAttribute* a = store_ ? find_attribute(store_->manifest(), field) : nullptr; a && a->max > a->min) {
    set.value_min = a->min;
    set.value_max = a->max;
  }
  lines_ = std::make_shared<const LineSet>(std::move(set));
  traced_ = request;
  selected_for_.reset();
  lines_cut_error_ = cut_estimated_error_;
}

bool ViewPipeline::tensors_stale(const ViewRequest& request) const {
  if (!request.tensors) return false;
  if (!tensors_traced_) return true;
  view::TensorRequest a = *tensors_traced_, b = request.tensor;
  a.point_size = b.point_size = 0;
  return !(a == b);
}

void ViewPipeline::update_tensors(const storage::TetMesh& mesh, const ViewRequest& request, RenderSettings& s) {
  if (tensors_stale(request)) {
    TensorPoints points = renderer::tensor_points(mesh, request.tensor);
    // a derived quantity coloured over its range over the whole dataset, as the store records
    // it: the same value the same colour on every trace, and the range a legend can state
    const std::string derived = points.field + "." + points.color;
    if (const storage::StoreAttribute* a = store_ && !points.by_class ? find_attribute(store_->manifest(), derived) : nullptr; a && a->max > a->min) {
      points.value_min = a->min;
      points.value_max = a->max;
    }
    tensor_points_ = std::make_shared<const TensorPoints>(std::move(points));
    tensors_traced_ = request.tensor;
  }
  if (!request.tensors) return;
  s.tensor_points = tensor_points_;
  s.tensor_point_size = request.tensor.point_size;
}

// The lines into the settings; a box or a click becomes line ids once (a click with the
// camera of the frame it was made on).
void ViewPipeline::apply_lines(const LineRequest& request, RenderSettings& s) {
  if (!selected_for_ || !same_selection(*selected_for_, request)) {
    selection_ = request.selected;
    if (request.select_box) {
      const auto& b = *request.select_box;
      const auto in_box = lines_in_box(*lines_, {b[0], b[1], b[2]}, {b[3], b[4], b[5]});
      selection_.insert(selection_.end(), in_box.begin(), in_box.end());
    }
    if (request.select_pixel) {
      const auto& fraction = *request.select_pixel;  // of the image: the same line at any frame size
      const auto picked = line_at_pixel(*lines_, s.camera, s.width, s.height, fraction[0] * s.width, fraction[1] * s.height);
      selection_.insert(selection_.end(), picked.begin(), picked.end());
    }
    std::sort(selection_.begin(), selection_.end());
    selection_.erase(std::unique(selection_.begin(), selection_.end()), selection_.end());
    const size_t count = lines_->line_count();
    std::erase_if(selection_, [count](uint32_t id) { return id >= count; });  // ids of an earlier trace
    selected_for_ = request;
  }
  s.lines = lines_;
  s.selected_lines = selection_;
  s.line_width = request.line_width;
  s.ghost_opacity = request.ghost_opacity;
  s.halos = request.halos;
  s.flow = request.flow;
  s.depth_correction = request.depth_correction;
  s.dash_phase = request.dash_phase;
}

void ViewPipeline::update_clip(const view::ClipSpec& clip, ViewTimings& timings) {
  const auto start = Clock::now();
  if (clip.empty()) {
    clipped_.reset();
    drawn_generation_ = scene_generation_;
  } else if (!clipped_ || clipped_from_ != scene_generation_ || !(clip_ == clip)) {
    clipped_ = std::make_unique<SceneMesh>(clip_scene(*scene_, clip));
    clip_ = clip;
    clipped_from_ = scene_generation_;
    drawn_generation_ = next_scene_generation++;
  }
  timings.clip_ms = ms_since(start);
}

// The regions of the drawn scene's boundary faces, found when a frame hides some (the surface
// with regions hidden; otherwise no frame pays for them), once per scene: a scene's faces keep
// their regions, so a renderer's buffers built from them stay right.
void ViewPipeline::classify_regions(const ViewRequest& request, ViewTimings& timings) {
  if (!regions_ || !request.surface || request.hidden_regions.empty()) return;
  const auto start = Clock::now();
  if (scene_->boundary_region.size() != scene_->boundary.size()) scene_->boundary_region = regions_->classify(*scene_);
  if (clipped_ && clipped_->boundary_region.size() != clipped_->boundary.size()) {
    std::vector<std::array<double, 4>> planes;  // the cut faces on the clip's planes belong to no region
    for (const view::Plane& p : clip_.half_spaces()) {
      const double n = std::max(1e-300, std::sqrt(p.normal[0] * p.normal[0] + p.normal[1] * p.normal[1] + p.normal[2] * p.normal[2]));
      planes.push_back({p.normal[0] / n, p.normal[1] / n, p.normal[2] / n, p.offset / n});
    }
    clipped_->boundary_region = regions_->classify(*clipped_, planes);
  }
  timings.regions_ms = ms_since(start);
}

RenderSettings ViewPipeline::update(const ViewRequest& request, ViewTimings* timings, const std::function<bool()>& should_stop) {
  RenderSettings s;
  static_cast<view::DrawOptions&>(s) = request;  // drawn as asked, resolved below
  s.use_iso_color_attribute = !request.iso_color_attribute.empty();
  resolve_attribute(s.tf);
  const bool trace = request.lines && (!traced_ || !same_trace(*traced_, request.line));

  s.camera = request.camera ? *request.camera : view::default_camera(bounds_);
  s.camera.aspect = double(s.width) / s.height;
  ViewTimings local;
  ViewTimings& t = timings ? *timings : local;
  if (store_) {
    if (s.iso && s.isovalues.empty() && s.tf.range) s.isovalues = {0.5 * ((*s.tf.range)[0] + (*s.tf.range)[1])};
    if (front_ && !request.segment_cut) {
      update_front(request, s, t, trace);
      return s;
    }
    lod::CutCriteria criteria = lod::criteria_for(*store_, *dag_, s.tf, s.iso ? std::span<const double>(s.isovalues) : std::span<const double>());
    if (!s.iso && !volume_shown(s)) criteria.opacity.clear();
    lod::set_view(criteria, s.camera);
    criteria.unit_distance = s.unit_distance;
    criteria.clip = request.clip.half_spaces();
    criteria.slices = request.slices.planes;
    auto start = Clock::now();
    const auto changes = cut_->update(criteria, request.budget);
    cut_estimated_error_ = changes.estimated_error;
    cut_budget_ = CutBudget{request.budget, changes.tets, changes.budget_limited, changes.over_budget};
    t.cut_ms = ms_since(start);
    start = Clock::now();
    // segments wholly clipped away are not read (a change of the clip may need others)
    std::optional<lod::CutMesh> assembled;
    if (!scene_ || scene_from_front_ || scene_stale_ || step_changed_ || !changes.added.empty() || !changes.removed.empty() || changes.variants_changed || attribute_ != s.tf.attribute || component_ != s.tf.component ||
        iso_color_attribute_ != request.iso_color_attribute || !(assembled_clip_ == criteria.clip)) {
      assembled = lod::assemble_cut(*store_, *cache_, *cut_, false, criteria.clip, should_stop);
      if (assembled->interrupted || (should_stop && should_stop())) {
        scene_stale_ = true;  // the next update assembles whatever its cut is
        t.interrupted = true;
        t.assemble_ms = ms_since(start);
        return s;
      }
      rebuild_scene(assembled->mesh, s.tf, request.iso_color_attribute);
      scene_from_front_ = false;
      step_changed_ = false;
      assembled_clip_ = criteria.clip;
      scene_stale_ = false;
    }
    t.assemble_ms = ms_since(start);
    update_clip(request.clip, t);
    classify_regions(request, t);
    if ((trace || tensors_stale(request)) && !assembled) assembled = lod::assemble_cut(*store_, *cache_, *cut_, false, criteria.clip);
    if (trace) trace_lines(assembled->mesh, request.line);
    if (request.lines) apply_lines(request.line, s);
    update_tensors(assembled ? assembled->mesh : storage::TetMesh{}, request, s);
    return s;
  }
  const auto start = Clock::now();
  if (!scene_ || attribute_ != s.tf.attribute || component_ != s.tf.component || iso_color_attribute_ != request.iso_color_attribute) rebuild_scene(*mesh_, s.tf, request.iso_color_attribute);
  t.assemble_ms = ms_since(start);
  s.tf.attribute = scene_->attribute;
  if (!s.tf.range && !scene_->attribute.empty()) {
    // a whole mesh's range as a store's manifest gives it: the drawn values', a vector's
    // magnitude from 0, so that a transfer function without one ramps its opacity over it
    const auto a = std::find_if(mesh_->attributes.begin(), mesh_->attributes.end(), [&](const storage::Attribute& x) { return x.info.name == scene_->attribute; });
    const double lo = a != mesh_->attributes.end() && a->info.components > 1 && s.tf.component == view::kMagnitude ? 0 : scene_->value_min;
    s.tf.range = std::array<double, 2>{lo, scene_->value_max > lo ? scene_->value_max : lo + 1};
  }
  if (s.iso && s.isovalues.empty()) s.isovalues = {0.5 * (scene_->value_min + scene_->value_max)};
  update_clip(request.clip, t);
  classify_regions(request, t);
  if (trace) trace_lines(*mesh_, request.line);
  if (request.lines) apply_lines(request.line, s);
  update_tensors(*mesh_, request, s);
  return s;
}

Image ViewPipeline::draw(const RenderSettings& settings, Renderer& renderer, uint64_t& held_generation, ViewTimings* timings) {
  ViewTimings local;
  ViewTimings& t = timings ? *timings : local;
  auto start = Clock::now();
  if (held_generation != drawn_generation_) {
    renderer.set_mesh(scene());
    held_generation = drawn_generation_;
  }
  t.upload_ms = ms_since(start);
  start = Clock::now();
  Image image = renderer.render(settings, &t.draw);
  t.draw_ms = ms_since(start);
  return image;
}

Image ViewPipeline::cast(const RenderSettings& settings, ViewTimings* timings, unsigned threads) {
  ViewTimings local;
  ViewTimings& t = timings ? *timings : local;
  if (const std::string what = RayCaster::unsupported(settings); !what.empty()) throw std::invalid_argument("the CPU ray caster does not draw " + what);
  auto start = Clock::now();
  if (!caster_ || caster_generation_ != drawn_generation_) {
    caster_.reset();
    caster_ = std::make_unique<RayCaster>(scene());
    caster_generation_ = drawn_generation_;
  }
  t.upload_ms = ms_since(start);
  start = Clock::now();
  Image image = caster_->render(settings, &t.draw, threads);
  t.draw_ms = ms_since(start);
  return image;
}

ViewFrame ViewPipeline::render(const ViewRequest& request, Renderer& renderer, uint64_t& held_generation) {
  ViewFrame frame;
  frame.settings = update(request, &frame.timings);
  frame.image = draw(frame.settings, renderer, held_generation, &frame.timings);
  frame.tets = scene().tets.size() / 4;
  return frame;
}

}  // namespace tetrascope::renderer
