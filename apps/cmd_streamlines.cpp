// `tetrascope streamlines`: stream lines of a vector field of a mesh or store, written as
// legacy VTK POLYDATA (dissertation §7.3; lod/field/streamlines.cpp).
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
  tetrascope::storage::TetMesh mesh;
  if (std::filesystem::is_directory(input)) {
    // the full-resolution mesh: every segment of the finest cut
    auto store = tetrascope::storage::Store::open(input);
    auto dag = lod::open_dag(*store);
    if (!dag) throw std::invalid_argument(input + " is a single-level store (made by segment); run tetrascope preprocess for a multiresolution store");
    lod::Cut cut(*dag);
    cut.refine_all();
    tetrascope::storage::SegmentCache cache(*store, 1ull << 30);
    mesh = std::move(lod::assemble_cut(*store, cache, cut, false).mesh);
  } else {
    mesh = tetrascope::storage::load_mesh(input);
  }
  const double load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
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

}  // namespace tetrascope::apps
