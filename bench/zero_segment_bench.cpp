// The 0-segment (§6.2.3) against rebuilding the cut's adjacency: over a camera orbit of N steps
// at a tet budget (as cut_bench), per step the cut update, the swaps through the 0-segment
// (the patches that left undocked, those that joined docked), the same front docked from
// scratch (a rebuild through the 0-segment), and the cut mesh assembled with and without its
// face adjacency (the adjacency the renderer gets today: every border face of the front
// hashed). Segments stay mapped (a warm cache), so the times are the adjacency's alone.
//   zero_segment_bench STORE [--budget N] [--steps N] [--attribute A]   -> one JSON object
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/cut/zero_segment.h"
#include "tetrascope/storage/store.h"

using namespace tetrascope;
using clock_type = std::chrono::steady_clock;

namespace {

double ms_since(clock_type::time_point t0) { return std::chrono::duration<double, std::milli>(clock_type::now() - t0).count(); }

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: zero_segment_bench STORE [--budget N] [--steps N] [--attribute A]\n");
    return 2;
  }
  uint64_t budget = 0;
  int steps = 40;
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
    const auto& manifest = store->manifest().json["multiresolution"];
    const uint64_t input_tets = manifest["input"]["tetrahedra"].get<uint64_t>();
    if (budget == 0) budget = input_tets / 5;
    storage::SegmentCache cache(*store, uint64_t{1} << 34);
    auto t0 = clock_type::now();
    lod::ZeroSegment zero(cache, *dag);
    const double build_ms = ms_since(t0);
    view::TransferFunction tf;
    tf.attribute = attribute;
    lod::CutCriteria criteria = lod::criteria_for(*store, *dag, tf);
    lod::Cut cut(*dag);
    zero.follow(cut);
    std::vector<double> update_ms, swap_ms, redock_ms, assemble_ms, assemble_plain_ms, swapped;
    double swap_total_ms = 0;
    uint64_t swapped_total = 0, swapped_tets = 0, swap_steps = 0;
    for (int s = 0; s <= steps; ++s) {
      view::Camera camera = view::parse_camera("azimuth=" + std::to_string(360.0 * s / steps) + ",elevation=20,distance=0.5,fov=30", store->manifest().bounds);
      lod::set_view(criteria, camera);
      t0 = clock_type::now();
      const lod::CutChanges changes = cut.update(criteria, budget);
      const double update = ms_since(t0);
      t0 = clock_type::now();
      zero.swap(changes.removed, changes.added);
      const double swap = ms_since(t0);
      t0 = clock_type::now();
      const lod::CutMesh with = lod::assemble_cut(*store, cache, cut, true);
      const double assemble = ms_since(t0);
      t0 = clock_type::now();
      const lod::CutMesh without = lod::assemble_cut(*store, cache, cut, false);
      const double plain = ms_since(t0);
      if (s == 0) continue;  // the first update builds the cut from the coarsest
      lod::ZeroSegment& again = zero;  // the same front docked from scratch
      t0 = clock_type::now();
      again.clear();
      again.follow(cut);
      redock_ms.push_back(ms_since(t0));
      update_ms.push_back(update);
      assemble_ms.push_back(assemble);
      assemble_plain_ms.push_back(plain);
      const size_t n = changes.added.size() + changes.removed.size();
      if (n == 0) continue;  // the rates are over the steps that swapped
      swapped.push_back(double(n));
      ++swap_steps;
      swapped_total += n;
      swap_total_ms += swap;
      swap_ms.push_back(swap);
      for (uint32_t p : changes.added) swapped_tets += dag->patch(p).tet_count;
      for (uint32_t p : changes.removed) swapped_tets += dag->patch(p).tet_count;
      if (with.mesh.tet_count() != without.mesh.tet_count()) throw std::runtime_error("the two assemblies differ");
    }
    const double rebuild = median(assemble_ms) - median(assemble_plain_ms);
    nlohmann::json j = {{"store", argv[1]}, {"model", manifest.value("model", "mt")}, {"input_tets", input_tets}, {"segments", dag->node_count()},
                        {"patches", dag->patch_count()}, {"budget", budget}, {"steps", steps}, {"final_tets", cut.tet_count()},
                        {"zero_segment", {{"triangles", zero.triangle_count()}, {"bytes", zero.bytes()}, {"build_ms", build_ms}}},
                        {"median_ms", {{"cut_update", median(update_ms)}, {"zero_segment_swap_when_swapping", median(swap_ms)}, {"zero_segment_redock", median(redock_ms)},
                                       {"assemble_with_adjacency", median(assemble_ms)}, {"assemble_without_adjacency", median(assemble_plain_ms)},
                                       {"adjacency_rebuild", rebuild}}},
                        {"steps_that_swapped", swap_steps}, {"patches_swapped_per_swapping_step", median(swapped)},
                        // without the 0-segment every step that swaps rebuilds the front's adjacency
                        {"swaps_per_second", {{"zero_segment", swap_total_ms > 0 ? double(swapped_total) / (swap_total_ms / 1000) : 0.0},
                                              {"rebuild", rebuild > 0 && swap_steps ? double(swapped_total) / (double(swap_steps) * rebuild / 1000) : 0.0}}},
                        {"tets_swapped_per_second_zero_segment", swap_total_ms > 0 ? double(swapped_tets) / (swap_total_ms / 1000) : 0.0}};
    std::printf("%s\n", j.dump().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "zero_segment_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
