// info, verify, segment, preprocess: inspecting meshes and stores, and building stores.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "args.h"
#include "commands.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/lod/mt/store_check.h"
#include "tetrascope/lod/mt/time_series.h"
#include "tetrascope/lod/cut/variants.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/lod/mt/segmentation.h"
#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/storage/boundary_tags.h"
#include "tetrascope/storage/mesh_info.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_verify.h"
#include "tetrascope/storage/tensor.h"
#include "tetrascope/storage/time_steps.h"

namespace tetrascope::apps {
namespace {

void print_store_attribute(const storage::StoreAttribute& a) {
  storage::AttributeInfo info{a.name, a.components, a.kind, a.positive_semidefinite, a.derived_from};
  std::printf("  %-24s %s  %g .. %g\n", a.name.c_str(), storage::attribute_kind_text(info).c_str(), a.min, a.max);
}

// The boundary regions of a multiresolution store as render --hide-regions and the viewer number
// them: from its boundary_tags.bin or from sharp edges, found on the input mesh (so listed up to
// kInfoRegionTets input tets).
constexpr uint64_t kInfoRegionTets = 20'000'000;
nlohmann::json store_regions(const storage::Store& store, const lod::Dag& dag, uint64_t input_tets) {
  const std::optional<storage::FaceTags> tags = storage::open_boundary_tags(store);
  nlohmann::json out = {{"source", tags ? "input tags" : "sharp edges"}, {"tags_file", tags ? storage::kBoundaryTagsFile : ""}};
  if (input_tets > kInfoRegionTets) {
    out["regions"] = nullptr;
    return out;
  }
  const auto map = renderer::RegionMap::of_store(store, dag, 256ull << 20, tags);
  out["source"] = renderer::region_source_name(map->source());
  nlohmann::json list = nlohmann::json::array();
  for (const auto& r : map->regions())
    list.push_back({{"id", r.id}, {"name", r.name}, {"triangles", r.triangles}, {"touches_domain_box", r.touches_domain_box}});
  out["regions"] = list;
  return out;
}

void print_store_regions(const nlohmann::json& regions) {
  if (regions["regions"].is_null()) {
    std::printf("regions     from %s (not listed above %llu input tets)\n", regions["source"].get<std::string>().c_str(), static_cast<unsigned long long>(kInfoRegionTets));
    return;
  }
  std::printf("regions     %zu, from %s\n", regions["regions"].size(), regions["source"].get<std::string>().c_str());
  for (const auto& r : regions["regions"])
    std::printf("  region %-3u %-24s %llu triangles%s\n", r["id"].get<unsigned>(), r["name"].get<std::string>().empty() ? "-" : r["name"].get<std::string>().c_str(),
                r["triangles"].get<unsigned long long>(), r["touches_domain_box"].get<bool>() ? "  (on the domain's box)" : "");
}

void print_time_steps(const storage::StoreManifest& m) {
  const std::vector<storage::TimeStep> steps = storage::manifest_time_steps(m);
  if (steps.empty()) return;
  std::printf("time steps  %zu, t = %g .. %g (steps.bin %.1f MB)\n", steps.size(), steps.front().time, steps.back().time, m.json["time_steps"].value("bytes", 0.0) / 1e6);
  for (const auto& s : steps) {
    std::printf("  step %-4u t = %-12g %-28s", s.index, s.time, s.name.c_str());
    for (size_t a = 0; a < s.ranges.size() && a < 2; ++a) std::printf("  %s %g .. %g", m.attributes[a].name.c_str(), s.ranges[a][0], s.ranges[a][1]);
    std::printf("\n");
  }
}

int print_store_info(const std::string& path, bool json) {
  auto store = storage::Store::open(path);
  const auto& m = store->manifest();
  nlohmann::json j = m.json;
  j.erase("stream");
  j.erase("checksum");
  std::error_code ec;
  j["files"]["segments.bin"]["bytes"] = std::filesystem::file_size(std::filesystem::path(path) / "segments.bin", ec);
  j["files"]["manifest.json"]["bytes"] = std::filesystem::file_size(std::filesystem::path(path) / "manifest.json", ec);
  j["vertices"] = m.vertex_count;
  j["tetrahedra"] = m.tet_count;
  auto dag = lod::open_dag(*store);
  if (dag) {
    j["files"]["dag.bin"]["bytes"] = std::filesystem::file_size(std::filesystem::path(path) / "dag.bin", ec);
    j["vertices"] = m.json["multiresolution"]["input"]["vertices"];
    j["tetrahedra"] = m.json["multiresolution"]["input"]["tetrahedra"];
    j["stored_vertices"] = m.vertex_count;
    j["stored_tetrahedra"] = m.tet_count;
    const auto variants_file = std::filesystem::path(path) / "variants.bin";
    if (std::filesystem::exists(variants_file)) j["files"]["variants.bin"]["bytes"] = std::filesystem::file_size(variants_file, ec);
    const auto tags_file = std::filesystem::path(path) / storage::kBoundaryTagsFile;
    if (std::filesystem::exists(tags_file)) j["files"][storage::kBoundaryTagsFile]["bytes"] = std::filesystem::file_size(tags_file, ec);
    j["regions"] = store_regions(*store, *dag, j["tetrahedra"].get<uint64_t>());
  }
  if (json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  if (dag) {
    const auto& mr = m.json["multiresolution"];
    std::printf("store       %s (format %u, multiresolution)\n", path.c_str(), m.version);
    const bool binary = mr.value("model", std::string("mt")) == "binary";
    std::printf("model       %s\n", binary ? "binary segment hierarchy (segments merged a pair at a time, §6.2)" : "multi-triangulation (§6.3)");
    std::printf("source      %s (sha256 %.16s...)\n", m.source_file.c_str(), m.source_sha256.c_str());
    std::printf("input       %llu vertices, %llu tetrahedra\n", mr["input"]["vertices"].get<unsigned long long>(), mr["input"]["tetrahedra"].get<unsigned long long>());
    std::printf("levels      %u (0 = the input), %u segments, %u patches, histograms of %u bins\n", dag->level_count(), dag->node_count(), dag->patch_count(), dag->bins());
    for (const auto& l : mr["levels"])
      std::printf("  level %-3u %6u segments %10llu tets %9llu vertices %7u patches to the level above\n", l["level"].get<unsigned>(), l["segments"].get<unsigned>(),
                  l["tets"].get<unsigned long long>(), l["vertices"].get<unsigned long long>(), l["patches"].get<unsigned>());
    std::printf("bounds      [%g, %g] x [%g, %g] x [%g, %g]\n", m.bounds.min[0], m.bounds.max[0], m.bounds.min[1], m.bounds.max[1], m.bounds.min[2], m.bounds.max[2]);
    for (const auto& a : m.attributes) print_store_attribute(a);
    const double input_tets = mr["input"]["tetrahedra"].get<double>();
    const double bytes = j["files"]["segments.bin"]["bytes"].get<double>() + j["files"]["dag.bin"]["bytes"].get<double>();
    std::printf("files       segments.bin %.1f MB (segments: %s), dag.bin %.1f MB (%.1f bytes per input tet)\n", j["files"]["segments.bin"]["bytes"].get<double>() / 1e6,
                storage::compression_name(store->compression()), j["files"]["dag.bin"]["bytes"].get<double>() / 1e6, bytes / input_tets);
    if (j["files"].contains("variants.bin"))
      std::printf("            variants.bin %.1f MB (%llu tets in segment variants, %.1f bytes per input tet)\n", j["files"]["variants.bin"]["bytes"].get<double>() / 1e6,
                  mr.contains("variants") ? mr["variants"]["tets"].get<unsigned long long>() : 0ull, j["files"]["variants.bin"]["bytes"].get<double>() / input_tets);
    if (j["files"].contains(storage::kBoundaryTagsFile))
      std::printf("            %s %.1f kB (%llu tags, %llu tagged triangles)\n", storage::kBoundaryTagsFile, j["files"][storage::kBoundaryTagsFile]["bytes"].get<double>() / 1e3,
                  m.json["boundary_tags"].value("tags", 0ull), m.json["boundary_tags"].value("triangles", 0ull));
    print_store_regions(j["regions"]);
    print_time_steps(m);
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
  for (const auto& a : m.attributes) print_store_attribute(a);
  std::printf("files       segments.bin %.1f MB\n", j["files"]["segments.bin"]["bytes"].get<double>() / 1e6);
  return 0;
}

// preprocess of a time series: the store of the first step, then every step's values.
int preprocess_series(const Args& args, const std::vector<storage::SeriesInput>& series, const lod::PreprocessOptions& options) {
  storage::Progress progress(progress_mode(args), {{"read", 0.03}, {"partition", 0.01}, {"simplify", 0.66}, {"write", 0.08}, {"steps", 0.22}});
  lod::PreprocessReport build;
  const lod::SeriesReport report = lod::preprocess_series(series, args.get("--output"), options, &progress, &build);
  lod::require_sound_store(args.get("--output"));  // steps.bin's blocks and ranges included
  if (args.has("--json")) {
    nlohmann::json j = build.to_json();
    j["time_steps"] = {{"steps", report.steps}, {"bytes", report.steps_bytes}, {"interpolated_vertices", report.interpolated_vertices},
                       {"outside_vertices", report.outside_vertices}, {"seconds", report.seconds}};
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::printf("%s: %llu tets -> %zu levels, %u segments; %u time steps (t = %g .. %g), steps.bin %.1f MB (%.1f bytes a vertex a step); %.2f s (steps %.2f s)\n",
              args.get("--output").c_str(), static_cast<unsigned long long>(build.input_tets), build.levels.size(), build.segments, report.steps, series.front().time,
              series.back().time, report.steps_bytes / 1e6, double(report.steps_bytes) / double(report.steps - 1) / double(std::max<uint64_t>(1, build.input_vertices)),
              build.seconds + report.seconds, report.seconds);
  return 0;
}

}  // namespace

int run_info(const Arguments& raw) {
  Args args(raw, {"--json"}, {});
  if (args.positionals().size() != 1) {
    std::fprintf(stderr, "usage: tetrascope info MESH|STORE [--json]\n");
    return 2;
  }
  const std::string& path = args.positionals()[0];
  // a store is a folder with a manifest; another folder may be an OpenFOAM case or time folder
  if (std::filesystem::is_directory(path) && std::filesystem::exists(std::filesystem::path(path) / "manifest.json")) return print_store_info(path, args.has("--json"));
  auto summary = storage::summarize_mesh(path);
  if (args.has("--json")) std::cout << storage::summary_json(summary).dump(2) << "\n";
  else std::cout << storage::summary_text(summary);
  return 0;
}

int run_verify(const Arguments& raw) {
  Args args(raw, {"--json"}, {"--progress"});
  if (args.positionals().size() != 1) {
    std::fprintf(stderr, "usage: tetrascope verify STORE [--progress bar|json|none] [--json]\n");
    return 2;
  }
  storage::Progress progress(progress_mode(args), {{"check segments", 1.0}});
  auto report = storage::verify_store(args.positionals()[0], &progress);
  if (report.ok) {  // a multiresolution store: the DAG too
    try {
      auto store = storage::Store::open(args.positionals()[0]);
      if (auto dag = lod::open_dag(*store)) {
        for (auto& p : lod::verify_dag(*store, *dag)) report.problems.push_back(p);
        for (auto& p : lod::verify_variants(*store, *dag)) report.problems.push_back(p);
        for (auto& p : lod::verify_vertex_hierarchy(store->path())) report.problems.push_back(p);
      }
      for (auto& p : storage::verify_time_steps(*store)) report.problems.push_back(p);
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

int run_segment(const Arguments& raw) {
  Args args(raw, {"--force", "--json"}, {"--output", "--leaf-vertices", "--segment-tets", "--segments", "--seed", "--progress", "--max-inflate-ratio"});
  if (args.positionals().size() != 1 || !args.has("--output")) {
    std::fprintf(stderr, "usage: tetrascope segment MESH -o STORE [--leaf-vertices K] [--segment-tets T | --segments N] [--seed S] [--max-inflate-ratio R] [--force] [--progress bar|json|none] [--json]\n");
    return 2;
  }
  lod::SegmentationOptions options;
  options.leaf_vertices = args.number("--leaf-vertices", options.leaf_vertices);
  options.segment_tets = args.number("--segment-tets", options.segment_tets);
  options.segments = args.number("--segments", 0);
  options.seed = static_cast<int>(args.number("--seed", 1));
  options.replace = args.has("--force");
  if (args.has("--max-inflate-ratio")) options.read_limits.max_inflate_ratio = args.real("--max-inflate-ratio");
  if (!(options.read_limits.max_inflate_ratio >= 1)) throw std::invalid_argument("--max-inflate-ratio must be at least 1");
  storage::Progress progress(progress_mode(args), {{"read vertices", 0.15}, {"partition", 0.05}, {"assign tets", 0.3}, {"match faces", 0.2}, {"write segments", 0.3}});
  auto report = lod::segment_mesh(args.positionals()[0], args.get("--output"), options, &progress);
  lod::require_sound_store(args.get("--output"));  // as preprocess: a store that fails verify's checks is removed, never reported as written
  if (args.has("--json")) {
    std::cout << report.to_json().dump(2) << "\n";
  } else {
    std::printf("%s: %llu tets in %u segments (%.0f avg, %u max tets; %u..%u vertices), at most %u segments active; %.2f s, %.2f M tets/s\n",
                args.get("--output").c_str(), static_cast<unsigned long long>(report.tets), report.segments, report.avg_tets, report.max_tets,
                report.min_vertices, report.max_vertices, report.max_workload, report.seconds, report.tets / 1e6 / report.seconds);
  }
  return 0;
}

int run_preprocess(const Arguments& raw) {
  Args args(raw, {"--force", "--json", "--all-steps"}, {"--output", "--model", "--dependency-ratio", "--base-tets", "--segment-tets", "--min-segments", "--level-ratio", "--level-targets", "--bins", "--threads", "--seed", "--progress", "--max-inflate-ratio", "--simplifier", "--compress-segments", "--memory-mb", "--variants", "--vertices"});
  if (args.positionals().empty() || !args.has("--output")) {
    std::fprintf(stderr, "usage: tetrascope preprocess MESH|SERIES.pvd|STEP_FILES...|'PATTERN' -o STORE [--all-steps] [--model mt|binary] [--dependency-ratio R|off] [--base-tets B] [--segment-tets auto|T] [--min-segments S] [--variants K] [--level-ratio auto|R] [--level-targets error|ratio] [--bins N] [--threads N] [--seed S] [--max-inflate-ratio R] [--simplifier qem|sample] [--compress-segments none|index16|cutborder] [--memory-mb M] [--vertices independent|queue|off] [--force] [--progress bar|json|none] [--json]\n");
    return 2;
  }
  lod::PreprocessOptions options;
  // a level whose tets take more than a quarter of M is kept in a spill file beside the store
  options.memory_mb = args.number("--memory-mb", static_cast<uint32_t>(options.memory_mb));
  options.base_tets = args.number("--base-tets", static_cast<uint32_t>(options.base_tets));
  // auto (the default): 8192 on a graded mesh, 16384 on a nearly uniform one (auto_segment_tets)
  if (args.has("--segment-tets") && args.get("--segment-tets") != "auto") {
    options.segment_tets = args.number("--segment-tets", 0);
    // 0 would read as auto in PreprocessOptions; 1-255 preprocess refuses (check_options)
    if (options.segment_tets == 0) throw std::invalid_argument("--segment-tets must be 'auto' or at least 256");
  }
  options.min_segments = static_cast<uint32_t>(args.number("--min-segments", options.min_segments));
  options.variants = static_cast<uint32_t>(args.number("--variants", options.variants));
  // the binary vertex hierarchy (vertices.bin): independent edges (the default), one global queue, or none
  if (args.has("--vertices")) {
    const std::string v = args.get("--vertices");
    if (v != "independent" && v != "queue" && v != "off") throw std::invalid_argument("--vertices must be 'independent', 'queue' or 'off'");
    if (v == "off") options.vertex_hierarchy_max_tets = 0;
    options.vertex_hierarchy_independent = v == "independent";
  }
  // auto (the default): 0.25 on a graded mesh, 0.5 on a nearly uniform one (auto_level_ratio)
  if (args.has("--level-ratio") && args.get("--level-ratio") != "auto") {
    options.level_ratio = args.real("--level-ratio");
    // 0 would read as auto in PreprocessOptions; other values out of range preprocess refuses
    if (options.level_ratio == 0) throw std::invalid_argument("--level-ratio must be 'auto' or in (0.01, 0.95)");
  }
  if (args.has("--level-targets")) {
    const std::string t = args.get("--level-targets");
    if (t != "error" && t != "ratio") throw std::invalid_argument("--level-targets must be 'error' (one error threshold a level) or 'ratio' (every segment to --level-ratio)");
    options.common_error = t == "error";
  }
  options.histogram_bins = args.number("--bins", options.histogram_bins);
  if (args.has("--model")) {
    const std::string model = args.get("--model");
    if (model != "mt" && model != "binary") throw std::invalid_argument("--model must be 'mt' (multi-triangulation) or 'binary' (binary segment hierarchy)");
    options.model = model == "binary" ? lod::MultiresModel::kBinary : lod::MultiresModel::kMultiTriangulation;
  }
  if (args.has("--dependency-ratio")) {
    if (options.model != lod::MultiresModel::kBinary) throw std::invalid_argument("--dependency-ratio applies to --model binary");
    options.dependency_ratio = args.get("--dependency-ratio") == "off" ? -1.0 : args.real("--dependency-ratio");
    if (!(options.dependency_ratio >= 0) && args.get("--dependency-ratio") != "off") throw std::invalid_argument("--dependency-ratio must be 'off' or a ratio of at least 0");
  }

  options.seed = static_cast<int>(args.number("--seed", 1));
  options.replace = args.has("--force");
  options.simplifier = simplify_method(args.has("--simplifier") ? args.get("--simplifier") : "qem", "--simplifier");
  if (args.has("--max-inflate-ratio")) options.read_limits.max_inflate_ratio = args.real("--max-inflate-ratio");
  if (!(options.read_limits.max_inflate_ratio >= 1)) throw std::invalid_argument("--max-inflate-ratio must be at least 1");
  // started by mpirun: the ranks share the levels' segments, rank 0 reports and
  // writes; not started by one, MPI is never touched
  lod::Ranks* ranks = lod::launched_ranks();
  options.ranks = ranks;
  // by default the node's cores, shared among the ranks on it
  options.threads = args.number("--threads", std::max(1u, std::thread::hardware_concurrency() / static_cast<unsigned>(ranks ? ranks->node_size() : 1)));
  const bool lead = !ranks || ranks->rank() == 0;
  if (args.has("--compress-segments")) options.compression = storage::parse_compression(args.get("--compress-segments"));
  // each stage's share of the time, measured on disk_out_ref, nasa_bluntfin and nasa_oxygen_post
  // (bench/job_progress.py, bench/results/job_progress.json); the job's bar and ETA follow them
  // a time series: a .pvd, several step files, a pattern, or with --all-steps an OpenFOAM
  // case's time folders or the time steps of an Exodus II, Gmsh or CGNS file
  const std::vector<storage::SeriesInput> series = storage::series_inputs(args.positionals(), args.has("--all-steps"), options.read_limits);
  if (series.empty() && args.positionals().size() != 1) throw std::invalid_argument("preprocess takes one mesh, or the steps of a time series");
  if (!series.empty()) return preprocess_series(args, series, options);
  storage::Progress progress(lead ? progress_mode(args) : storage::Progress::Mode::kNone,
                             {{"read", 0.03}, {"partition", 0.01}, {"simplify", 0.86}, {"write", 0.10}});
  lod::PreprocessReport report;
  try {
    report = lod::preprocess(args.positionals()[0], args.get("--output"), options, &progress);
    if (lead) lod::require_sound_store(args.get("--output"));  // a store that fails verify's checks is removed, never reported as written
  } catch (const std::exception& e) {
    // the other ranks would wait for this one in the next exchange: end them all
    if (ranks && ranks->size() > 1)
      ranks->abort("tetrascope preprocess: rank " + std::to_string(ranks->rank()) + " of " + std::to_string(ranks->size()) + ": error: " + e.what(),
                   dynamic_cast<const std::invalid_argument*>(&e) ? 2 : 1);
    throw;
  }
  if (ranks) ranks->barrier();  // every rank ends once the store is written and checked
  if (!lead) return 0;
  if (args.has("--json")) {
    std::cout << report.to_json().dump(2) << "\n";
  } else {
    // what auto chose, and why, when it chose either
    const bool chosen = options.segment_tets == 0 || options.level_ratio == 0;
    std::printf("%s: %llu tets -> %zu levels, each about %.2g of the one below, %u segments of about %u tets%s, %u patches; coarsest level %llu tets; %.1f MB (%.1f bytes a tet); %.2f s (%.0f tets/s)\n",
                args.get("--output").c_str(), static_cast<unsigned long long>(report.input_tets), report.levels.size(), report.level_ratio, report.segments,
                report.segment_tets, chosen ? (lod::graded_mesh(report.grading) ? " (auto: a graded mesh)" : " (auto: a nearly uniform mesh)") : "", report.patches,
                static_cast<unsigned long long>(report.levels.back().tets), report.store_bytes / 1e6, double(report.store_bytes) / report.input_tets, report.seconds,
                report.input_tets / report.seconds);
  }
  return 0;
}

}  // namespace tetrascope::apps
