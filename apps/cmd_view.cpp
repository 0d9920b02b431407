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

#include "args.h"
#include "commands.h"
#include "tetrascope/lod/cut.h"
#include "tetrascope/lod/dag.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/renderer/view_frame.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store.h"
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

// What `render` was asked for, beyond the view itself.
struct RenderOptions {
  r::ViewRequest view;
  std::string mode, output, camera_text;
  int quality = kDefaultQuality;
  uint32_t orbit = 0;
  bool reference = false, json = false;
};

RenderOptions render_options(const Args& args) {
  RenderOptions o;
  r::ViewRequest& v = o.view;
  o.mode = args.get("--mode", "dvr");
  try {
    const protocol::Modes modes = protocol::parse_modes(o.mode);
    v.dvr = modes.dvr;
    v.iso = modes.iso;
    v.surface = modes.surface;
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--mode: ") + e.what());
  }
  v.wireframe = args.has("--wireframe");
  v.box = args.has("--box");
  if (args.has("--tf")) v.tf = read_tf(args.get("--tf"));
  if (args.has("--attribute")) v.tf.attribute = args.get("--attribute");
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
  v.iso_color_attribute = args.get("--iso-color");
  o.camera_text = args.get("--camera");
  o.orbit = args.number("--orbit", 0);
  o.reference = args.has("--reference");
  o.json = args.has("--json");
  return o;
}

// The camera of orbit frame f of n: around the box centre at elevation 20°.
lod::Camera orbit_camera(uint32_t f, uint32_t n, const storage::Bounds& bounds, double aspect) {
  lod::Camera camera = lod::parse_camera("azimuth=" + std::to_string(30 + 360.0 * f / n) + ",elevation=20", bounds);
  camera.aspect = aspect;
  return camera;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
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
                      {"legend", {{"attribute", scene.attribute}, {"colormap", settings.tf.colormap},
                                  {"range", {settings.tf.range ? (*settings.tf.range)[0] : scene.value_min, settings.tf.range ? (*settings.tf.range)[1] : scene.value_max}}}}};
  if (settings.use_iso_color_attribute)
    j["legend"]["isosurfaces"] = {{"attribute", scene.iso_color_attribute}, {"colormap", settings.tf.colormap}, {"range", {scene.iso_color_min, scene.iso_color_max}}};
  return j;
}

// The CPU reference ray caster of `settings` (DVR only) next to the output, and its PSNR.
double write_reference(const RenderOptions& o, const r::SceneMesh& scene, const r::RenderSettings& settings, const r::Image& image) {
  if (!settings.dvr || settings.surface || settings.use_iso_color_attribute)
    throw std::invalid_argument("--reference compares volume rendering only (--mode dvr or dvr+iso, isosurfaces coloured by value)");
  const r::Image reference = r::reference_render(scene, settings);
  std::filesystem::path path(o.output);
  path.replace_filename(path.stem().string() + ".reference" + path.extension().string());
  r::write_image(path.string(), reference, o.quality);
  return r::psnr(image, reference);
}

}  // namespace

int run_cut(const Arguments& raw) {
  Args args(raw, {"--json"}, {"--output", "--budget", "--camera", "--size", "--tf", "--iso", "--attribute"});
  if (args.positionals().size() != 1 || !args.has("--output") || !args.has("--budget")) {
    std::fprintf(stderr, "usage: tetrascope cut STORE --budget N -o OUT.vtk [--camera C] [--size WxH] [--tf TF.json] [--attribute A] [--iso v1,v2] [--json]\n");
    return 2;
  }
  const OpenedStore opened = open_multires(args.positionals()[0], " (made by segment); run tetrascope preprocess for a multiresolution store");
  const storage::Store& store = *opened.store;
  const uint64_t budget = args.number("--budget", 0);
  if (budget == 0) throw std::invalid_argument("--budget must be at least 1");
  lod::TransferFunction tf;
  if (args.has("--tf")) tf = read_tf(args.get("--tf"));
  if (args.has("--attribute")) tf.attribute = args.get("--attribute");
  const std::vector<double> isovalues = args.has("--iso") ? number_list("--iso", args.get("--iso")) : std::vector<double>{};
  lod::CutCriteria criteria = lod::criteria_for(store, *opened.dag, tf, isovalues);
  if (args.has("--camera")) {
    lod::Camera camera = lod::parse_camera(args.get("--camera"), store.manifest().bounds);
    if (args.has("--size")) {
      const ImageSize size = parse_size("--size", args.get("--size"), 1, r::kMaxImageSide);
      camera.aspect = double(size.width) / size.height;
    }
    lod::set_view(criteria, camera);
  }
  lod::Cut cut(*opened.dag);
  const auto start = Clock::now();
  const auto changes = cut.update(criteria, budget);
  const double update_ms = ms_since(start);
  storage::SegmentCache cache(store, kCutCacheBytes);
  const auto mesh = lod::assemble_cut(store, cache, cut, false);
  storage::write_vtk(args.get("--output"), mesh.mesh, "tetrascope cut of " + std::filesystem::path(args.positionals()[0]).filename().string());
  nlohmann::json j = {{"tets", mesh.mesh.tet_count()}, {"vertices", mesh.mesh.vertex_count()}, {"patches", mesh.patches.size()}, {"budget", budget},
                      {"refinements", changes.refinements}, {"forced_refinements", changes.forced_refinements}, {"coarsenings", changes.coarsenings},
                      {"budget_limited", changes.budget_limited}, {"estimated_error", changes.estimated_error}, {"update_ms", update_ms}};
  if (args.has("--json")) std::cout << j.dump(2) << "\n";
  else std::printf("%s: %zu tets, %zu vertices from %zu patches (budget %llu%s); cut update %.2f ms\n", args.get("--output").c_str(), mesh.mesh.tet_count(),
                   mesh.mesh.vertex_count(), mesh.patches.size(), static_cast<unsigned long long>(budget), changes.budget_limited ? ", budget reached" : "", update_ms);
  return 0;
}

int run_render(const Arguments& raw) {
  Args args(raw, {"--json", "--wireframe", "--box", "--reference"},
            {"--output", "--mode", "--attribute", "--tf", "--iso", "--camera", "--size", "--budget", "--quality", "--orbit", "--unit-distance", "--iso-opacity", "--iso-color", "--volume"});
  if (args.positionals().size() != 1 || !args.has("--output")) {
    std::fprintf(stderr, "usage: tetrascope render MESH|STORE -o OUT.png|jpg [--mode dvr|iso|surface|dvr+iso|surface+iso] [--attribute A] [--tf TF.json] [--iso v1,v2] [--camera C] [--size WxH] [--budget TETS] [--quality Q] [--volume exact|projected] [--wireframe] [--box] [--orbit N] [--json]\n");
    return 2;
  }
  RenderOptions o = render_options(args);
  // the mesh: the cut of a multiresolution store for this view, or a whole mesh file
  const std::string input = args.positionals()[0];
  OpenedStore opened;
  std::unique_ptr<storage::SegmentCache> cache;
  std::unique_ptr<r::ViewPipeline> pipeline;
  if (std::filesystem::is_directory(input)) {
    opened = open_multires(input, "; render the mesh file or preprocess it");
    cache = std::make_unique<storage::SegmentCache>(*opened.store, kCutCacheBytes);
    pipeline = std::make_unique<r::ViewPipeline>(*opened.store, *opened.dag, *cache);
    o.view.budget = args.number("--budget", kDefaultRenderBudget);
  } else {
    if (args.has("--budget")) throw std::invalid_argument("--budget applies to a multiresolution store; a mesh file renders whole");
    pipeline = std::make_unique<r::ViewPipeline>(storage::load_mesh(input));
  }
  if (!o.camera_text.empty()) o.view.camera = lod::parse_camera(o.camera_text, pipeline->bounds());
  const r::RenderSettings settings = pipeline->update(o.view);
  // The context stays up to exit, on every path: Mesa's driver, unloaded by eglTerminate,
  // would leave allocations behind that leak checkers report against us.
  static r::Renderer* renderer = nullptr;  // reachable from here: not a leak
  renderer = r::Renderer::create().release();
  uint64_t held_scene = 0;
  const std::string extension = std::filesystem::path(o.output).extension().string();
  const bool jpeg = extension == ".jpg" || extension == ".jpeg";  // timing only: write_image picks the codec
  std::vector<r::FrameTimings> frames;
  r::RenderSettings frame = settings;
  r::Image image;
  for (uint32_t f = 0; f < std::max(1u, o.orbit); ++f) {
    if (o.orbit) frame.camera = orbit_camera(f, o.orbit, pipeline->bounds(), settings.camera.aspect);
    r::ViewTimings t;
    image = pipeline->draw(frame, *renderer, held_scene, &t);
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
  nlohmann::json j = render_report(o, settings, pipeline->scene(), renderer->description(), frames, reference_db);
  if (auto error = pipeline->cut_estimated_error()) j["cut_estimated_error"] = *error;
  if (o.json) std::cout << j.dump() << "\n";
  else std::printf("%s: %ux%u %s of %zu tets (%s), median %.1f ms a frame\n", o.output.c_str(), settings.width, settings.height, o.mode.c_str(),
                   pipeline->scene().tets.size() / 4, pipeline->scene().attribute.c_str(), j["median_ms"].get<double>());
  return 0;
}

}  // namespace tetrascope::apps
