// cut, render: one view of a store or mesh (camera, transfer function, mode, budget), written
// as the adapted mesh (cut) or as an image (render, through renderer::ViewPipeline, the frame
// pipeline the server's sessions use too).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>

#include "args.h"
#include "commands.h"
#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/field/streamlines.h"
#include "tetrascope/lod/vertex/vertex_front.h"
#include "tetrascope/protocol/planes.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/renderer/ray_caster.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/renderer/view_frame.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/tensor.h"
#include "tetrascope/storage/time_steps.h"
#include "tetrascope/storage/vtk_writer.h"

namespace tetrascope::apps {
namespace {

namespace r = renderer;
using Clock = std::chrono::steady_clock;

constexpr uint64_t kCutCacheBytes = 1ull << 30;  // segments mapped while a cut is assembled
constexpr uint32_t kDefaultRenderBudget = 1000000;
constexpr int kDefaultQuality = 90;

double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

struct OpenedStore {
  std::unique_ptr<storage::Store> store;
  std::unique_ptr<lod::Dag> dag;
};

OpenedStore open_multires(const std::string& path, const std::string& single_level_hint) {
  OpenedStore s;
  s.store = storage::Store::open(path);
  s.dag = lod::open_dag(*s.store);
  if (!s.dag) throw std::invalid_argument(path + " is a single-level store" + single_level_hint);
  return s;
}

// --clip nx,ny,nz,d (repeatable, "!" in front or ",invert" after inverts), --clip-box
// x0,y0,z0,x1,y1,z1, --crinkle, --slice nx,ny,nz,d (repeatable), --slice-edges, --slice-flat: taken out of
// the arguments before Args (which keeps one value an option) sees them.
Arguments take_plane_options(const Arguments& raw, protocol::ClipSpec& clip, protocol::SliceSpec* slices) {
  Arguments rest;
  for (size_t i = 0; i < raw.size(); ++i) {
    const std::string& a = raw[i];
    const bool valued = a == "--clip" || a == "--clip-box" || (slices && a == "--slice");
    if (valued && i + 1 >= raw.size()) throw std::invalid_argument(a + " needs a value (nx,ny,nz,d)");
    if (a == "--clip") {
      if (clip.planes.size() == protocol::kMaxClipPlanes) throw std::invalid_argument("--clip: at most " + std::to_string(protocol::kMaxClipPlanes) + " clip planes (use --clip-box for a box)");
      try {
        clip.planes.push_back(protocol::parse_plane_text(raw[++i], true));
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("--clip: ") + e.what());
      }
    } else if (a == "--clip-box") {
      const std::vector<double> v = number_list("--clip-box", raw[++i]);
      if (v.size() != 6) throw std::invalid_argument("--clip-box expects x0,y0,z0,x1,y1,z1");
      protocol::ClipBox box{{v[0], v[1], v[2]}, {v[3], v[4], v[5]}};
      for (int k = 0; k < 3; ++k)
        if (!(box.min[k] <= box.max[k])) throw std::invalid_argument("--clip-box: min exceeds max on axis " + std::string(1, "xyz"[k]));
      clip.box = box;
    } else if (a == "--crinkle") {
      clip.crinkle = true;
    } else if (slices && a == "--slice") {
      if (slices->planes.size() == protocol::kMaxSlicePlanes) throw std::invalid_argument("--slice: at most " + std::to_string(protocol::kMaxSlicePlanes) + " slice planes");
      try {
        slices->planes.push_back(protocol::parse_plane_text(raw[++i], false).plane);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("--slice: ") + e.what());
      }
    } else if (slices && a == "--slice-edges") {
      slices->edges = true;
    } else if (slices && a == "--slice-flat") {
      slices->lit = false;
    } else {
      rest.push_back(a);
    }
  }
  if (clip.crinkle && clip.empty()) throw std::invalid_argument("--crinkle needs a --clip plane or a --clip-box");
  return rest;
}

// What `render` was asked for, beyond the view itself.
struct RenderOptions {
  r::ViewRequest view;
  std::string mode, output, camera_text, compare;
  std::string hide_regions;  // --hide-regions: region ids, or "box"
  std::optional<std::array<double, 2>> select_pixel;  // pixels, made fractions once the size is known
  int quality = kDefaultQuality;
  uint32_t orbit = 0;
  uint32_t threads = 0;  // the CPU ray caster's (0: every core)
  bool reference = false, json = false;
};

// The stream-line options of `render` (modes with lines): --field, --seeds, the selection and
// the style. Seeds and numbers are checked here; the field by the dataset when traced.
void line_options(const Args& args, RenderOptions& o) {
  r::LineRequest& line = o.view.line;
  const char* kLineOptions[] = {"--field", "--seeds", "--max-steps", "--select-box", "--select-lines", "--select-pixel", "--ghost-opacity", "--line-width", "--flow", "--no-halos", "--depth-correction"};
  if (!o.view.lines) {
    for (const char* name : kLineOptions)
      if (args.has(name)) throw std::invalid_argument(std::string(name) + " needs a mode with lines (e.g. --mode dvr+lines)");
    return;
  }
  line.field = args.get("--field");
  line.seeds = args.get("--seeds");
  if (!line.seeds.empty()) lod::parse_seeds(line.seeds);  // a bad spec fails here, before the mesh is read
  line.max_steps = args.number("--max-steps", line.max_steps);
  if (line.max_steps == 0) throw std::invalid_argument("--max-steps must be at least 1");
  if (args.has("--select-box")) {
    const std::vector<double> b = number_list("--select-box", args.get("--select-box"));
    if (b.size() != 6 || b[0] > b[3] || b[1] > b[4] || b[2] > b[5]) throw std::invalid_argument("--select-box expects x0,y0,z0,x1,y1,z1 with the low corner first");
    line.select_box = std::array<double, 6>{b[0], b[1], b[2], b[3], b[4], b[5]};
  }
  if (args.has("--select-lines")) {
    for (double id : number_list("--select-lines", args.get("--select-lines"))) {
      if (id < 0 || id != std::floor(id) || id > 4294967295.0) throw std::invalid_argument("--select-lines expects line ids (whole numbers)");
      line.selected.push_back(static_cast<uint32_t>(id));
    }
  }
  if (args.has("--select-pixel")) {
    const std::vector<double> p = number_list("--select-pixel", args.get("--select-pixel"));
    if (p.size() != 2 || p[0] < 0 || p[1] < 0) throw std::invalid_argument("--select-pixel expects x,y (pixels from the top left)");
    o.select_pixel = std::array<double, 2>{p[0], p[1]};
  }
  if (args.has("--ghost-opacity")) {
    line.ghost_opacity = args.real("--ghost-opacity");
    if (!(line.ghost_opacity > 0 && line.ghost_opacity <= 1)) throw std::invalid_argument("--ghost-opacity must be in (0, 1]");
  }
  if (args.has("--line-width")) {
    line.line_width = args.real("--line-width");
    if (!(line.line_width >= 1 && line.line_width <= r::kMaxLineWidth)) throw std::invalid_argument("--line-width must be 1 to 32 pixels");
  }
  if (args.has("--flow")) {
    const std::string flow = args.get("--flow");
    if (flow == "arrows") line.flow = r::FlowStyle::arrows;
    else if (flow == "dashes") line.flow = r::FlowStyle::dashes;
    else if (flow == "none") line.flow = r::FlowStyle::none;
    else throw std::invalid_argument("--flow expects arrows, dashes or none, got '" + flow + "'");
  }
  line.halos = !args.has("--no-halos");
  if (args.has("--depth-correction")) {
    line.depth_correction = args.real("--depth-correction");
    if (!(line.depth_correction >= 0 && line.depth_correction <= 1)) throw std::invalid_argument("--depth-correction must be in [0, 1]");
  }
}

// The tensor options of `render` (modes with tensors): the field, seeding, thresholds, colour
// and splat size, checked here; the field by the dataset when traced.
void tensor_options(const Args& args, RenderOptions& o) {
  view::TensorRequest& t = o.view.tensor;
  const char* kTensorOptions[] = {"--tensor", "--tube-cells", "--surface-cells", "--tensor-min-cl", "--tensor-min-cp", "--tensor-color", "--tensor-point-size"};
  if (!o.view.tensors) {
    for (const char* name : kTensorOptions)
      if (args.has(name)) throw std::invalid_argument(std::string(name) + " needs a mode with tensors (e.g. --mode dvr+tensors)");
    return;
  }
  t.field = args.get("--tensor");
  t.tube_cells = static_cast<uint32_t>(args.number("--tube-cells", t.tube_cells));
  t.surface_cells = static_cast<uint32_t>(args.number("--surface-cells", t.surface_cells));
  if (t.tube_cells > lod::kMaxDenseResolution || t.surface_cells > lod::kMaxDenseResolution) throw std::invalid_argument("--tube-cells and --surface-cells must be 0 to 256");
  if (args.has("--tensor-min-cl")) t.min_linear = args.real("--tensor-min-cl");
  if (args.has("--tensor-min-cp")) t.min_planar = args.real("--tensor-min-cp");
  if (!(t.min_linear >= 0 && t.min_linear <= 1 && t.min_planar >= 0 && t.min_planar <= 1))
    throw std::invalid_argument("--tensor-min-cl and --tensor-min-cp are anisotropy measures between 0 and 1");
  t.color = args.get("--tensor-color", "class");
  if (args.has("--tensor-point-size")) {
    t.point_size = args.real("--tensor-point-size");
    if (!(t.point_size >= 0 && t.point_size <= r::kMaxPointSize)) throw std::invalid_argument("--tensor-point-size must be 0 (covering) to 64 pixels");
  }
}

RenderOptions render_options(const Args& args) {
  RenderOptions o;
  r::ViewRequest& v = o.view;
  o.mode = args.get("--mode", "dvr");
  try {
    const protocol::Modes modes = protocol::parse_modes(o.mode);
    v.dvr = modes.dvr;
    v.iso = modes.iso;
    v.surface = modes.surface;
    v.lines = modes.lines;
    v.points = modes.points;
    v.tensors = modes.tensors;
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--mode: ") + e.what());
  }
  line_options(args, o);
  tensor_options(args, o);
  if (args.has("--lod")) {
    const std::string lod = args.get("--lod");
    if (lod != "vertices" && lod != "segments") throw std::invalid_argument("--lod must be 'vertices' (single vertex splits, when the store has them) or 'segments' (the segments' DAG)");
    v.segment_cut = lod == "segments";
  }
  v.wireframe = args.has("--wireframe");
  v.box = args.has("--box");
  o.hide_regions = args.get("--hide-regions");
  if (args.has("--hide-regions") && !v.surface) throw std::invalid_argument("--hide-regions needs a mode with surface (e.g. --mode surface)");
  if (args.has("--tf")) v.tf = read_tf(args.get("--tf"));
  if (args.has("--attribute")) v.tf.attribute = args.get("--attribute");
  if (args.has("--component")) v.tf.component = parse_component(args.get("--component"));
  if (args.has("--size")) {
    const ImageSize size = parse_size("--size", args.get("--size"), 1, r::kMaxImageSide);
    v.width = size.width;
    v.height = size.height;
  } else {
    v.width = v.height = r::RenderSettings{}.width;
  }
  o.output = args.get("--output");
  std::string ext = std::filesystem::path(o.output).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") throw std::invalid_argument(o.output + ": the output must end in .png, .jpg or .jpeg");
  o.quality = static_cast<int>(args.number("--quality", kDefaultQuality));
  if (o.quality < 1 || o.quality > protocol::kMaxJpegQuality) throw std::invalid_argument("--quality must be 1 to 100");
  if (args.has("--unit-distance")) v.unit_distance = args.real("--unit-distance");
  if (const std::string method = args.get("--volume", "exact"); method == "projected") v.volume = r::VolumeMethod::projected;
  else if (method != "exact") throw std::invalid_argument("--volume must be exact or projected");
  if (args.has("--iso-opacity")) v.iso_opacity = args.real("--iso-opacity");
  if (args.has("--iso")) v.isovalues = number_list("--iso", args.get("--iso"));
  if (v.points) v.point_isovalues = v.isovalues;
  if (v.points && args.has("--point-size")) {
    v.point_size = args.real("--point-size");
    if (!(v.point_size >= 0 && v.point_size <= r::kMaxPointSize)) throw std::invalid_argument("--point-size must be 0 (covering) to 64 pixels");
  }
  if (!v.points && (args.has("--point-size") || args.has("--point-target"))) throw std::invalid_argument("--point-size and --point-target need a mode with points");
  if (args.has("--point-target")) {
    v.point_target = args.number("--point-target", 0);
    if (v.point_target == 0) throw std::invalid_argument("--point-target must be at least 1");
  }
  o.compare = args.get("--compare");
  v.iso_color_attribute = args.get("--iso-color");
  if (o.select_pixel) {
    if ((*o.select_pixel)[0] > v.width || (*o.select_pixel)[1] > v.height) throw std::invalid_argument("--select-pixel lies outside the image");
    v.line.select_pixel = std::array<double, 2>{(*o.select_pixel)[0] / v.width, (*o.select_pixel)[1] / v.height};
  }
  o.camera_text = args.get("--camera");
  o.orbit = args.number("--orbit", 0);
  o.threads = args.number("--threads", 0);
  o.reference = args.has("--reference");
  o.json = args.has("--json");
  return o;
}

// The camera of orbit frame f of n: around the box centre at elevation 20°.
view::Camera orbit_camera(uint32_t f, uint32_t n, const storage::Bounds& bounds, double aspect) {
  view::Camera camera = view::parse_camera("azimuth=" + std::to_string(30 + 360.0 * f / n) + ",elevation=20", bounds);
  camera.aspect = aspect;
  return camera;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// --hide-regions: the boundary regions the surface leaves out, by id or name (comma-separated;
// a name as `info` lists it, from the input's tags) or "box" (every region on the domain's
// bounding box, as the viewer's Bodies only), checked against `regions`.
void hide_regions(const std::string& text, const r::RegionMap& regions, r::ViewRequest& v) {
  const auto& list = regions.regions();
  if (text == "box") {
    for (const auto& region : list)
      if (region.touches_domain_box) v.hidden_regions.push_back(region.id);
    return;
  }
  const std::string has = list.empty() ? "none" : std::to_string(list.size()) + ": 0 to " + std::to_string(list.size() - 1);
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    start = comma + 1;
    const auto named = std::find_if(list.begin(), list.end(), [&](const r::BoundaryRegion& region) { return !region.name.empty() && region.name == item; });
    if (named != list.end()) {
      v.hidden_regions.push_back(named->id);
      continue;
    }
    double id = -1;
    try {
      id = number_list("--hide-regions", item).at(0);
    } catch (const std::exception&) {
      throw std::invalid_argument("--hide-regions: no region named '" + item + "' (the boundary has " + has + "; names as `tetrascope info` lists them; or 'box')");
    }
    if (!(id >= 0 && id == std::floor(id) && id < double(list.size()))) {
      char shown[32];
      std::snprintf(shown, sizeof shown, "%g", id);
      throw std::invalid_argument(std::string("--hide-regions: no region ") + shown + " (the boundary has " + has + "; or 'box')");
    }
    v.hidden_regions.push_back(static_cast<uint32_t>(id));
  }
  std::sort(v.hidden_regions.begin(), v.hidden_regions.end());
  v.hidden_regions.erase(std::unique(v.hidden_regions.begin(), v.hidden_regions.end()), v.hidden_regions.end());
}

nlohmann::json regions_report(const r::RegionMap& regions, const r::ViewRequest& v) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& region : regions.regions())
    out.push_back({{"id", region.id}, {"name", region.name}, {"source", r::region_source_name(regions.source())}, {"triangles", region.triangles}, {"area", region.area}, {"touches_domain_box", region.touches_domain_box},
                   {"hidden", std::binary_search(v.hidden_regions.begin(), v.hidden_regions.end(), region.id)}});
  return out;
}

nlohmann::json render_report(const RenderOptions& o, const r::RenderSettings& settings, const r::SceneMesh& scene, const std::string& description,
                             const std::vector<r::FrameTimings>& frames, double reference_db) {
  auto median_of = [&](double r::FrameTimings::*field) {
    std::vector<double> v;
    for (const auto& t : frames) v.push_back(t.*field);
    return median(v);
  };
  const auto& last = frames.back();
  nlohmann::json j = {{"output", o.output}, {"width", settings.width}, {"height", settings.height}, {"mode", o.mode}, {"renderer", description},
                      {"tets", scene.tets.size() / 4}, {"tets_drawn", last.tets_drawn}, {"tets_skipped", last.tets_skipped},
                      {"iso_triangles", last.iso_triangles}, {"frames", frames.size()},
                      {"median_ms", median_of(&r::FrameTimings::total_ms)}, {"median_sort_ms", median_of(&r::FrameTimings::sort_ms)},
                      {"median_draw_ms", median_of(&r::FrameTimings::draw_ms)}, {"median_classify_ms", median_of(&r::FrameTimings::classify_ms)}, {"median_cpu_ms", median_of(&r::FrameTimings::cpu_ms)}, {"median_readback_ms", median_of(&r::FrameTimings::readback_ms)},
                      {"median_encode_ms", median_of(&r::FrameTimings::encode_ms)}, {"reference_psnr_db", reference_db},
                      {"legend", {{"attribute", scene.attribute}, {"component", scene.component == view::kMagnitude ? "magnitude" : std::string(view::kComponentNames[size_t(scene.component)])}, {"colormap", settings.tf.colormap},
                                  {"range", {settings.tf.range ? (*settings.tf.range)[0] : scene.value_min, settings.tf.range ? (*settings.tf.range)[1] : scene.value_max}}}}};
  if (settings.use_iso_color_attribute)
    j["legend"]["isosurfaces"] = {{"attribute", scene.iso_color_attribute}, {"colormap", settings.tf.colormap}, {"range", {scene.iso_color_min, scene.iso_color_max}}};
  return j;
}

// The CPU reference ray caster of `settings` (DVR only) next to the output (and as float
// colours in OUT.reference.pfm), and its PSNR.
double write_reference(const RenderOptions& o, const r::SceneMesh& scene, const r::RenderSettings& settings, const r::Image& image) {
  if (!settings.dvr || settings.surface || settings.use_iso_color_attribute)
    throw std::invalid_argument("--reference compares volume rendering only (--mode dvr or dvr+iso, isosurfaces coloured by value, with --clip and --slice)");
  const r::Image reference = r::reference_render(scene, settings);
  std::filesystem::path path(o.output);
  path.replace_filename(path.stem().string() + ".reference" + path.extension().string());
  r::write_image(path.string(), reference, o.quality);
  path.replace_extension(".pfm");  // the same image unrounded, for measurements past 8 bits
  r::write_pfm(path.string(), reference);
  return r::psnr(image, reference);
}

// --step N or --time T: a step of a time series, its values and a segment cache that gives
// them (step 0: the store's own values and no cache of its own).
struct ChosenStep {
  uint32_t step = 0;
  std::shared_ptr<const storage::TimeSteps> steps;
  std::shared_ptr<const std::vector<float>> values;  // null: step 0
  std::unique_ptr<storage::SegmentCache> cache;      // the step's segments (step > 0)
};

void choose_step(const Args& args, const storage::Store& store, ChosenStep& out) {
  if (!args.has("--step") && !args.has("--time")) return;
  if (args.has("--step") && args.has("--time")) throw std::invalid_argument("--step or --time, not both");
  out.steps = storage::TimeSteps::open(store);
  if (!out.steps) throw std::invalid_argument(store.path().string() + " holds one time step; --step and --time choose a step of a time series");
  if (args.has("--step")) {
    out.step = args.number("--step", 0);
    if (out.step >= out.steps->count())
      throw std::invalid_argument("--step " + std::to_string(out.step) + ": the series has steps 0.." + std::to_string(out.steps->count() - 1));
  } else {
    out.step = out.steps->step_at_time(args.real("--time"));
  }
  out.values = out.steps->values(out.step);
  if (!out.values) return;
  const storage::Store* s = &store;
  std::shared_ptr<const storage::TimeSteps> steps = out.steps;
  std::shared_ptr<const std::vector<float>> values = out.values;
  out.cache = std::make_unique<storage::SegmentCache>(store, std::make_shared<storage::SegmentPool>(kCutCacheBytes), [s, steps, values](std::shared_ptr<const storage::MappedSegment> segment) {
    return storage::with_step_values(std::move(segment), s->manifest(), steps->layout(), *values);
  });
}

// `tetrascope cut` on the store's vertex hierarchy: the front for the view under the budget.
int write_front_cut(const Args& args, const lod::VertexHierarchy& vertices, const view::TransferFunction& tf, std::span<const double> isovalues,
                    const lod::CutCriteria& view, const protocol::ClipSpec& clip, uint64_t budget, const storage::StoreManifest& manifest, const ChosenStep& step) {
  if (step.values && step.steps->layout().collapses != vertices.collapse_count())
    throw storage::TimeStepsError("steps.bin: " + std::to_string(step.steps->layout().collapses) + " collapsed vertices, vertices.bin has " + std::to_string(vertices.collapse_count()));
  lod::FrontCriteria criteria = lod::front_criteria(vertices, tf, isovalues);
  criteria.camera = view.camera;
  criteria.clip = view.clip;
  lod::VertexFront front(vertices);
  const auto start = Clock::now();
  const lod::FrontChanges changes = front.update(criteria, budget);
  const double update_ms = ms_since(start);
  storage::TetMesh mesh = front.mesh(nullptr, step.values ? step.values->data() : nullptr);
  for (storage::Attribute& a : mesh.attributes)  // tensors and their derived scalars, as the manifest keeps them
    for (const storage::StoreAttribute& m : manifest.attributes)
      if (m.name == a.info.name) a.info = {m.name, m.components, m.kind, m.positive_semidefinite, m.derived_from};
  storage::refresh_tensor_attributes(mesh);  // the front's collapsed vertices: PSD kept, derived scalars from their tensors
  if (!clip.empty()) mesh = r::clip_mesh(mesh, clip);
  storage::write_vtk(args.get("--output"), mesh, "tetrascope cut of " + std::filesystem::path(args.positionals()[0]).filename().string());
  nlohmann::json j = {{"tets", mesh.tet_count()}, {"vertices", mesh.vertex_count()}, {"budget", budget}, {"by", "vertices"}, {"splits", changes.splits},
                      {"budget_limited", changes.budget_limited}, {"over_budget", changes.over_budget}, {"complete", changes.complete},
                      {"forced_tets", changes.forced_tets}, {"unseen_tets", changes.unseen_tets}, {"refused_splits", changes.refused}, {"run_time_valid", changes.run_time_valid}, {"estimated_error", changes.estimated_error}, {"update_ms", update_ms}};
  if (args.has("--json")) std::cout << j.dump(2) << "\n";
  else std::printf("%s: %zu tets, %zu vertices by %u vertex splits (budget %llu%s); cut update %.2f ms\n", args.get("--output").c_str(), mesh.tet_count(), mesh.vertex_count(),
                   changes.splits, static_cast<unsigned long long>(budget), changes.budget_limited ? ", budget reached" : "", update_ms);
  return 0;
}

}  // namespace

int run_cut(const Arguments& all) {
  protocol::ClipSpec clip;
  const Arguments raw = take_plane_options(all, clip, nullptr);
  Args args(raw, {"--json"}, {"--output", "--budget", "--camera", "--size", "--tf", "--iso", "--attribute", "--lod", "--step", "--time"});
  if (args.positionals().size() != 1 || !args.has("--output") || !args.has("--budget")) {
    std::fprintf(stderr, "usage: tetrascope cut STORE --budget N -o OUT.vtk [--lod vertices|segments] [--camera C] [--size WxH] [--tf TF.json] [--attribute A] [--iso v1,v2] [--clip nx,ny,nz,d ...] [--clip-box x0,y0,z0,x1,y1,z1] [--crinkle] [--step N | --time T] [--json]\n");
    return 2;
  }
  const OpenedStore opened = open_multires(args.positionals()[0], " (made by segment); run tetrascope preprocess for a multiresolution store");
  const storage::Store& store = *opened.store;
  ChosenStep step;
  choose_step(args, store, step);
  const uint64_t budget = args.number("--budget", 0);
  if (budget == 0) throw std::invalid_argument("--budget must be at least 1");
  view::TransferFunction tf;
  if (args.has("--tf")) tf = read_tf(args.get("--tf"));
  if (args.has("--attribute")) tf.attribute = args.get("--attribute");
  const std::vector<double> isovalues = args.has("--iso") ? number_list("--iso", args.get("--iso")) : std::vector<double>{};
  lod::CutCriteria criteria = lod::criteria_for(store, *opened.dag, tf, isovalues);
  if (args.has("--camera")) {
    view::Camera camera = view::parse_camera(args.get("--camera"), store.manifest().bounds);
    if (args.has("--size")) {
      const ImageSize size = parse_size("--size", args.get("--size"), 1, r::kMaxImageSide);
      camera.aspect = double(size.width) / size.height;
    }
    lod::set_view(criteria, camera);
  }
  criteria.clip = clip.half_spaces();
  const auto vertices = args.get("--lod", "vertices") == "vertices" ? lod::open_vertex_hierarchy(store.path()) : nullptr;
  if (vertices) return write_front_cut(args, *vertices, tf, isovalues, criteria, clip, budget, store.manifest(), step);
  lod::Cut cut(*opened.dag);
  const std::unique_ptr<lod::Variants> variants = lod::Variants::open(store, *opened.dag);  // as render shows the cut
  cut.attach_variants(variants.get());
  const auto start = Clock::now();
  const auto changes = cut.update(criteria, budget);
  const double update_ms = ms_since(start);
  storage::SegmentCache cache(store, kCutCacheBytes);
  auto mesh = lod::assemble_cut(store, step.cache ? *step.cache : cache, cut, false, criteria.clip);
  if (!clip.empty()) mesh.mesh = r::clip_mesh(mesh.mesh, clip);
  storage::write_vtk(args.get("--output"), mesh.mesh, "tetrascope cut of " + std::filesystem::path(args.positionals()[0]).filename().string());
  nlohmann::json j = {{"tets", mesh.mesh.tet_count()}, {"vertices", mesh.mesh.vertex_count()}, {"patches", mesh.patches.size()}, {"budget", budget},
                      {"refinements", changes.refinements}, {"forced_refinements", changes.forced_refinements}, {"coarsenings", changes.coarsenings},
                      {"budget_limited", changes.budget_limited}, {"estimated_error", changes.estimated_error}, {"update_ms", update_ms},
                      {"variant_segments", mesh.variant_segments.size()}, {"variant_extra_tets", cut.variant_extra_tets()}};
  if (args.has("--json")) std::cout << j.dump(2) << "\n";
  else std::printf("%s: %zu tets, %zu vertices from %zu patches and %zu segment variants (budget %llu%s); cut update %.2f ms\n", args.get("--output").c_str(),
                   mesh.mesh.tet_count(), mesh.mesh.vertex_count(), mesh.patches.size(), mesh.variant_segments.size(), static_cast<unsigned long long>(budget),
                   changes.budget_limited ? ", budget reached" : "", update_ms);
  return 0;
}

namespace {

// What the cut, the stream lines, the points and the tensor field of a render came to, in its
// JSON report.
void add_pipeline_report(nlohmann::json& j, r::ViewPipeline& p, const r::RenderSettings& settings, const r::FrameTimings& last, bool segment_cut) {
  if (auto error = p.cut_estimated_error()) j["cut_estimated_error"] = *error;
  if (const auto budget = p.cut_budget()) {
    j["cut"] = {{"budget", budget->budget}, {"tets", budget->tets}, {"budget_used", budget->budget ? double(budget->tets) / double(budget->budget) : 0.0},
                {"budget_limited", budget->budget_limited}, {"over_budget", budget->over_budget}, {"complete", budget->complete},
                {"by", p.front() && !segment_cut ? "vertices" : "segments"}};
    if (p.front() && !segment_cut) {
      j["cut"]["forced_tets"] = budget->forced_tets;
      j["cut"]["unseen_tets"] = budget->unseen_tets;
      j["cut"]["refused_splits"] = budget->refused_splits;
      j["cut"]["run_time_valid"] = budget->run_time_valid;
    }
    // below the coarsest level the cut cannot go: said, not drawn silently
    if (budget->over_budget)
      std::fprintf(stderr, "tetrascope render: the store's coarsest cut holds %llu tets, above the budget of %llu; drawn as it is\n",
                   static_cast<unsigned long long>(budget->tets), static_cast<unsigned long long>(budget->budget));
  }
  if (const auto lines = p.lines()) {
    j["lines"] = {{"field", lines->field}, {"count", lines->line_count()}, {"points", lines->point_count()}, {"selected", settings.selected_lines.size()},
                  {"segments_opaque", last.line_segments_opaque}, {"segments_ghosted", last.line_segments_ghosted}};
    if (auto error = p.lines_cut_error()) j["lines"]["cut_estimated_error"] = *error;
  }
  if (settings.points) j["points"] = last.points;
  if (const auto t = settings.tensor_points) {
    nlohmann::json legend = {{"by_class", t->by_class}, {"color", t->color}};
    if (!t->by_class) legend["range"] = {t->value_min, t->value_max};
    j["tensors"] = {{"field", t->field}, {"tubes", t->tubes}, {"surfaces", t->surfaces}, {"tube_points", t->tube_points}, {"surface_points", t->surface_points},
                    {"surface_triangles", t->surface_triangles}, {"spacing", t->spacing}, {"trace_ms", t->trace_ms}, {"legend", legend}};
  }
}

}  // namespace

int run_render(const Arguments& all) {
  protocol::ClipSpec clip;
  protocol::SliceSpec slices;
  const Arguments raw = take_plane_options(all, clip, &slices);
  Args args(raw, {"--json", "--wireframe", "--box", "--reference", "--no-halos"},
            {"--output", "--mode", "--attribute", "--component", "--tf", "--iso", "--camera", "--size", "--budget", "--quality", "--orbit", "--unit-distance", "--iso-opacity", "--iso-color",
             "--field", "--seeds", "--max-steps", "--select-box", "--select-lines", "--select-pixel", "--ghost-opacity", "--line-width", "--flow", "--depth-correction", "--point-size",
             "--point-target", "--compare", "--volume", "--lod", "--backend", "--hide-regions", "--tensor", "--tube-cells", "--surface-cells", "--tensor-min-cl",
             "--tensor-min-cp", "--tensor-color", "--tensor-point-size", "--step", "--time", "--threads"});
  if (args.positionals().size() != 1 || !args.has("--output")) {
    std::fprintf(stderr, "usage: tetrascope render MESH|STORE -o OUT.png|jpg [--mode dvr|iso|surface|lines|points|slice and combinations such as dvr+lines] [--attribute A] [--component magnitude|x|y|z] [--tf TF.json] [--iso v1,v2] [--camera C] [--size WxH] [--budget TETS] [--lod vertices|segments] [--quality Q] [--volume exact|projected] [--backend gl|cpu|auto] [--threads N] [--wireframe] [--box] [--hide-regions IDS|NAMES|box] [--step N | --time T] [--orbit N] [--reference] [--json]\n"
                 "       planes: [--clip nx,ny,nz,d ...] [--clip-box x0,y0,z0,x1,y1,z1] [--crinkle] [--slice nx,ny,nz,d ...] [--slice-edges] [--slice-flat]\n"
                 "       lines: [--field V] [--seeds SPEC] [--max-steps S] [--select-box x0,y0,z0,x1,y1,z1] [--select-lines 1,2] [--select-pixel x,y] [--ghost-opacity A] [--line-width PX] [--flow arrows|dashes|none] [--no-halos] [--depth-correction C]\n"
                 "       points: [--iso v1,v2,...] [--point-size PX] [--point-target N]; [--compare OTHER.png] reports the PSNR against another image\n"
                 "       tensors: [--tensor T] [--tube-cells N] [--surface-cells N] [--tensor-min-cl C] [--tensor-min-cp C] [--tensor-color class|lambda1|...|von_mises|fa|cl|cp|cs] [--tensor-point-size PX]\n");
    return 2;
  }
  RenderOptions o = render_options(args);
  o.view.clip = clip;
  o.view.slices = slices;
  // the mesh: the cut of a multiresolution store for this view, or a whole mesh file
  const std::string input = args.positionals()[0];
  OpenedStore opened;
  std::unique_ptr<storage::SegmentCache> cache;
  ChosenStep step;  // before the pipeline, which reads its cache
  std::unique_ptr<r::ViewPipeline> pipeline;
  std::shared_ptr<const r::RegionMap> regions;  // found only for --hide-regions
  if (std::filesystem::is_directory(input)) {
    opened = open_multires(input, "; render the mesh file or preprocess it");
    cache = std::make_unique<storage::SegmentCache>(*opened.store, kCutCacheBytes);
    pipeline = std::make_unique<r::ViewPipeline>(*opened.store, *opened.dag, *cache, o.view.segment_cut ? nullptr : lod::open_vertex_hierarchy(opened.store->path()));
    choose_step(args, *opened.store, step);
    if (step.cache) pipeline->set_step(step.step, *step.cache, step.values);
    o.view.budget = args.number("--budget", kDefaultRenderBudget);
    if (args.has("--hide-regions")) regions = r::RegionMap::of_store(*opened.store, *opened.dag, kCutCacheBytes);
  } else {
    if (args.has("--budget")) throw std::invalid_argument("--budget applies to a multiresolution store; a mesh file renders whole");
    if (args.has("--step") || args.has("--time")) throw std::invalid_argument("--step and --time choose a step of a preprocessed time series (a store)");
    storage::TetMesh mesh = storage::load_mesh(input);
    if (args.has("--hide-regions")) regions = r::RegionMap::tagged(mesh, mesh.face_tags);
    pipeline = std::make_unique<r::ViewPipeline>(std::move(mesh));
  }
  if (regions) {
    hide_regions(o.hide_regions, *regions, o.view);
    pipeline->set_regions(regions);
  }
  if (!o.camera_text.empty()) o.view.camera = view::parse_camera(o.camera_text, pipeline->bounds());
  r::ViewTimings update_timings;  // the one-off cost of this view: cut, assembly, clip
  const r::RenderSettings settings = pipeline->update(o.view, &update_timings);
  // The context stays up to exit, on every path: Mesa's driver, unloaded by eglTerminate,
  // would leave allocations behind that leak checkers report against us.
  static r::Renderer* renderer = nullptr;  // reachable from here: not a leak
  // the backend: the GL renderer, the CPU ray caster, or (auto) the caster where the only
  // EGL device is software and the caster draws everything asked for
  const std::string backend = args.get("--backend", "gl");
  if (!r::known_backend(backend)) throw std::invalid_argument("--backend: gl, cpu or auto");
  const std::string cpu_lacks = r::RayCaster::unsupported(settings);
  if (backend == "cpu" && !cpu_lacks.empty()) throw std::invalid_argument("--backend cpu: the CPU ray caster does not draw " + cpu_lacks);
  bool cpu = backend == "cpu";
  if (!cpu) {
    renderer = r::Renderer::create().release();
    cpu = backend == "auto" && cpu_lacks.empty() && r::software_renderer(renderer->description());
  }
  uint64_t held_scene = 0;
  const std::string extension = std::filesystem::path(o.output).extension().string();
  const bool jpeg = extension == ".jpg" || extension == ".jpeg";  // timing only: write_image picks the codec
  std::vector<r::FrameTimings> frames;
  r::RenderSettings frame = settings;
  r::Image image;
  for (uint32_t f = 0; f < std::max(1u, o.orbit); ++f) {
    if (o.orbit) frame.camera = orbit_camera(f, o.orbit, pipeline->bounds(), settings.camera.aspect);
    r::ViewTimings t;
    image = cpu ? pipeline->cast(frame, &t, o.threads) : pipeline->draw(frame, *renderer, held_scene, &t);
    const auto encode_start = Clock::now();
    const auto bytes = jpeg ? r::encode_jpeg(image, o.quality) : r::encode_png(image);
    t.draw.encode_ms = ms_since(encode_start);
    t.draw.total_ms += t.draw.encode_ms;
    frames.push_back(t.draw);
    if (o.orbit && !o.json)
      std::printf("frame %3u  sort %7.2f  draw %8.2f  readback %6.2f  encode %6.2f  total %8.2f ms  (%llu tets drawn, %llu skipped)\n", f, t.draw.sort_ms, t.draw.draw_ms,
                  t.draw.readback_ms, t.draw.encode_ms, t.draw.total_ms, static_cast<unsigned long long>(t.draw.tets_drawn), static_cast<unsigned long long>(t.draw.tets_skipped));
  }
  r::write_image(o.output, image, o.quality);
  const double reference_db = o.reference ? write_reference(o, pipeline->scene(), frame, image) : -1;
  const std::string description = cpu ? "tetrascope CPU ray caster (" + std::to_string(o.threads ? o.threads : std::max(1u, std::thread::hardware_concurrency())) + " threads)" : renderer->description();
  nlohmann::json j = render_report(o, settings, pipeline->scene(), description, frames, reference_db);
  j["backend"] = cpu ? "cpu" : "gl";
  add_pipeline_report(j, *pipeline, settings, frames.back(), o.view.segment_cut);
  if (regions) j["regions"] = regions_report(*regions, o.view);
  if (!o.compare.empty()) j["compare_psnr_db"] = r::psnr(image, r::read_png(o.compare));
  j["update"] = {{"cut_ms", update_timings.cut_ms}, {"assemble_ms", update_timings.assemble_ms}, {"clip_ms", update_timings.clip_ms}};
  if (o.json) std::cout << j.dump() << "\n";
  else std::printf("%s: %ux%u %s of %zu tets (%s), median %.1f ms a frame\n", o.output.c_str(), settings.width, settings.height, o.mode.c_str(),
                   pipeline->scene().tets.size() / 4, pipeline->scene().attribute.c_str(), j["median_ms"].get<double>());
  return 0;
}

}  // namespace tetrascope::apps
