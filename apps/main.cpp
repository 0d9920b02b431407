// The one tetrascope executable; each subcommand lives in the library that owns it and
// this file only parses arguments and maps errors to exit codes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "tetrascope/lod/cut.h"
#include "tetrascope/lod/error_measure.h"
#include "tetrascope/lod/dag.h"
#include "tetrascope/lod/mt_build.h"
#include "tetrascope/lod/segmentation.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/server/loadtest.h"
#include "tetrascope/server/server.h"
#include "tetrascope/lod/simplify.h"
#include "tetrascope/lod/store_check.h"
#include "tetrascope/storage/vtk_writer.h"
#include "tetrascope/storage/mesh_error.h"
#include "tetrascope/storage/mesh_info.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_verify.h"

namespace {

constexpr const char* kUsage =
    "usage: tetrascope <command> [options]\n"
    "\n"
    "commands:\n"
    "  info MESH|STORE [--json]      counts, attributes with ranges, bounds, quality counters\n"
    "  segment MESH -o STORE [--leaf-vertices K] [--segment-tets T | --segments N] [--seed S]\n"
    "                                [--force] [--progress bar|json|none] [--json]\n"
    "                                out-of-core segmentation (stage 1 of preprocess)\n"
    "  preprocess MESH -o STORE [--base-tets B] [--segment-tets T] [--min-segments S] [--level-ratio R] [--bins N]\n"
    "                                [--threads N] [--seed S] [--force] [--progress bar|json|none] [--json]\n"
    "                                [--max-inflate-ratio R]  compressed input may inflate to R x its size + 64 MiB (100)\n"
    "                                multiresolution store: segments, levels, DAG, error histograms (§6.3);\n"
    "                                the store passes verify's checks or is removed and the command fails\n"
    "  cut STORE --budget N -o OUT.vtk [--camera C] [--size WxH] [--tf TF.json] [--attribute A] [--iso v1,v2] [--json]\n"
    "                                the adapted mesh of a view and transfer function (§6.3.4)\n"
    "  render MESH|STORE -o OUT.png|jpg [--mode dvr|iso|surface|dvr+iso|surface+iso] [--attribute A] [--tf TF.json]\n"
    "                                [--iso v1,v2] [--iso-opacity A] [--iso-color B] [--camera C] [--size WxH] [--budget TETS] [--quality Q] [--wireframe] [--box]\n"
    "                                [--orbit N] [--reference] [--json]   headless EGL rendering (volume, isosurfaces, boundary)\n"
    "  verify STORE [--progress bar|json|none] [--json]\n"
    "                                checksums and structure of a store\n"
    "  simplify MESH -o OUT.vtk (--ratio R | --tets N | --max-error E) [--attribute A[,B..]]\n"
    "                                [--independent] [--attribute-weight W] [--boundary-weight W] [--feature-weight W]\n"
    "                                [--vertex-weight W] [--min-quality Q] [--threads N] [--json]\n"
    "                                quadric simplification of a whole mesh\n"
    "  error ORIGINAL SIMPLIFIED [--samples N] [--json]\n"
    "                                mean/max field error and domain error (§4.2.5)\n"
    "  serve --data DIR [--port 8080] [--bind ADDR] [--token T] [--threads N] [--workers N] [--cache-mb M]\n"
    "                                [--max-sessions N] [--max-message-bytes B] [--max-messages-per-second N] [--max-image-side S]\n"
    "                                [--max-upload-mb M] [--max-jobs N] [--max-fps F] [--budget TETS] [--interaction-budget TETS]\n"
    "                                [--interaction-scale S] [--web DIR]\n"
    "                                the viewer: web client at /, REST API under /api/v1/, WebSocket sessions\n"
    "  loadtest --url ws://HOST:PORT/api/v1/session --dataset NAME [--clients N] [--duration S] [--path orbit|random]\n"
    "                                [--rate HZ] [--size WxH] [--token T] [--allow-remote] [--json]\n"
    "                                concurrent sessions replaying a camera path: fps, latency, bytes, errors"
    "\n"
    "MESH: .vtk (legacy ASCII/BINARY), .vtu, .msh (Gmsh 2.2/4.1), .node/.ele (TetGen), .off\n";

// Command-line arguments: positionals and --name value / --flag options.
class Args {
 public:
  Args(const std::vector<std::string>& args, const std::vector<std::string>& flags, const std::vector<std::string>& valued) {
    for (size_t i = 0; i < args.size(); ++i) {
      const std::string& a = args[i];
      if (a.size() > 1 && a[0] == '-') {
        std::string name = a == "-o" ? "--output" : a;
        if (std::find(flags.begin(), flags.end(), name) != flags.end()) {
          values_.insert_or_assign(name, std::string(1, '1'));
        } else if (std::find(valued.begin(), valued.end(), name) != valued.end()) {
          if (i + 1 >= args.size()) throw std::invalid_argument(name + " needs a value");
          values_[name] = args[++i];
        } else {
          throw std::invalid_argument("unknown option " + a);
        }
      } else {
        positionals_.push_back(a);
      }
    }
  }
  const std::vector<std::string>& positionals() const { return positionals_; }
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  std::string get(const std::string& name, const std::string& fallback = "") const {
    auto it = values_.find(name);
    return it == values_.end() ? fallback : it->second;
  }
  uint32_t number(const std::string& name, uint32_t fallback) const {
    if (!has(name)) return fallback;
    const std::string& text = values_.at(name);
    size_t used = 0;
    unsigned long long v = 0;
    try {
      v = std::stoull(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || text.empty() || text[0] == '-' || v > 0xFFFFFFFFull) throw std::invalid_argument(name + " expects a whole number, got '" + text + "'");
    return static_cast<uint32_t>(v);
  }

 private:
  std::vector<std::string> positionals_;
  std::map<std::string, std::string> values_;
};

tetrascope::storage::Progress::Mode progress_mode(const Args& args) {
  std::string option = args.get("--progress", "bar");
  if (option != "bar" && option != "json" && option != "none") throw std::invalid_argument("--progress expects bar, json or none");
  return tetrascope::storage::Progress::mode_from(option, option == "json" || ::isatty(STDERR_FILENO));
}

int print_store_info(const std::string& path, bool json) {
  auto store = tetrascope::storage::Store::open(path);
  const auto& m = store->manifest();
  nlohmann::json j = m.json;
  j.erase("stream");
  j.erase("checksum");
  std::error_code ec;
  j["files"]["segments.bin"]["bytes"] = std::filesystem::file_size(std::filesystem::path(path) / "segments.bin", ec);
  j["files"]["manifest.json"]["bytes"] = std::filesystem::file_size(std::filesystem::path(path) / "manifest.json", ec);
  j["vertices"] = m.vertex_count;
  j["tetrahedra"] = m.tet_count;
  auto dag = tetrascope::lod::open_dag(*store);
  if (dag) {
    j["files"]["dag.bin"]["bytes"] = std::filesystem::file_size(std::filesystem::path(path) / "dag.bin", ec);
    j["vertices"] = m.json["multiresolution"]["input"]["vertices"];
    j["tetrahedra"] = m.json["multiresolution"]["input"]["tetrahedra"];
    j["stored_vertices"] = m.vertex_count;
    j["stored_tetrahedra"] = m.tet_count;
  }
  if (json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  if (dag) {
    const auto& mr = m.json["multiresolution"];
    std::printf("store       %s (format %u, multiresolution)\n", path.c_str(), m.version);
    std::printf("source      %s (sha256 %.16s...)\n", m.source_file.c_str(), m.source_sha256.c_str());
    std::printf("input       %llu vertices, %llu tetrahedra\n", mr["input"]["vertices"].get<unsigned long long>(), mr["input"]["tetrahedra"].get<unsigned long long>());
    std::printf("levels      %u (0 = the input), %u segments, %u patches, histograms of %u bins\n", dag->level_count(), dag->node_count(), dag->patch_count(), dag->bins());
    for (const auto& l : mr["levels"])
      std::printf("  level %-3u %6u segments %10llu tets %9llu vertices %7u patches to the level above\n", l["level"].get<unsigned>(), l["segments"].get<unsigned>(),
                  l["tets"].get<unsigned long long>(), l["vertices"].get<unsigned long long>(), l["patches"].get<unsigned>());
    std::printf("bounds      [%g, %g] x [%g, %g] x [%g, %g]\n", m.bounds.min[0], m.bounds.max[0], m.bounds.min[1], m.bounds.max[1], m.bounds.min[2], m.bounds.max[2]);
    for (const auto& a : m.attributes) std::printf("  %-24s %u  %g .. %g\n", a.name.c_str(), a.components, a.min, a.max);
    const double input_tets = mr["input"]["tetrahedra"].get<double>();
    const double bytes = j["files"]["segments.bin"]["bytes"].get<double>() + j["files"]["dag.bin"]["bytes"].get<double>();
    std::printf("files       segments.bin %.1f MB, dag.bin %.1f MB (%.1f bytes per input tet)\n", j["files"]["segments.bin"]["bytes"].get<double>() / 1e6,
                j["files"]["dag.bin"]["bytes"].get<double>() / 1e6, bytes / input_tets);
    return 0;
  }
  std::printf("store       %s (format %u)\n", path.c_str(), m.version);
  std::printf("source      %s (sha256 %.16s...)\n", m.source_file.c_str(), m.source_sha256.c_str());
  std::printf("vertices    %llu\ntetrahedra  %llu\nsegments    %u\n", static_cast<unsigned long long>(m.vertex_count),
              static_cast<unsigned long long>(m.tet_count), m.segment_count);
  const auto& seg = m.json.at("segmentation");
  std::printf("per segment %s vertices, %s tets (min/avg/max)\n",
              (seg["vertices_per_segment"]["min"].dump() + "/" + std::to_string(seg["vertices_per_segment"]["avg"].get<double>()).substr(0, 8) + "/" + seg["vertices_per_segment"]["max"].dump()).c_str(),
              (seg["tets_per_segment"]["min"].dump() + "/" + std::to_string(seg["tets_per_segment"]["avg"].get<double>()).substr(0, 8) + "/" + seg["tets_per_segment"]["max"].dump()).c_str());
  std::printf("streaming   at most %u segments active (%.1f%%)\n", m.max_workload_segments, 100.0 * m.max_workload_segments / m.segment_count);
  std::printf("bounds      [%g, %g] x [%g, %g] x [%g, %g]\n", m.bounds.min[0], m.bounds.max[0], m.bounds.min[1], m.bounds.max[1], m.bounds.min[2], m.bounds.max[2]);
  for (const auto& a : m.attributes) std::printf("  %-24s %u  %g .. %g\n", a.name.c_str(), a.components, a.min, a.max);
  std::printf("files       segments.bin %.1f MB\n", j["files"]["segments.bin"]["bytes"].get<double>() / 1e6);
  return 0;
}

int run_info(const std::vector<std::string>& raw) {
  Args args(raw, {"--json"}, {});
  if (args.positionals().size() != 1) {
    std::fprintf(stderr, "usage: tetrascope info MESH|STORE [--json]\n");
    return 2;
  }
  const std::string& path = args.positionals()[0];
  if (std::filesystem::is_directory(path)) return print_store_info(path, args.has("--json"));
  auto summary = tetrascope::storage::summarize_mesh(path);
  if (args.has("--json")) std::cout << tetrascope::storage::summary_json(summary).dump(2) << "\n";
  else std::cout << tetrascope::storage::summary_text(summary);
  return 0;
}

int run_segment(const std::vector<std::string>& raw) {
  Args args(raw, {"--force", "--json"}, {"--output", "--leaf-vertices", "--segment-tets", "--segments", "--seed", "--progress"});
  if (args.positionals().size() != 1 || !args.has("--output")) {
    std::fprintf(stderr, "usage: tetrascope segment MESH -o STORE [--leaf-vertices K] [--segment-tets T | --segments N] [--seed S] [--force] [--progress bar|json|none] [--json]\n");
    return 2;
  }
  tetrascope::lod::SegmentationOptions options;
  options.leaf_vertices = args.number("--leaf-vertices", options.leaf_vertices);
  options.segment_tets = args.number("--segment-tets", options.segment_tets);
  options.segments = args.number("--segments", 0);
  options.seed = static_cast<int>(args.number("--seed", 1));
  options.replace = args.has("--force");
  tetrascope::storage::Progress progress(progress_mode(args), {{"read vertices", 0.15}, {"partition", 0.05}, {"assign tets", 0.3}, {"match faces", 0.2}, {"write segments", 0.3}});
  auto report = tetrascope::lod::segment_mesh(args.positionals()[0], args.get("--output"), options, &progress);
  if (args.has("--json")) {
    std::cout << report.to_json().dump(2) << "\n";
  } else {
    std::printf("%s: %llu tets in %u segments (%.0f avg, %u max tets; %u..%u vertices), at most %u segments active; %.2f s, %.2f M tets/s\n",
                args.get("--output").c_str(), static_cast<unsigned long long>(report.tets), report.segments, report.avg_tets, report.max_tets,
                report.min_vertices, report.max_vertices, report.max_workload, report.seconds, report.tets / 1e6 / report.seconds);
  }
  return 0;
}

double real_number(const Args& args, const std::string& name) {
  const std::string text = args.get(name);
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || !std::isfinite(v)) throw std::invalid_argument(name + " expects a number, got '" + text + "'");
  return v;
}

int run_simplify(const std::vector<std::string>& raw) {
  Args args(raw, {"--independent", "--json"}, {"--output", "--ratio", "--tets", "--max-error", "--attribute", "--seed", "--boundary-weight",
                                             "--feature-weight", "--vertex-weight", "--min-quality", "--attribute-weight", "--threads"});
  int criteria = args.has("--ratio") + args.has("--tets") + args.has("--max-error");
  if (args.positionals().size() != 1 || !args.has("--output") || criteria == 0) {
    std::fprintf(stderr, "usage: tetrascope simplify MESH -o OUT.vtk (--ratio R | --tets N | --max-error E) [--attribute A[,B..]] [--independent] [--json]\n");
    return 2;
  }
  tetrascope::storage::ReadStats stats;
  auto mesh = tetrascope::storage::load_mesh(args.positionals()[0], &stats);
  tetrascope::lod::SimplifyOptions options;
  if (args.has("--ratio")) {
    double ratio = real_number(args, "--ratio");
    if (!(ratio > 0 && ratio <= 1)) throw std::invalid_argument("--ratio must be in (0, 1]");
    options.target_tets = std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(ratio * mesh.tet_count())));
  }
  if (args.has("--tets")) {
    options.target_tets = args.number("--tets", 0);
    if (options.target_tets == 0) throw std::invalid_argument("--tets must be at least 1");
  }
  if (args.has("--max-error")) {
    options.max_error = real_number(args, "--max-error");
    if (!(options.max_error > 0)) throw std::invalid_argument("--max-error must be > 0");
  }
  if (args.has("--attribute")) {
    std::string list = args.get("--attribute");
    for (size_t at = 0; at <= list.size();) {
      size_t comma = list.find(',', at);
      if (comma == std::string::npos) comma = list.size();
      if (comma > at) options.attributes.push_back(list.substr(at, comma - at));
      at = comma + 1;
    }
  }
  options.independent = args.has("--independent");
  if (args.has("--attribute-weight")) options.attribute_weight = real_number(args, "--attribute-weight");
  if (args.has("--boundary-weight")) options.boundary_weight = real_number(args, "--boundary-weight");
  if (args.has("--feature-weight")) options.feature_weight = real_number(args, "--feature-weight");
  if (args.has("--vertex-weight")) options.vertex_weight = real_number(args, "--vertex-weight");
  if (args.has("--min-quality")) options.min_quality = real_number(args, "--min-quality");
  options.seed = args.number("--seed", 1);
  options.threads = static_cast<uint32_t>(args.number("--threads", std::max(1u, std::thread::hardware_concurrency())));
  if (options.threads == 0 || options.threads > 64) throw std::invalid_argument("--threads must be in 1..64");
  auto report = tetrascope::lod::simplify(mesh, options);
  tetrascope::storage::write_vtk(args.get("--output"), mesh, "tetrascope simplify of " + std::filesystem::path(args.positionals()[0]).filename().string());
  nlohmann::json j = {{"tets_before", report.tets_before}, {"tets_after", report.tets_after}, {"vertices_before", report.vertices_before},
                      {"vertices_after", report.vertices_after}, {"collapses", report.collapses}, {"runs", report.runs},
                      {"refused_topology", report.refused_topology}, {"refused_geometry", report.refused_geometry},
                      {"max_queue", report.max_queue}, {"threads", report.threads}, {"seconds", report.seconds},
                      {"collapses_per_second", report.seconds > 0 ? report.collapses / report.seconds : 0.0}};
  if (args.has("--json")) std::cout << j.dump(2) << "\n";
  else std::printf("%s: %llu -> %llu tets (%.1f%%), %llu collapses in %.2f s (%.0f/s), max queue %llu\n", args.get("--output").c_str(),
                   static_cast<unsigned long long>(report.tets_before), static_cast<unsigned long long>(report.tets_after),
                   100.0 * report.tets_after / std::max<uint64_t>(1, report.tets_before), static_cast<unsigned long long>(report.collapses),
                   report.seconds, report.seconds > 0 ? report.collapses / report.seconds : 0.0, static_cast<unsigned long long>(report.max_queue));
  return 0;
}

int run_error(const std::vector<std::string>& raw) {
  Args args(raw, {"--json"}, {"--samples"});
  if (args.positionals().size() != 2) {
    std::fprintf(stderr, "usage: tetrascope error ORIGINAL SIMPLIFIED [--samples N] [--json]\n");
    return 2;
  }
  auto original = tetrascope::storage::load_mesh(args.positionals()[0]);
  auto simplified = tetrascope::storage::load_mesh(args.positionals()[1]);
  uint32_t samples = args.number("--samples", 20000);
  if (samples > 10000000) throw std::invalid_argument("--samples is at most 10000000");
  auto report = tetrascope::lod::measure_error(original, simplified, samples);
  if (args.has("--json")) {
    std::cout << report.to_json().dump(2) << "\n";
    return 0;
  }
  std::printf("vertices        %llu of the original (%llu outside the simplified mesh, projected to its boundary)\n",
              static_cast<unsigned long long>(report.vertices), static_cast<unsigned long long>(report.outside));
  std::printf("field error     mean (RMS) %.6f  over all attributes, normalised to [0, 1]\n", report.mean_all);
  for (const auto& f : report.fields) std::printf("  %-24s mean %.6f  max %.6f\n", f.name.c_str(), f.mean, f.max);
  std::printf("domain error    Hausdorff %.6g (%.4f%% of the diagonal), mean %.6g (%.4f%%)\n", report.hausdorff,
              100 * report.hausdorff / report.diagonal, report.mean_distance, 100 * report.mean_distance / report.diagonal);
  return 0;
}

std::vector<double> number_list(const std::string& option, const std::string& list) {
  std::vector<double> out;
  for (size_t at = 0; at <= list.size();) {
    size_t comma = list.find(',', at);
    if (comma == std::string::npos) comma = list.size();
    const std::string item = list.substr(at, comma - at);
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || item.empty() || !std::isfinite(v)) throw std::invalid_argument(option + " expects numbers separated by commas, got '" + item + "'");
    out.push_back(v);
    at = comma + 1;
  }
  return out;
}

tetrascope::lod::TransferFunction read_tf(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("--tf: cannot read " + path);
  try {
    return tetrascope::lod::TransferFunction::from_json(nlohmann::json::parse(in));
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument("--tf: " + path + " is not JSON: " + e.what());
  }
}

int run_preprocess(const std::vector<std::string>& raw) {
  Args args(raw, {"--force", "--json"}, {"--output", "--base-tets", "--segment-tets", "--min-segments", "--level-ratio", "--bins", "--threads", "--seed", "--progress", "--max-inflate-ratio"});
  if (args.positionals().size() != 1 || !args.has("--output")) {
    std::fprintf(stderr, "usage: tetrascope preprocess MESH -o STORE [--base-tets B] [--segment-tets T] [--min-segments S] [--level-ratio R] [--bins N] [--threads N] [--seed S] [--force] [--progress bar|json|none] [--json]\n");
    return 2;
  }
  tetrascope::lod::PreprocessOptions options;
  options.base_tets = args.number("--base-tets", static_cast<uint32_t>(options.base_tets));
  options.segment_tets = args.number("--segment-tets", options.segment_tets);
  if (args.has("--level-ratio")) options.level_ratio = real_number(args, "--level-ratio");
  options.min_segments = static_cast<uint32_t>(args.number("--min-segments", options.min_segments));
  options.histogram_bins = args.number("--bins", options.histogram_bins);
  options.threads = args.number("--threads", std::max(1u, std::thread::hardware_concurrency()));
  options.seed = static_cast<int>(args.number("--seed", 1));
  options.replace = args.has("--force");
  if (args.has("--max-inflate-ratio")) options.read_limits.max_inflate_ratio = real_number(args, "--max-inflate-ratio");
  if (!(options.read_limits.max_inflate_ratio >= 1)) throw std::invalid_argument("--max-inflate-ratio must be at least 1");
  tetrascope::storage::Progress progress(progress_mode(args), {{"read", 0.1}, {"partition", 0.05}, {"simplify", 0.75}, {"write", 0.1}});
  auto report = tetrascope::lod::preprocess(args.positionals()[0], args.get("--output"), options, &progress);
  tetrascope::lod::require_sound_store(args.get("--output"));
  if (args.has("--json")) {
    std::cout << report.to_json().dump(2) << "\n";
  } else {
    std::printf("%s: %llu tets -> %zu levels, %u segments, %u patches; coarsest level %llu tets; %.1f MB (%.1f bytes a tet); %.2f s (%.0f tets/s)\n",
                args.get("--output").c_str(), static_cast<unsigned long long>(report.input_tets), report.levels.size(), report.segments, report.patches,
                static_cast<unsigned long long>(report.levels.back().tets), report.store_bytes / 1e6, double(report.store_bytes) / report.input_tets, report.seconds,
                report.input_tets / report.seconds);
  }
  return 0;
}

int run_cut(const std::vector<std::string>& raw) {
  Args args(raw, {"--json"}, {"--output", "--budget", "--camera", "--size", "--tf", "--iso", "--attribute"});
  if (args.positionals().size() != 1 || !args.has("--output") || !args.has("--budget")) {
    std::fprintf(stderr, "usage: tetrascope cut STORE --budget N -o OUT.vtk [--camera C] [--size WxH] [--tf TF.json] [--attribute A] [--iso v1,v2] [--json]\n");
    return 2;
  }
  auto store = tetrascope::storage::Store::open(args.positionals()[0]);
  auto dag = tetrascope::lod::open_dag(*store);
  if (!dag) throw std::invalid_argument(args.positionals()[0] + " is a single-level store (made by segment); run tetrascope preprocess for a multiresolution store");
  const uint64_t budget = args.number("--budget", 0);
  if (budget == 0) throw std::invalid_argument("--budget must be at least 1");
  tetrascope::lod::TransferFunction tf;
  if (args.has("--tf")) tf = read_tf(args.get("--tf"));
  if (args.has("--attribute")) tf.attribute = args.get("--attribute");
  const std::vector<double> isovalues = args.has("--iso") ? number_list("--iso", args.get("--iso")) : std::vector<double>{};
  tetrascope::lod::CutCriteria criteria = tetrascope::lod::criteria_for(*store, *dag, tf, isovalues);
  if (args.has("--camera")) {
    tetrascope::lod::Camera camera = tetrascope::lod::parse_camera(args.get("--camera"), store->manifest().bounds);
    if (args.has("--size")) {
      unsigned w = 0, h = 0;
      if (std::sscanf(args.get("--size").c_str(), "%ux%u", &w, &h) != 2 || w == 0 || h == 0) throw std::invalid_argument("--size expects WxH");
      camera.aspect = double(w) / h;
    }
    const auto& b = store->manifest().bounds;
    const double diagonal = std::sqrt(std::pow(b.max[0] - b.min[0], 2) + std::pow(b.max[1] - b.min[1], 2) + std::pow(b.max[2] - b.min[2], 2));
    tetrascope::lod::set_view(criteria, camera, 1e3 * diagonal + 1e3);
  }
  tetrascope::lod::Cut cut(*dag);
  const auto start = std::chrono::steady_clock::now();
  auto changes = cut.update(criteria, budget);
  const double update_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  tetrascope::storage::SegmentCache cache(*store, 1ull << 30);
  auto mesh = tetrascope::lod::assemble_cut(*store, cache, cut, false);
  tetrascope::storage::write_vtk(args.get("--output"), mesh.mesh, "tetrascope cut of " + std::filesystem::path(args.positionals()[0]).filename().string());
  nlohmann::json j = {{"tets", mesh.mesh.tet_count()}, {"vertices", mesh.mesh.vertex_count()}, {"patches", mesh.patches.size()}, {"budget", budget},
                      {"refinements", changes.refinements}, {"forced_refinements", changes.forced_refinements}, {"coarsenings", changes.coarsenings},
                      {"budget_limited", changes.budget_limited}, {"estimated_error", changes.estimated_error}, {"update_ms", update_ms}};
  if (args.has("--json")) std::cout << j.dump(2) << "\n";
  else std::printf("%s: %zu tets, %zu vertices from %zu patches (budget %llu%s); cut update %.2f ms\n", args.get("--output").c_str(), mesh.mesh.tet_count(),
                   mesh.mesh.vertex_count(), mesh.patches.size(), static_cast<unsigned long long>(budget), changes.budget_limited ? ", budget reached" : "", update_ms);
  return 0;
}

int run_render(const std::vector<std::string>& raw) {
  namespace r = tetrascope::renderer;
  Args args(raw, {"--json", "--wireframe", "--box", "--reference"}, {"--output", "--mode", "--attribute", "--tf", "--iso", "--camera", "--size", "--budget", "--quality", "--orbit", "--unit-distance", "--iso-opacity", "--iso-color"});
  if (args.positionals().size() != 1 || !args.has("--output")) {
    std::fprintf(stderr, "usage: tetrascope render MESH|STORE -o OUT.png|jpg [--mode dvr|iso|surface|dvr+iso|surface+iso] [--attribute A] [--tf TF.json] [--iso v1,v2] [--camera C] [--size WxH] [--budget TETS] [--quality Q] [--wireframe] [--box] [--orbit N] [--json]\n");
    return 2;
  }
  r::RenderSettings settings;
  const std::string mode = args.get("--mode", "dvr");
  try {
    const tetrascope::protocol::Modes modes = tetrascope::protocol::parse_modes(mode);
    settings.dvr = modes.dvr;
    settings.iso = modes.iso;
    settings.surface = modes.surface;
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--mode: ") + e.what());
  }
  settings.wireframe = args.has("--wireframe");
  settings.box = args.has("--box");
  if (args.has("--tf")) settings.tf = read_tf(args.get("--tf"));
  if (args.has("--attribute")) settings.tf.attribute = args.get("--attribute");
  if (args.has("--size")) {
    unsigned w = 0, h = 0;
    char tail = 0;
    if (std::sscanf(args.get("--size").c_str(), "%ux%u%c", &w, &h, &tail) != 2 || w < 1 || h < 1 || w > 8192 || h > 8192) throw std::invalid_argument("--size expects WxH, each 1..8192");
    settings.width = w;
    settings.height = h;
  }
  {
    std::string ext = std::filesystem::path(args.get("--output")).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") throw std::invalid_argument(args.get("--output") + ": the output must end in .png, .jpg or .jpeg");
  }
  const int quality = static_cast<int>(args.number("--quality", 90));
  if (quality < 1 || quality > 100) throw std::invalid_argument("--quality must be 1 to 100");
  if (args.has("--unit-distance")) settings.unit_distance = real_number(args, "--unit-distance");
  if (args.has("--iso-opacity")) settings.iso_opacity = real_number(args, "--iso-opacity");
  // the mesh: a file, or the cut of a multiresolution store for this view
  const std::string input = args.positionals()[0];
  tetrascope::storage::TetMesh mesh;
  std::optional<double> cut_estimated_error;
  std::string source = input;
  if (std::filesystem::is_directory(input)) {
    auto store = tetrascope::storage::Store::open(input);
    auto dag = tetrascope::lod::open_dag(*store);
    if (!dag) throw std::invalid_argument(input + " is a single-level store; render the mesh file or preprocess it");
    const uint64_t budget = args.number("--budget", 1000000);
    // an isosurface view is steered by the spatial error at its isovalues
    const std::vector<double> isovalues = settings.iso && args.has("--iso") ? number_list("--iso", args.get("--iso")) : std::vector<double>{};
    auto criteria = tetrascope::lod::criteria_for(*store, *dag, settings.tf, isovalues);
    tetrascope::lod::Camera camera = args.has("--camera") ? tetrascope::lod::parse_camera(args.get("--camera"), store->manifest().bounds)
                                                          : tetrascope::lod::default_camera(store->manifest().bounds);
    camera.aspect = double(settings.width) / settings.height;
    tetrascope::lod::set_view(criteria, camera, 1e30);
    tetrascope::lod::Cut cut(*dag);
    cut_estimated_error = cut.update(criteria, budget).estimated_error;
    tetrascope::storage::SegmentCache cache(*store, 1ull << 30);
    mesh = std::move(tetrascope::lod::assemble_cut(*store, cache, cut, false).mesh);
  } else {
    if (args.has("--budget")) throw std::invalid_argument("--budget applies to a multiresolution store; a mesh file renders whole");
    mesh = tetrascope::storage::load_mesh(input);
  }
  const r::SceneMesh scene = r::SceneMesh::from(mesh, settings.tf.attribute, args.get("--iso-color"));
  settings.use_iso_color_attribute = args.has("--iso-color");
  settings.tf.attribute = scene.attribute;
  if (args.has("--iso")) settings.isovalues = number_list("--iso", args.get("--iso"));
  else if (settings.iso) settings.isovalues = {0.5 * (scene.value_min + scene.value_max)};
  settings.camera = args.has("--camera") ? tetrascope::lod::parse_camera(args.get("--camera"), scene.bounds) : tetrascope::lod::default_camera(scene.bounds);
  settings.camera.aspect = double(settings.width) / settings.height;
  // The context stays up to exit, on every path: Mesa's driver, unloaded by eglTerminate,
  // would leave allocations behind that leak checkers report against us.
  static r::Renderer* renderer = nullptr;  // reachable from here: not a leak
  renderer = r::Renderer::create().release();
  renderer->set_mesh(scene);
  const uint32_t orbit = args.number("--orbit", 0);
  std::vector<r::FrameTimings> frames;
  r::Image image;
  const std::string output = args.get("--output");
  const bool jpeg = output.size() > 4 && (output.substr(output.size() - 4) == ".jpg" || output.substr(output.size() - 5) == ".jpeg");
  for (uint32_t f = 0; f < std::max(1u, orbit); ++f) {
    r::RenderSettings frame = settings;
    if (orbit) {
      const double azimuth = 30 + 360.0 * f / orbit;
      frame.camera = tetrascope::lod::parse_camera("azimuth=" + std::to_string(azimuth) + ",elevation=20", scene.bounds);
      frame.camera.aspect = settings.camera.aspect;
    }
    r::FrameTimings t;
    image = renderer->render(frame, &t);
    const auto encode_start = std::chrono::steady_clock::now();
    auto bytes = jpeg ? r::encode_jpeg(image, quality) : r::encode_png(image);
    t.encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - encode_start).count();
    t.total_ms += t.encode_ms;
    frames.push_back(t);
    if (orbit && !args.has("--json"))
      std::printf("frame %3u  sort %7.2f  draw %8.2f  readback %6.2f  encode %6.2f  total %8.2f ms  (%llu tets drawn, %llu skipped)\n", f, t.sort_ms, t.draw_ms,
                  t.readback_ms, t.encode_ms, t.total_ms, static_cast<unsigned long long>(t.tets_drawn), static_cast<unsigned long long>(t.tets_skipped));
  }
  r::write_image(output, image, quality);
  double reference_db = -1;
  if (args.has("--reference")) {  // the CPU reference ray caster of the last frame (DVR only), and the PSNR between them
    if (!settings.dvr || settings.iso || settings.surface) throw std::invalid_argument("--reference compares volume rendering only (--mode dvr)");
    r::RenderSettings last = settings;
    if (orbit) {
      last.camera = tetrascope::lod::parse_camera("azimuth=" + std::to_string(30 + 360.0 * (orbit - 1) / orbit) + ",elevation=20", scene.bounds);
      last.camera.aspect = settings.camera.aspect;
    }
    const r::Image reference = r::reference_render(scene, last);
    reference_db = r::psnr(image, reference);
    std::filesystem::path ref_path(output);
    ref_path.replace_filename(ref_path.stem().string() + ".reference" + ref_path.extension().string());
    r::write_image(ref_path.string(), reference, quality);
  }
  auto median = [&](auto field) {
    std::vector<double> v;
    for (const auto& t : frames) v.push_back(field(t));
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  nlohmann::json j = {{"output", output}, {"width", settings.width}, {"height", settings.height}, {"mode", mode}, {"renderer", renderer->description()},
                      {"tets", mesh.tet_count()}, {"tets_drawn", frames.back().tets_drawn}, {"tets_skipped", frames.back().tets_skipped},
                      {"iso_triangles", frames.back().iso_triangles}, {"frames", frames.size()},
                      {"median_ms", median([](const r::FrameTimings& t) { return t.total_ms; })},
                      {"median_sort_ms", median([](const r::FrameTimings& t) { return t.sort_ms; })},
                      {"median_draw_ms", median([](const r::FrameTimings& t) { return t.draw_ms; })},
                      {"median_readback_ms", median([](const r::FrameTimings& t) { return t.readback_ms; })},
                      {"median_encode_ms", median([](const r::FrameTimings& t) { return t.encode_ms; })},
                      {"reference_psnr_db", reference_db},
                      {"legend", {{"attribute", scene.attribute}, {"colormap", settings.tf.colormap},
                                  {"range", {settings.tf.range ? (*settings.tf.range)[0] : scene.value_min, settings.tf.range ? (*settings.tf.range)[1] : scene.value_max}}}}};
  if (cut_estimated_error) j["cut_estimated_error"] = *cut_estimated_error;
  if (settings.use_iso_color_attribute) j["legend"]["isosurfaces"] = {{"attribute", scene.iso_color_attribute}, {"colormap", settings.tf.colormap}, {"range", {scene.iso_color_min, scene.iso_color_max}}};
  if (args.has("--json")) std::cout << j.dump() << "\n";
  else std::printf("%s: %ux%u %s of %zu tets (%s), median %.1f ms a frame\n", output.c_str(), settings.width, settings.height, mode.c_str(), mesh.tet_count(),
                   scene.attribute.c_str(), j["median_ms"].get<double>());
  return 0;
}

int run_verify(const std::vector<std::string>& raw) {
  Args args(raw, {"--json"}, {"--progress"});
  if (args.positionals().size() != 1) {
    std::fprintf(stderr, "usage: tetrascope verify STORE [--progress bar|json|none] [--json]\n");
    return 2;
  }
  tetrascope::storage::Progress progress(progress_mode(args), {{"check segments", 1.0}});
  auto report = tetrascope::storage::verify_store(args.positionals()[0], &progress);
  if (report.ok) {  // a multiresolution store: the DAG too
    try {
      auto store = tetrascope::storage::Store::open(args.positionals()[0]);
      if (auto dag = tetrascope::lod::open_dag(*store)) {
        for (auto& p : tetrascope::lod::verify_dag(*store, *dag)) report.problems.push_back(p);
      }
    } catch (const std::exception& e) {
      report.problems.push_back(e.what());
    }
    report.ok = report.problems.empty();
  }
  if (args.has("--json")) {
    std::cout << report.to_json().dump(2) << "\n";
  } else if (report.ok) {
    std::printf("%s: ok (%llu segments, %llu tets, %llu shared vertex copies, %llu border faces)\n", args.positionals()[0].c_str(),
                static_cast<unsigned long long>(report.segments), static_cast<unsigned long long>(report.tets),
                static_cast<unsigned long long>(report.shared_vertex_copies), static_cast<unsigned long long>(report.border_faces));
  } else {
    std::fprintf(stderr, "%s: DAMAGED\n", args.positionals()[0].c_str());
    for (const auto& p : report.problems) std::fprintf(stderr, "  %s\n", p.c_str());
  }
  return report.ok ? 0 : 1;
}

double positive_number(const Args& args, const std::string& name, double fallback) {
  if (!args.has(name)) return fallback;
  const double v = real_number(args, name);
  if (!(v > 0)) throw std::invalid_argument(name + " must be above 0");
  return v;
}

int run_serve(const std::vector<std::string>& raw) {
  Args args(raw, {}, {"--data", "--port", "--bind", "--token", "--threads", "--workers", "--cache-mb", "--max-sessions", "--max-message-bytes",
                      "--max-messages-per-second", "--max-image-side", "--max-upload-mb", "--max-jobs", "--max-fps", "--budget", "--interaction-budget",
                      "--interaction-scale", "--web"});
  if (!args.has("--data") || !args.positionals().empty()) {
    std::fprintf(stderr, "usage: tetrascope serve --data DIR [--port 8080] [--bind ADDR] [--token T] [--threads N] ... (tetrascope --help)\n");
    return 2;
  }
  tetrascope::server::ServerOptions o;
  o.data_dir = args.get("--data");
  const std::filesystem::path source = TETRA_SOURCE_DIR;
  o.web_root = args.has("--web") ? std::filesystem::path(args.get("--web")) : source / "web-client";
  o.protocol_root = (o.web_root / "..").lexically_normal() / "protocol";  // a trailing '/' on --web too
  const uint32_t port = args.number("--port", 8080);
  if (port > 65535) throw std::invalid_argument("--port must be 0 to 65535");
  o.port = static_cast<uint16_t>(port);
  o.bind = args.get("--bind", "127.0.0.1");
  o.token = args.get("--token", std::getenv("TETRASCOPE_TOKEN") ? std::getenv("TETRASCOPE_TOKEN") : "");
  o.io_threads = std::max(1u, args.number("--threads", 1));
  o.render_workers = std::max(1u, args.number("--workers", 2));
  o.cache_bytes = uint64_t(args.number("--cache-mb", 2048)) << 20;
  o.limits.max_sessions = args.number("--max-sessions", o.limits.max_sessions);
  o.limits.max_message_bytes = args.number("--max-message-bytes", static_cast<uint32_t>(o.limits.max_message_bytes));
  o.limits.max_messages_per_second = args.number("--max-messages-per-second", o.limits.max_messages_per_second);
  o.limits.max_image_side = std::min(8192u, args.number("--max-image-side", o.limits.max_image_side));
  o.max_upload_bytes = uint64_t(args.number("--max-upload-mb", 8192)) << 20;
  o.max_running_jobs = std::max(1u, args.number("--max-jobs", 1));
  o.max_fps = positive_number(args, "--max-fps", 30);
  o.still_budget = args.number("--budget", static_cast<uint32_t>(o.still_budget));
  o.interaction_budget = args.number("--interaction-budget", static_cast<uint32_t>(o.interaction_budget));
  o.interaction_scale = positive_number(args, "--interaction-scale", 0.375);
  if (o.interaction_scale < 0.25 || o.interaction_scale > 1) throw std::invalid_argument("--interaction-scale must be 0.25 to 1");
  tetrascope::server::Server server(o);
  std::printf("tetrascope serve: open http://%s:%u/ (data %s, %u render workers%s)\n", o.bind == "0.0.0.0" ? "localhost" : o.bind.c_str(), server.port(),
              o.data_dir.c_str(), o.render_workers, o.token.empty() ? "" : ", token required");
  std::fflush(stdout);
  server.run_until_signal();
  return 0;
}

int run_loadtest(const std::vector<std::string>& raw) {
  Args args(raw, {"--json", "--allow-remote"}, {"--url", "--dataset", "--clients", "--duration", "--path", "--rate", "--size", "--token"});
  if (!args.has("--url") || !args.has("--dataset")) {
    std::fprintf(stderr, "usage: tetrascope loadtest --url ws://HOST:PORT/api/v1/session --dataset NAME [--clients N] [--duration S] [--path orbit|random] [--json]\n");
    return 2;
  }
  tetrascope::server::LoadtestOptions o;
  o.url = args.get("--url");
  o.dataset = args.get("--dataset");
  o.token = args.get("--token", std::getenv("TETRASCOPE_TOKEN") ? std::getenv("TETRASCOPE_TOKEN") : "");
  o.clients = args.number("--clients", 1);
  o.duration_s = positive_number(args, "--duration", 10);
  o.path = args.get("--path", "orbit");
  o.rate_hz = positive_number(args, "--rate", 30);
  o.allow_remote = args.has("--allow-remote");
  if (args.has("--size")) {
    unsigned w = 0, h = 0;
    if (std::sscanf(args.get("--size").c_str(), "%ux%u", &w, &h) != 2 || w < 16 || h < 16 || w > 4096 || h > 4096) throw std::invalid_argument("--size expects WxH, each 16..4096");
    o.width = w;
    o.height = h;
  }
  const nlohmann::json r = tetrascope::server::run_loadtest(o);
  if (args.has("--json")) {
    std::cout << r.dump() << "\n";
  } else {
    for (size_t c = 0; c < r["per_client"].size(); ++c) {
      const auto& pc = r["per_client"][c];
      std::printf("client %2zu: %6.1f fps  %5llu frames  latency p50 %6.1f p95 %6.1f p99 %6.1f ms  %llu errors%s%s\n", c, pc["fps"].get<double>(),
                  static_cast<unsigned long long>(pc["frames"].get<uint64_t>()), pc["latency_ms"]["p50"].get<double>(), pc["latency_ms"]["p95"].get<double>(),
                  pc["latency_ms"]["p99"].get<double>(), static_cast<unsigned long long>(pc["errors"].get<uint64_t>()), pc["failure"].is_null() ? "" : "  ",
                  pc["failure"].is_null() ? "" : pc["failure"].get<std::string>().c_str());
    }
    std::printf("total: %.1f fps over %u clients, latency p50 %.1f p95 %.1f p99 %.1f ms, %.0f KB/s, %llu errors\n", r["total_fps"].get<double>(), o.clients,
                r["latency_ms"]["p50"].get<double>(), r["latency_ms"]["p95"].get<double>(), r["latency_ms"]["p99"].get<double>(), r["bytes_per_s"].get<double>() / 1024,
                static_cast<unsigned long long>(r["errors"].get<uint64_t>()));
  }
  return r["errors"].get<uint64_t>() == 0 && r["clients_without_frames"].get<int64_t>() == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  std::string command = argv[1];
  std::vector<std::string> args(argv + 2, argv + argc);
  try {
    if (command == "info") return run_info(args);
    if (command == "segment") return run_segment(args);
    if (command == "verify") return run_verify(args);
    if (command == "preprocess") return run_preprocess(args);
    if (command == "cut") return run_cut(args);
    if (command == "render") return run_render(args);
    if (command == "simplify") return run_simplify(args);
    if (command == "error") return run_error(args);
    if (command == "serve") return run_serve(args);
    if (command == "loadtest") return run_loadtest(args);
    std::fprintf(stderr, "tetrascope: unknown command '%s'\n\n%s", command.c_str(), kUsage);
    return 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "tetrascope %s: %s\n", command.c_str(), e.what());
    return 2;
  } catch (const tetrascope::renderer::RenderError& e) {
    std::fprintf(stderr, "tetrascope %s: rendering: %s\n", command.c_str(), e.what());
    return 1;
  } catch (const tetrascope::storage::MeshError& e) {
    std::fprintf(stderr, "tetrascope %s: %s\n", command.c_str(), e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tetrascope %s: error: %s\n", command.c_str(), e.what());
    return 1;
  }
}
