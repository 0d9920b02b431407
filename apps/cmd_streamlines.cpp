// `tetrascope streamlines`: stream lines of a vector field of a mesh or store, and
// `tetrascope diffusion-surfaces`: diffusion surfaces of a tensor field, both written as legacy
// VTK POLYDATA (dissertation §7.3, §7.4; lod/field/streamlines.cpp, diffusion_surfaces.cpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/field/diffusion_surfaces.h"
#include "tetrascope/lod/field/streamlines.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/core/tet_topology.h"

#include "args.h"
#include "commands.h"

namespace tetrascope::apps {

namespace {

constexpr const char* kStreamlinesUsage =
    "usage: tetrascope streamlines MESH|STORE --field V --seeds SPEC -o OUT.vtk [--direction forward|backward|both]\n"
    "                              [--max-steps S] [--max-length L] [--tolerance T] [--max-points P] [--threads N] [--min-cl C] [--json]\n"
    "  SPEC: line:x0,y0,z0,x1,y1,z1,N | plane:ox,oy,oz,ux,uy,uz,vx,vy,vz,NU,NV | points:x,y,z;x,y,z... | dense:N\n";

constexpr const char* kSurfacesUsage =
    "usage: tetrascope diffusion-surfaces MESH|STORE --tensor T --seeds SPEC -o OUT.vtk [--min-cp C] [--min-cl C] [--edge L]\n"
    "                              [--max-bend DEGREES] [--max-triangles N] [--json]\n"
    "  SPEC: line:x0,y0,z0,x1,y1,z1,N | plane:ox,oy,oz,ux,uy,uz,vx,vy,vz,NU,NV | points:x,y,z;x,y,z... | dense:N\n";

// The input at full resolution: a mesh file, or every segment of a store's finest cut.
storage::TetMesh load_full_mesh(const std::string& input) {
  if (!std::filesystem::is_directory(input)) return storage::load_mesh(input);
  auto store = storage::Store::open(input);
  auto dag = lod::open_dag(*store);
  if (!dag) throw std::invalid_argument(input + " is a single-level store (made by segment); run tetrascope preprocess for a multiresolution store");
  lod::Cut cut(*dag);
  cut.refine_all();
  storage::SegmentCache cache(*store, 1ull << 30);
  return std::move(lod::assemble_cut(*store, cache, cut, false).mesh);
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int run_streamlines(const Arguments& raw) {
  Args args(raw, {"--json"}, {"--field", "--seeds", "--output", "--direction", "--max-steps", "--max-length", "--tolerance", "--threads", "--max-points", "--min-cl"});
  if (args.positionals().size() != 1 || !args.has("--field") || !args.has("--seeds") || !args.has("--output")) {
    std::fputs(kStreamlinesUsage, stderr);
    return 2;
  }
  const bool json = args.has("--json");
  std::map<std::string, std::string> options = {{"--field", args.get("--field")}, {"--seeds", args.get("--seeds")}, {"--output", args.get("--output")}};
  const std::vector<std::string> positionals = args.positionals();
  lod::StreamlineOptions o;
  if (args.has("--direction")) {
    const std::string d = args.get("--direction");
    if (d == "forward") o.direction = lod::StreamDirection::forward;
    else if (d == "backward") o.direction = lod::StreamDirection::backward;
    else if (d == "both") o.direction = lod::StreamDirection::both;
    else throw std::invalid_argument("--direction expects forward, backward or both, got '" + d + "'");
  }
  o.max_steps = args.number("--max-steps", o.max_steps);
  if (o.max_steps == 0) throw std::invalid_argument("--max-steps must be at least 1");
  o.max_length = args.positive("--max-length", 0);
  o.tolerance = args.positive("--tolerance", o.tolerance);
  o.threads = args.number("--threads", 0);
  o.max_points = args.number("--max-points", 50'000'000);
  if (o.max_points == 0) throw std::invalid_argument("--max-points must be at least 1");
  const lod::SeedSpec seeds = lod::parse_seeds(options["--seeds"]);

  const std::string input = positionals[0];
  const auto load_start = std::chrono::steady_clock::now();
  const storage::TetMesh mesh = load_full_mesh(input);
  const double load_s = seconds_since(load_start);
  if (args.has("--min-cl")) {  // a tensor's lines run cl * e1: the zero speed is the linear anisotropy where they stop
    const tetrascope::storage::Attribute* field = mesh.find_attribute(options["--field"]);
    if (!field || field->info.kind != tetrascope::storage::AttributeKind::kTensor) throw std::invalid_argument("--min-cl needs a tensor --field");
    o.zero_speed = args.positive("--min-cl", 0);
  }
  const auto setup_start = std::chrono::steady_clock::now();
  const std::vector<uint32_t> opposite = tetrascope::pair_faces(mesh.tets).opposite;
  lod::StreamlineTracer tracer(mesh, opposite, options["--field"]);
  const double setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();
  const auto trace_start = std::chrono::steady_clock::now();
  const lod::Streamlines lines = tracer.trace(seeds, o);
  const double trace_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - trace_start).count();
  lod::write_streamlines_vtk(options["--output"], lines, options["--field"], "tetrascope streamlines of " + std::filesystem::path(input).filename().string());

  nlohmann::json stops = nlohmann::json::object();
  for (size_t r = 0; r < size_t(lod::StopReason::kCount); ++r) stops[lod::stop_reason_name(lod::StopReason(r))] = lines.stops[r];
  if (json) {
    nlohmann::json j = {{"lines", lines.line_count()}, {"points", lines.point_count()}, {"seeds", lines.seeds}, {"seeds_outside", lines.seeds_outside},
                        {"stops", stops}, {"tets", mesh.tet_count()}, {"load_seconds", load_s}, {"setup_seconds", setup_s}, {"trace_seconds", trace_s},
                        {"seconds", setup_s + trace_s}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("%s: %zu lines, %zu points from %llu seeds (%llu outside the domain); setup %.3f s, tracing %.3f s\n", options["--output"].c_str(), lines.line_count(),
                lines.point_count(), static_cast<unsigned long long>(lines.seeds), static_cast<unsigned long long>(lines.seeds_outside), setup_s, trace_s);
    std::printf("stops: %s\n", stops.dump().c_str());
  }
  return 0;
}

int run_diffusion_surfaces(const Arguments& raw) {
  Args args(raw, {"--json"}, {"--tensor", "--seeds", "--output", "--min-cp", "--min-cl", "--edge", "--max-bend", "--max-triangles"});
  if (args.positionals().size() != 1 || !args.has("--tensor") || !args.has("--seeds") || !args.has("--output")) {
    std::fputs(kSurfacesUsage, stderr);
    return 2;
  }
  lod::DiffusionSurfaceOptions o;
  o.min_planar = args.positive("--min-cp", o.min_planar);
  const double min_linear = args.positive("--min-cl", 0.25);
  if (o.min_planar > 1 || min_linear > 1) throw std::invalid_argument("--min-cp and --min-cl are anisotropy measures between 0 and 1");
  o.edge = args.positive("--edge", 0);
  o.max_bend_degrees = args.positive("--max-bend", o.max_bend_degrees);
  if (o.max_bend_degrees >= 90) throw std::invalid_argument("--max-bend must be below 90 degrees");
  o.max_triangles = args.number("--max-triangles", 2'000'000);
  if (o.max_triangles == 0) throw std::invalid_argument("--max-triangles must be at least 1");
  const lod::SeedSpec seeds = lod::parse_seeds(args.get("--seeds"));
  if (seeds.critical_subdivision) throw std::invalid_argument("critical-point seeds need a vector field; diffusion surfaces take line, plane, points or dense seeds");

  const std::string input = args.positionals()[0];
  const auto load_start = std::chrono::steady_clock::now();
  const storage::TetMesh mesh = load_full_mesh(input);
  const double load_s = seconds_since(load_start);
  const auto trace_start = std::chrono::steady_clock::now();
  const lod::AnisotropySegmentation classes = lod::segment_anisotropy(mesh, args.get("--tensor"), min_linear, o.min_planar);
  lod::DiffusionSurfaceTracer tracer(mesh, args.get("--tensor"));
  const lod::DiffusionSurfaces surfaces = seeds.dense_resolution ? tracer.trace_dense(seeds.dense_resolution, o) : tracer.trace(std::span<const Vec3>(seeds.points), o);
  const double trace_s = seconds_since(trace_start);
  lod::write_diffusion_surfaces_vtk(args.get("--output"), surfaces, "tetrascope diffusion surfaces of " + std::filesystem::path(input).filename().string());

  nlohmann::json operations = nlohmann::json::object();
  for (size_t k = 0; k < size_t(lod::SurfaceOperation::kCount); ++k) operations[lod::surface_operation_name(lod::SurfaceOperation(k))] = surfaces.operations[k];
  nlohmann::json regions = nlohmann::json::object();
  const char* names[] = {"isotropic", "linear", "planar"};
  for (size_t k = 0; k < 3; ++k) regions[names[k]] = {{"vertices", classes.vertices[k]}, {"volume_share", classes.volume_share[k]}};
  if (args.has("--json")) {
    const nlohmann::json j = {{"surfaces", surfaces.surface_count()}, {"triangles", surfaces.triangle_count()}, {"vertices", surfaces.vertex_count()},
                              {"seeds", surfaces.seeds}, {"seeds_refused", surfaces.seeds_refused}, {"operations", operations}, {"truncated", surfaces.truncated},
                              {"anisotropy", regions}, {"tets", mesh.tet_count()}, {"load_seconds", load_s}, {"seconds", trace_s}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("%s: %zu surfaces, %zu triangles from %llu seeds (%llu refused)%s; %.3f s\n", args.get("--output").c_str(), surfaces.surface_count(),
                surfaces.triangle_count(), static_cast<unsigned long long>(surfaces.seeds), static_cast<unsigned long long>(surfaces.seeds_refused),
                surfaces.truncated ? ", stopped at --max-triangles" : "", trace_s);
    std::printf("operations: %s\nanisotropy: %s\n", operations.dump().c_str(), regions.dump().c_str());
  }
  return 0;
}

}  // namespace tetrascope::apps
