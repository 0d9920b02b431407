// The runtime cut on a multiresolution store (§6.3.4): update time for a camera orbit of
// N steps at a tet budget (the view frustum and a transfer function steer it), patches
// changed per step, and the segment swap rate - tets a second mapped and validated from a
// warm page cache (every segment of the store, twice, the first pass warms the cache).
//   cut_bench STORE [--budget N] [--steps N] [--attribute A]   -> one JSON object
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/storage/store.h"

using namespace tetrascope;
using clock_type = std::chrono::steady_clock;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: cut_bench STORE [--budget N] [--steps N] [--attribute A]\n");
    return 2;
  }
  uint64_t budget = 0;
  int steps = 100;
  std::string attribute;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--budget")) budget = std::stoull(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--steps")) steps = std::stoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--attribute")) attribute = argv[i + 1];
  }
  try {
    auto store = storage::Store::open(argv[1]);
    auto dag = lod::open_dag(*store);
    if (!dag) throw std::runtime_error("not a multiresolution store");
    const uint64_t input_tets = store->manifest().json["multiresolution"]["input"]["tetrahedra"].get<uint64_t>();
    if (budget == 0) budget = input_tets / 5;
    view::TransferFunction tf;
    tf.attribute = attribute;
    lod::CutCriteria criteria = lod::criteria_for(*store, *dag, tf);
    lod::Cut cut(*dag);
    // orbit: azimuth steps of 360/steps at elevation 20, closer than the whole view so the
    // frustum clips part of the mesh
    std::vector<double> ms;
    std::vector<size_t> changed;
    uint64_t limited = 0;
    for (int s = 0; s <= steps; ++s) {
      view::Camera camera = view::parse_camera("azimuth=" + std::to_string(360.0 * s / steps) + ",elevation=20,distance=0.5,fov=30", store->manifest().bounds);
      lod::set_view(criteria, camera);
      const auto t0 = clock_type::now();
      auto changes = cut.update(criteria, budget);
      const double elapsed = std::chrono::duration<double, std::milli>(clock_type::now() - t0).count();
      if (s == 0) continue;  // the first update builds the cut from the coarsest
      ms.push_back(elapsed);
      changed.push_back(changes.added.size() + changes.removed.size());
      limited += changes.budget_limited;
    }
    std::vector<double> sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    std::vector<size_t> sorted_changes = changed;
    std::sort(sorted_changes.begin(), sorted_changes.end());
    // swap rate: map + validate every segment (CRC and every index), warm page cache
    double swap_seconds = 0;
    uint64_t swap_tets = 0, swap_bytes = 0;
    for (int pass = 0; pass < 2; ++pass) {
      const auto t0 = clock_type::now();
      uint64_t tets = 0, bytes = 0;
      for (uint32_t seg = 0; seg < store->segment_count(); ++seg) {
        auto mapped = store->map_segment(seg);
        tets += mapped->view().tet_count;
        bytes += mapped->mapped_bytes();
      }
      swap_seconds = std::chrono::duration<double>(clock_type::now() - t0).count();
      swap_tets = tets;
      swap_bytes = bytes;
    }
    nlohmann::json j = {{"store", argv[1]}, {"input_tets", input_tets}, {"segments", dag->node_count()}, {"patches", dag->patch_count()},
                        {"budget", budget}, {"steps", steps}, {"final_tets", cut.tet_count()},
                        {"update_ms", {{"median", sorted[sorted.size() / 2]}, {"p95", sorted[sorted.size() * 95 / 100]}, {"max", sorted.back()}}},
                        {"patches_changed_per_step", {{"median", sorted_changes[sorted_changes.size() / 2]}, {"max", sorted_changes.back()}}},
                        {"steps_budget_limited", limited},
                        {"swap", {{"tets", swap_tets}, {"bytes", swap_bytes}, {"seconds", swap_seconds}, {"tets_per_second", swap_tets / swap_seconds}}}};
    std::printf("%s\n", j.dump().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cut_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
