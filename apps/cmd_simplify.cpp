// simplify, error: a simplifier (quadric collapses, or the sampling simplifier of §4.2) on a
// whole mesh, and the error it leaves (§4.2.5) with whether the border intersects itself.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "args.h"
#include "commands.h"
#include <cmath>

#include "tetrascope/lod/simplify/border_intersection.h"
#include "tetrascope/lod/field/error_measure.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/vtk_writer.h"

namespace tetrascope::apps {

lod::SimplifyMethod simplify_method(const std::string& value, const std::string& option) {
  if (value == "qem") return lod::SimplifyMethod::kQem;
  if (value == "sample") return lod::SimplifyMethod::kSample;
  throw std::invalid_argument(option + " must be 'qem' or 'sample', not '" + value + "'");
}

namespace {

// A threshold of the sampling simplifier: a finite number > 0 (or >= 0 with allow_zero).
double threshold(const Args& args, const std::string& name, bool allow_zero) {
  const double value = args.real(name);
  if (!(std::isfinite(value) && (value > 0 || (allow_zero && value == 0))))
    throw std::invalid_argument(name + " must be a finite number " + (allow_zero ? ">= 0" : "> 0") + ", not " + args.get(name));
  return value;
}

}  // namespace

int run_simplify(const Arguments& raw) {
  Args args(raw, {"--independent", "--json"}, {"--output", "--ratio", "--tets", "--max-error", "--attribute", "--seed", "--boundary-weight",
                                             "--feature-weight", "--vertex-weight", "--min-quality", "--attribute-weight", "--threads",
                                             "--method", "--field-error", "--space-error", "--border-error"});
  const std::string method_name = args.has("--method") ? args.get("--method") : "auto";
  const bool automatic = method_name == "auto";
  lod::SimplifyMethod method = automatic ? lod::SimplifyMethod::kQem : simplify_method(method_name, "--method");
  bool sample = method == lod::SimplifyMethod::kSample;
  int criteria = args.has("--ratio") + args.has("--tets") + args.has("--max-error") + (sample && (args.has("--field-error") || args.has("--space-error")));
  if (args.positionals().size() != 1 || !args.has("--output") || criteria == 0) {
    std::fprintf(stderr,
                 "usage: tetrascope simplify MESH -o OUT.vtk (--ratio R | --tets N | --max-error E) [--method auto|qem] [--attribute A[,B..]] [--independent] [--json]\n"
                 "       tetrascope simplify MESH -o OUT.vtk --method sample (--ratio R | --tets N | --field-error F | --space-error S) [--border-error B] [--attribute A[,B..]] [--json]\n");
    return 2;
  }
  if (automatic && (args.has("--field-error") || args.has("--space-error") || args.has("--border-error")))
    throw std::invalid_argument("--field-error, --space-error and --border-error belong to --method sample (the default, auto, chooses by the mesh)");
  if (!automatic && !sample && (args.has("--field-error") || args.has("--space-error") || args.has("--border-error")))
    throw std::invalid_argument("--field-error, --space-error and --border-error belong to --method sample");
  if (sample && args.has("--max-error")) throw std::invalid_argument("--max-error belongs to --method qem; the sampler takes --field-error and --space-error");
  storage::ReadStats stats;
  auto mesh = storage::load_mesh(args.positionals()[0], &stats);
  lod::SimplifyOptions options;
  if (args.has("--ratio")) {
    double ratio = args.real("--ratio");
    if (!(ratio > 0 && ratio <= 1)) throw std::invalid_argument("--ratio must be in (0, 1]");
    options.target_tets = std::max<uint64_t>(1, static_cast<uint64_t>(std::ceil(ratio * mesh.tet_count())));
  }
  if (args.has("--tets")) {
    options.target_tets = args.number("--tets", 0);
    if (options.target_tets == 0) throw std::invalid_argument("--tets must be at least 1");
  }
  if (args.has("--max-error")) {
    options.max_error = args.real("--max-error");
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
  if (args.has("--attribute-weight")) options.attribute_weight = args.real("--attribute-weight");
  if (args.has("--boundary-weight")) options.boundary_weight = args.real("--boundary-weight");
  if (args.has("--feature-weight")) options.feature_weight = args.real("--feature-weight");
  if (args.has("--vertex-weight")) options.vertex_weight = args.real("--vertex-weight");
  if (args.has("--min-quality")) options.min_quality = args.real("--min-quality");
  options.seed = args.number("--seed", 1);
  options.threads = static_cast<uint32_t>(args.number("--threads", std::max(1u, std::thread::hardware_concurrency())));
  if (options.threads == 0 || options.threads > 64) throw std::invalid_argument("--threads must be in 1..64");
  std::string chosen_because;
  // options only the quadric simplifier takes keep it
  const bool qem_only = args.has("--independent") || args.has("--boundary-weight") || args.has("--feature-weight") || args.has("--vertex-weight") ||
                        args.has("--min-quality") || args.has("--attribute-weight");
  if (automatic) {
    method = qem_only ? lod::SimplifyMethod::kQem : lod::choose_simplify_method(mesh, options, &chosen_because);
    if (qem_only) chosen_because = "an option of the quadric simplifier was given";
    sample = method == lod::SimplifyMethod::kSample;
  }
  options.method = method;
  if (args.has("--field-error")) options.field_error = threshold(args, "--field-error", false);
  if (args.has("--space-error")) options.space_error = threshold(args, "--space-error", false);
  if (args.has("--border-error")) {
    options.border_error = threshold(args, "--border-error", true);
    if (options.border_error > 1) throw std::invalid_argument("--border-error is a share of the diagonal: at most 1");
  }
  auto report = lod::simplify(mesh, options);
  storage::write_vtk(args.get("--output"), mesh, "tetrascope simplify of " + std::filesystem::path(args.positionals()[0]).filename().string());
  nlohmann::json j = {{"tets_before", report.tets_before}, {"tets_after", report.tets_after}, {"vertices_before", report.vertices_before},
                      {"vertices_after", report.vertices_after}, {"collapses", report.collapses}, {"runs", report.runs},
                      {"refused_topology", report.refused_topology}, {"refused_geometry", report.refused_geometry},
                      {"max_queue", report.max_queue}, {"threads", report.threads}, {"seconds", report.seconds},
                      {"collapses_per_second", report.seconds > 0 ? report.collapses / report.seconds : 0.0},
                      {"method", sample ? "sample" : "qem"}};
  if (automatic) j["method_chosen_because"] = chosen_because;
  if (sample) {
    j["border_triangles_before"] = report.border_before;
    j["border_triangles_after"] = report.border_after;
    j["samples"] = report.samples;
    j["steiner_points"] = report.steiner_points;
    j["refused_intersection"] = report.refused_intersection;
    j["tetrahedralizations"] = report.tetrahedralizations;
    j["fell_back_to_qem"] = report.fell_back_to_qem;
    if (!report.tetgen_failure.empty()) j["tetgen_failure"] = report.tetgen_failure;
    if (report.fell_back_to_qem)
      std::fprintf(stderr, "tetrascope simplify: %s: simplified by quadric collapses instead\n",
                   report.tetgen_failure.empty() ? "the border encloses a cavity the sampler cannot keep" : report.tetgen_failure.c_str());
    j["phase_seconds"] = {{"border", report.border_seconds}, {"sample", report.sample_seconds}, {"tetrahedralize", report.tetrahedralize_seconds},
                          {"output", report.output_seconds}, {"fit", report.fit_seconds}};
  }
  if (args.has("--json")) std::cout << j.dump(2) << "\n";
  else std::printf("%s: %llu -> %llu tets (%.1f%%), %llu collapses in %.2f s (%.0f/s), max queue %llu\n", args.get("--output").c_str(),
                   static_cast<unsigned long long>(report.tets_before), static_cast<unsigned long long>(report.tets_after),
                   100.0 * report.tets_after / std::max<uint64_t>(1, report.tets_before), static_cast<unsigned long long>(report.collapses),
                   report.seconds, report.seconds > 0 ? report.collapses / report.seconds : 0.0, static_cast<unsigned long long>(report.max_queue));
  return 0;
}

int run_error(const Arguments& raw) {
  Args args(raw, {"--json"}, {"--samples"});
  if (args.positionals().size() != 2) {
    std::fprintf(stderr, "usage: tetrascope error ORIGINAL SIMPLIFIED [--samples N] [--json]\n");
    return 2;
  }
  auto original = storage::load_mesh(args.positionals()[0]);
  auto simplified = storage::load_mesh(args.positionals()[1]);
  uint32_t samples = args.number("--samples", 20000);
  if (samples > 10000000) throw std::invalid_argument("--samples is at most 10000000");
  auto report = lod::measure_error(original, simplified, samples);
  const lod::BorderIntersections crossings = lod::border_self_intersections(simplified);
  if (args.has("--json")) {
    nlohmann::json j = report.to_json();
    j["border_triangles"] = crossings.border_triangles;
    j["border_self_intersects"] = !crossings.pairs.empty();
    j["border_intersecting_pairs"] = crossings.pairs.size();
    j["border_intersecting_pairs_truncated"] = crossings.truncated;
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::printf("vertices        %llu of the original (%llu outside the simplified mesh, projected to its boundary)\n",
              static_cast<unsigned long long>(report.vertices), static_cast<unsigned long long>(report.outside));
  std::printf("field error     mean (RMS) %.6f  over all attributes, normalised to [0, 1]\n", report.mean_all);
  for (const auto& f : report.fields) std::printf("  %-24s mean %.6f  max %.6f\n", f.name.c_str(), f.mean, f.max);
  std::printf("domain error    Hausdorff %.6g (%.4f%% of the diagonal), mean %.6g (%.4f%%)\n", report.hausdorff,
              100 * report.hausdorff / report.diagonal, report.mean_distance, 100 * report.mean_distance / report.diagonal);
  if (crossings.pairs.empty()) std::printf("border          %llu triangles, no self-intersection\n", static_cast<unsigned long long>(crossings.border_triangles));
  else
    std::printf("border          %llu triangles, SELF-INTERSECTING: %s%zu pairs of triangles meet\n", static_cast<unsigned long long>(crossings.border_triangles),
                crossings.truncated ? "at least " : "", crossings.pairs.size());
  return 0;
}

}  // namespace tetrascope::apps
