// `tetrascope preprocess`: the multi-triangulation of dissertation §6.3.1-6.3.2, built in
// stages (mt_stages.h): ingest, levels, histograms, store.
//
// Level 0 is the input mesh, partitioned by octree + METIS (§6.1) as `tetrascope segment`
// does. Level i+1 comes from the mesh M(i) of level i: partition it again (the mesh turned
// 45° about its longest box axis through the centroid on every odd level, so that the borders
// frozen at one level fall inside the segments of the next), cut every level-i segment
// (floor) by the new segments (ceilings) into patches, and simplify each ceiling segment with
// its border vertices locked. Stop at the base budget or one segment. A vertex keeps its
// global id while its position and values are unchanged; a moved vertex gets a new id.
//
// The vertices are held in memory (the table, and a few ids per vertex); the tets of a level
// are held in memory when they fit a quarter of --memory-mb, else in a spill file read a
// segment at a time (NodeTets), so that the input need never be whole in memory. Segment-wise work (simplification, error measure) runs on `threads`, and
// under MPI (options.ranks) is shared among the ranks, each of which holds the whole build.
#include "tetrascope/lod/cut/variants.h"
#include "tetrascope/lod/mt/mt_build.h"

#include <chrono>
#include <cmath>
#include <future>
#include <optional>
#include <stdexcept>
#include <string>

#include "mt_stages.h"
#include "tetrascope/lod/cut/dag_format.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/sha256.h"

namespace tetrascope::lod {

const char* model_name(MultiresModel model) { return model == MultiresModel::kBinary ? "binary" : "mt"; }

nlohmann::json PreprocessReport::to_json() const {
  nlohmann::json levels_json = nlohmann::json::array();
  for (const auto& l : levels) levels_json.push_back({{"level", l.level}, {"segments", l.segments}, {"patches", l.patches}, {"tets", l.tets}, {"vertices", l.vertices}});
  return {{"input_vertices", input_vertices}, {"input_tets", input_tets}, {"levels", levels_json}, {"segments", segments}, {"patches", patches},
          {"store_bytes", store_bytes}, {"dag_bytes", dag_bytes}, {"variants_bytes", variants_bytes}, {"variant_tets", variant_tets}, {"spilled_bytes", spilled_bytes}, {"tetgen_fallbacks", tetgen_fallbacks},
          {"segment_tets", segment_tets}, {"level_ratio", level_ratio}, {"model", model_name(model)}, {"dependencies", dependencies}, {"grading", grading}, {"seconds", seconds},
          {"stage_seconds", {{"read", read_seconds}, {"partition", segment_seconds}, {"simplify", simplify_seconds}, {"vertices", vertex_seconds}, {"write", write_seconds}}},
          {"vertices", vertex_hierarchy_skipped.empty() ? nlohmann::json{{"bytes", vertices_bytes}, {"collapses", vertex_collapses}, {"base_tets", vertex_base_tets}, {"depth", vertex_depth}}
                                                        : nlohmann::json{{"skipped", vertex_hierarchy_skipped}}}};
}

namespace {

void check_options(const PreprocessOptions& options, const std::filesystem::path& store_path) {
  if (options.segment_tets != 0 && options.segment_tets < 256) throw std::invalid_argument("--segment-tets must be 'auto' or at least 256");
  if (options.base_tets < 1) throw std::invalid_argument("--base-tets must be at least 1");
  if (options.level_ratio != 0 && !(options.level_ratio > 0.01 && options.level_ratio < 0.95))
    throw std::invalid_argument("--level-ratio must be 'auto' or in (0.01, 0.95)");
  if (options.histogram_bins < 2 || options.histogram_bins > dag::kMaxBins) throw std::invalid_argument("--bins must be 2 to " + std::to_string(dag::kMaxBins));
  if (options.threads < 1 || options.threads > 64) throw std::invalid_argument("--threads must be 1 to 64");
  if (options.variants > kMaxVariants) throw std::invalid_argument("--variants must be 0 to " + std::to_string(kMaxVariants));
  if (options.variants > 0 && options.simplifier != SimplifyMethod::kQem) throw std::invalid_argument("--variants needs --simplifier qem");
  if (!std::isfinite(options.dependency_ratio)) throw std::invalid_argument("--dependency-ratio must be a number or 'off'");
  if (options.model == MultiresModel::kBinary && options.ranks && options.ranks->size() > 1)
    throw std::invalid_argument("--model binary runs on one process (its levels are not shared among MPI ranks)");
  if (options.max_levels < 1 || options.max_levels > dag::kMaxLevels) throw std::invalid_argument("--max-levels must be 1 to " + std::to_string(dag::kMaxLevels));
  if (!options.replace && std::filesystem::exists(store_path)) throw std::runtime_error(store_path.string() + " exists (use --force to replace it)");
}

constexpr uint64_t kVertexBuildBytesPerTet = 256;  // the simplifier's and the replay's arrays: ONERA's peak grew by about 200

// The binary vertex hierarchy of the whole mesh (§5.2.1), when it is wanted and fits.
std::optional<VertexHierarchy> vertex_hierarchy(const std::filesystem::path& mesh_path, const PreprocessOptions& options, PreprocessReport& report) {
  if (options.vertex_hierarchy_max_tets == 0) {
    report.vertex_hierarchy_skipped = "turned off";
    return std::nullopt;
  }
  if (report.input_tets > options.vertex_hierarchy_max_tets) {
    report.vertex_hierarchy_skipped = "the mesh has more than " + std::to_string(options.vertex_hierarchy_max_tets) + " tets";
    return std::nullopt;
  }
  if (options.memory_mb && report.input_tets * kVertexBuildBytesPerTet > options.memory_mb << 20) {
    report.vertex_hierarchy_skipped = "its build would pass --memory-mb";
    return std::nullopt;
  }
  const auto start = std::chrono::steady_clock::now();
  storage::ReadStats stats;
  storage::TetMesh mesh = storage::load_mesh(mesh_path, &stats, options.read_limits);
  storage::drop_unused_vertices(mesh);
  VertexHierarchyOptions vo;
  vo.independent = options.vertex_hierarchy_independent;
  vo.threads = options.threads;  // the two regions of `tetrascope simplify` (their collapses touch disjoint tets)
  VertexHierarchyReport built;
  VertexHierarchy h = build_vertex_hierarchy(mesh, vo, &built);
  report.vertex_collapses = built.collapses;
  report.vertex_base_tets = built.base_tets;
  report.vertex_depth = built.depth;
  report.vertex_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return h;
}

// The vertex hierarchy, built beside the levels: it reads the input again and shares nothing
// with them, so on a host with cores to spare it adds little to the wall time (its CPU time
// stays). Where its build would take more than half of --memory-mb, the two are built one
// after the other.
class VertexHierarchyBuild {
 public:
  VertexHierarchyBuild(const std::filesystem::path& mesh_path, const PreprocessOptions& options, const PreprocessReport& report, bool beside)
      : mesh_path_(mesh_path), options_(options), report_(report) {
    if (beside) built_ = std::async(std::launch::async, [this] { return vertex_hierarchy(mesh_path_, options_, report_); });
  }
  // waits for it (or builds it now) and copies its figures into `report`
  std::optional<VertexHierarchy> take(PreprocessReport& report) {
    std::optional<VertexHierarchy> h = built_.valid() ? built_.get() : vertex_hierarchy(mesh_path_, options_, report_);
    report.vertex_hierarchy_skipped = report_.vertex_hierarchy_skipped;
    report.vertex_collapses = report_.vertex_collapses;
    report.vertex_base_tets = report_.vertex_base_tets;
    report.vertex_depth = report_.vertex_depth;
    report.vertex_seconds = report_.vertex_seconds;
    return h;
  }

 private:
  std::filesystem::path mesh_path_;
  PreprocessOptions options_;
  PreprocessReport report_;  // its own: the levels fill the caller's meanwhile
  std::future<std::optional<VertexHierarchy>> built_;
};

}  // namespace

PreprocessReport preprocess(const std::filesystem::path& mesh_path, const std::filesystem::path& store_path, const PreprocessOptions& given,
                            storage::Progress* progress) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  check_options(given, store_path);
  PreprocessOptions options = given;  // with the segment size resolved once the input is read
  const mt::StageProgress stage{progress, {}};
  PreprocessReport report;

  stage("read", 0);
  const std::filesystem::path hashed = storage::fingerprinted_file(mesh_path);
  // under MPI every rank reads and builds, rank 0 alone hashes and writes
  const bool writes = !options.ranks || options.ranks->rank() == 0;
  std::optional<storage::FileHasher> sha256;
  if (writes) sha256.emplace(hashed);  // checks the file is regular first; cancelled if reading fails
  const std::filesystem::path spill_directory = store_path.has_parent_path() ? store_path.parent_path() : std::filesystem::path(".");
  mt::IngestedMesh mesh = mt::ingest_mesh(mesh_path, options, spill_directory);
  report.spilled_bytes = mesh.tets.spilled_bytes();
  report.input_vertices = mesh.input_vertices;
  report.input_tets = mesh.input_tets;
  report.grading = mesh.grading;
  if (options.segment_tets == 0) options.segment_tets = auto_segment_tets(mesh.grading);
  // the binary hierarchy: a merged pair simplified to the size of one segment
  if (options.level_ratio == 0) options.level_ratio = options.model == MultiresModel::kBinary ? 0.5 : auto_level_ratio(mesh.grading);
  report.model = options.model;
  report.segment_tets = options.segment_tets;
  report.level_ratio = options.level_ratio;
  report.read_seconds = seconds_since(start);

  std::optional<VertexHierarchyBuild> vertex_build;
  if (writes) vertex_build.emplace(mesh_path, options, report, !options.memory_mb || 2 * report.input_tets * kVertexBuildBytesPerTet <= options.memory_mb << 20);
  const auto levels_start = clock::now();
  mt::Hierarchy hierarchy = mt::build_levels(mesh, options, stage);
  const std::vector<mt::PatchRange> arcs = mt::dag_arcs(hierarchy, static_cast<uint32_t>(mesh.channels.size()) * options.histogram_bins);
  report.segment_seconds = hierarchy.partition_seconds;
  report.tetgen_fallbacks = hierarchy.tetgen_fallbacks;
  report.dependencies = hierarchy.dependencies;
  report.simplify_seconds = seconds_since(levels_start) - hierarchy.partition_seconds;
  report.spilled_bytes += hierarchy.nodes.spilled_bytes();

  if (!writes) {
    report.seconds = seconds_since(start);
    return report;
  }

  const std::optional<VertexHierarchy> vertices = vertex_build->take(report);
  const auto write_start = clock::now();
  stage("write", 0);
  const mt::StoreOutput written =
      mt::write_mt_store({mesh, hierarchy, arcs, options, mesh_path, store_path, [&] { return sha256->get(); }, vertices ? &*vertices : nullptr}, stage);
  report.vertices_bytes = written.vertices_bytes;
  report.levels = written.levels;
  report.segments = static_cast<uint32_t>(hierarchy.nodes.size());
  report.patches = static_cast<uint32_t>(arcs.size());
  report.store_bytes = written.store_bytes;
  report.dag_bytes = written.dag_bytes;
  report.variants_bytes = written.variants_bytes;
  report.variant_tets = hierarchy.variants ? hierarchy.variants->tets() : 0;
  report.write_seconds = seconds_since(write_start);
  report.seconds = seconds_since(start);
  if (progress) progress->finish();
  return report;
}

}  // namespace tetrascope::lod
