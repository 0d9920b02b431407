// The vertex hierarchy of a store (vertices.bin, dissertation ch. 5): its size per update,
// single vertex splits and edge collapses a second on one core, and the vertex front's update
// and mesh times for a camera orbit at a budget.
//   vertex_bench STORE [--budget N] [--steps N] [--repeat N]   -> one JSON object
// Reading: the median of 3 reads of the file, and of the same hierarchy written with its value
// ranges and after links held rather than derived (its bytes too).
// Splits: from the base mesh every collapse is split in reverse order (none forces another);
// collapses: then every one collapsed again in order. Each pass is timed whole and the median
// of --repeat passes reported.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/vertex/vertex_front.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/view/camera.h"

using namespace tetrascope;
using clock_type = std::chrono::steady_clock;

namespace {

double seconds_since(clock_type::time_point t) { return std::chrono::duration<double>(clock_type::now() - t).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: vertex_bench STORE [--budget N] [--steps N] [--repeat N]\n");
    return 2;
  }
  uint64_t budget = 0;
  int steps = 36, repeat = 5;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--budget")) budget = std::stoull(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--steps")) steps = std::stoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--repeat")) repeat = std::stoi(argv[i + 1]);
  }
  try {
    const std::filesystem::path file = std::filesystem::path(argv[1]) / lod::kVertexHierarchyFile;
    std::vector<double> read_s;
    lod::VertexHierarchy h;
    for (int r = 0; r < 3; ++r) {
      const auto read_start = clock_type::now();
      h = lod::read_vertex_hierarchy(file);
      read_s.push_back(seconds_since(read_start));
    }
    // the same hierarchy with its value ranges and after links written, not derived: its size
    // and reading time beside the file's
    const std::filesystem::path held = std::filesystem::path(argv[1]) / "vertices.links-held.bench";
    lod::write_vertex_hierarchy(held, h, {.leaves_in_store = true, .tets_in_store = true, .derive_star_links = false});
    std::vector<double> read_held_s;
    for (int r = 0; r < 3; ++r) {
      const auto read_start = clock_type::now();
      lod::read_vertex_hierarchy(held);
      read_held_s.push_back(seconds_since(read_start));
    }
    const uint64_t held_bytes = std::filesystem::file_size(held);
    std::filesystem::remove(held);
    const uint64_t C = h.collapse_count();
    if (C == 0) throw std::runtime_error("the hierarchy has no collapses");
    if (budget == 0) budget = h.input_tets() / 10;
    // bytes: the whole file, and the part that only serves the splits (not the mesh itself:
    // positions, values and tets are what any mesh holds)
    const uint64_t file_bytes = std::filesystem::file_size(file);
    const uint64_t update_bytes = C * sizeof(lod::VertexNode) + h.ranges.size() * 4 + (h.after.size() + h.before.size() + h.after_offsets.size() + h.before_offsets.size()) * 4;
    const uint64_t split_bytes = (h.after.size() + h.before.size() + h.after_offsets.size() + h.before_offsets.size()) * 4 + h.killer.size() * 4 + C * 4;  // links, killers, fans
    const uint64_t new_vertex_bytes = C * (12 + 4 * uint64_t{h.value_floats});

    lod::VertexFront front(h);
    std::vector<double> split_s, collapse_s;
    for (int r = 0; r < repeat; ++r) {
      front.collapse_all();
      auto t = clock_type::now();
      for (uint64_t i = C; i-- > 0;) front.split(static_cast<uint32_t>(i));
      split_s.push_back(seconds_since(t));
      if (front.tet_count() != h.input_tets()) throw std::runtime_error("splitting every collapse did not give the input's tets");
      t = clock_type::now();
      for (uint64_t i = 0; i < C; ++i)
        if (!front.collapse(static_cast<uint32_t>(i))) throw std::runtime_error("a collapse in order was refused");
      collapse_s.push_back(seconds_since(t));
      if (front.tet_count() != h.base_tets()) throw std::runtime_error("collapsing every collapse did not give the base mesh");
    }

    // an orbit at half the distance of the whole view, the frustum clipping part of the mesh
    storage::Bounds bounds;
    for (int k = 0; k < 3; ++k) {
      bounds.min[k] = 1e300;
      bounds.max[k] = -1e300;
    }
    for (uint32_t v = 0; v < h.input_vertices; ++v)
      for (int k = 0; k < 3; ++k) {
        bounds.min[k] = std::min(bounds.min[k], double(h.positions[3 * size_t{v} + k]));
        bounds.max[k] = std::max(bounds.max[k], double(h.positions[3 * size_t{v} + k]));
      }
    view::TransferFunction tf;
    lod::FrontCriteria criteria = lod::front_criteria(h, tf);
    std::vector<double> update_ms, mesh_ms, used;
    for (int s = 0; s < steps; ++s) {
      criteria.camera = view::parse_camera("azimuth=" + std::to_string(360.0 * s / steps) + ",elevation=20,distance=0.5,fov=30", bounds);
      auto t = clock_type::now();
      front.update(criteria, budget);
      update_ms.push_back(1e3 * seconds_since(t));
      t = clock_type::now();
      const storage::TetMesh mesh = front.mesh();
      mesh_ms.push_back(1e3 * seconds_since(t));
      used.push_back(double(mesh.tet_count()) / double(budget));
    }
    nlohmann::json j = {
        {"store", argv[1]}, {"input_tets", h.input_tets()}, {"input_vertices", h.input_vertices}, {"collapses", C}, {"base_tets", h.base_tets()}, {"depth", h.depth()},
        {"file_bytes", file_bytes}, {"file_bytes_per_update", double(file_bytes) / C}, {"node_bytes_per_update", double(update_bytes) / C},
        {"split_information_bytes_per_update", double(split_bytes) / C}, {"new_vertex_bytes_per_update", double(new_vertex_bytes) / C},
        {"read_seconds", median(read_s)}, {"links_held", {{"file_bytes", held_bytes}, {"read_seconds", median(read_held_s)}}}, {"repeat", repeat},
        {"splits_per_second", double(C) / median(split_s)}, {"collapses_per_second", double(C) / median(collapse_s)},
        {"updates_per_second", 2.0 * double(C) / (median(split_s) + median(collapse_s))},
        {"orbit", {{"steps", steps}, {"budget", budget}, {"median_update_ms", median(update_ms)}, {"median_mesh_ms", median(mesh_ms)}, {"median_budget_used", median(used)},
                   {"least_budget_used", *std::min_element(used.begin(), used.end())}}}};
    std::printf("%s\n", j.dump(2).c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vertex_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
