// `tetrascope streamlines`: stream lines of a vector field of a mesh or store, written as
// legacy VTK POLYDATA (dissertation §7.3; lod/src/streamlines.cpp).
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

#include "tetrascope/lod/cut.h"
#include "tetrascope/lod/dag.h"
#include "tetrascope/lod/streamlines.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/tet_topology.h"

namespace {

constexpr const char* kStreamlinesUsage =
    "usage: tetrascope streamlines MESH|STORE --field V --seeds SPEC -o OUT.vtk [--direction forward|backward|both]\n"
    "                              [--max-steps S] [--max-length L] [--tolerance T] [--max-points P] [--threads N] [--json]\n"
    "  SPEC: line:x0,y0,z0,x1,y1,z1,N | plane:ox,oy,oz,ux,uy,uz,vx,vy,vz,NU,NV | points:x,y,z;x,y,z... | dense:N\n";

double positive_number(const std::string& name, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v) || v <= 0) throw std::invalid_argument(name + " expects a positive number, got '" + text + "'");
  return v;
}

uint32_t whole_number(const std::string& name, const std::string& text) {
  const double v = positive_number(name, text);
  if (v != std::floor(v) || v > 4e9) throw std::invalid_argument(name + " expects a whole number, got '" + text + "'");
  return static_cast<uint32_t>(v);
}

}  // namespace

int run_streamlines(const std::vector<std::string>& raw) {
  namespace lod = tetrascope::lod;
  std::map<std::string, std::string> options;
  std::vector<std::string> positionals;
  bool json = false;
  const std::vector<std::string> valued = {"--field", "--seeds", "--output", "--direction", "--max-steps", "--max-length", "--tolerance", "--threads", "--max-points"};
  for (size_t i = 0; i < raw.size(); ++i) {
    const std::string name = raw[i] == "-o" ? "--output" : raw[i];
    if (name == "--json") {
      json = true;
    } else if (std::find(valued.begin(), valued.end(), name) != valued.end()) {
      if (i + 1 >= raw.size()) throw std::invalid_argument(name + " needs a value");
      options[name] = raw[++i];
    } else if (name.size() > 1 && name[0] == '-') {
      throw std::invalid_argument("unknown option " + raw[i]);
    } else {
      positionals.push_back(raw[i]);
    }
  }
  if (positionals.size() != 1 || !options.count("--field") || !options.count("--seeds") || !options.count("--output")) {
    std::fputs(kStreamlinesUsage, stderr);
    return 2;
  }
  lod::StreamlineOptions o;
  if (options.count("--direction")) {
    const std::string& d = options["--direction"];
    if (d == "forward") o.direction = lod::StreamDirection::forward;
    else if (d == "backward") o.direction = lod::StreamDirection::backward;
    else if (d == "both") o.direction = lod::StreamDirection::both;
    else throw std::invalid_argument("--direction expects forward, backward or both, got '" + d + "'");
  }
  if (options.count("--max-steps")) o.max_steps = whole_number("--max-steps", options["--max-steps"]);
  if (options.count("--max-length")) o.max_length = positive_number("--max-length", options["--max-length"]);
  if (options.count("--tolerance")) o.tolerance = positive_number("--tolerance", options["--tolerance"]);
  if (options.count("--max-points")) o.max_points = whole_number("--max-points", options["--max-points"]);
  if (options.count("--threads")) o.threads = whole_number("--threads", options["--threads"]);
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
