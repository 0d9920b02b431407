// The cut with clip and slice planes (lod/cut.h): segments wholly clipped away are neither
// refined nor read; segments a slice crosses are refined first.
#include <gtest/gtest.h>

#include "mt_fixture.h"
#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::testing {
namespace {

TEST(CutPlanes, ClippedAwaySegmentsAreNeitherRefinedNorRead) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  storage::SegmentCache cache(*store, 1ull << 28);
  const auto& bounds = store->manifest().bounds;
  const double mid = 0.5 * (bounds.min[0] + bounds.max[0]);
  lod::CutCriteria criteria = lod::criteria_for(*store, *dag, view::TransferFunction{});
  criteria.clip = {view::Plane{{1, 0, 0}, mid}};  // keep x <= mid
  lod::Cut cut(*dag);
  cut.update(criteria, 1ull << 40);  // no budget limit: everything wanted is refined
  size_t refined_away = 0, refined_kept = 0;
  for (uint32_t v = 0; v < dag->node_count(); ++v) {
    if (!cut.refined(v) || dag->node(v).child_count == 0 || v == lod::dag::kRoot) continue;
    (lod::clipped_away(criteria.clip, dag->node(v).bounds) ? refined_away : refined_kept) += 1;
  }
  EXPECT_GT(refined_kept, 0u);
  // a clipped-away segment is refined only when a kept one forces it (its child shared)
  const lod::CutMesh all = lod::assemble_cut(*store, cache, cut, false);
  const lod::CutMesh kept = lod::assemble_cut(*store, cache, cut, false, criteria.clip);
  EXPECT_LT(kept.patches.size(), all.patches.size()) << "patches wholly clipped away are not read";
  for (uint32_t p : kept.patches) EXPECT_FALSE(lod::clipped_away(criteria.clip, dag->node(dag->patch(p).floor).bounds));
  // nothing on the kept side is lost: every tet of the full cut with a vertex at x <= mid is read
  size_t needed = 0;
  for (size_t t = 0; t < all.mesh.tet_count(); ++t) {
    bool inside = false;
    for (int k = 0; k < 4; ++k) inside |= all.mesh.x[all.mesh.tets[4 * t + k]] <= mid;
    needed += inside;
  }
  EXPECT_GE(kept.mesh.tet_count(), needed);
  std::printf("refined segments: %zu kept side, %zu clipped away (forced); patches read %zu of %zu\n", refined_kept, refined_away, kept.patches.size(),
              all.patches.size());
}

TEST(CutPlanes, SegmentsASliceCrossesAreRefinedFirst) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  const auto& bounds = store->manifest().bounds;
  const view::Plane slice{{0, 0, 1}, 0.5 * (bounds.min[2] + bounds.max[2])};
  lod::CutCriteria criteria = lod::criteria_for(*store, *dag, view::TransferFunction{});
  criteria.slices = {slice};
  // a budget that allows a few refinements only: they go to the slice
  lod::Cut probe(*dag);
  const uint64_t base = probe.tet_count();
  probe.refine_all();
  const uint64_t finest = probe.tet_count();
  lod::Cut cut(*dag);
  cut.update(criteria, base + (finest - base) / 4);
  size_t crossing = 0, other = 0;
  for (uint32_t v = 0; v < dag->node_count(); ++v) {
    if (!cut.refined(v) || dag->node(v).child_count == 0 || v == lod::dag::kRoot) continue;
    (lod::crosses(slice, dag->node(v).bounds) ? crossing : other) += 1;
  }
  EXPECT_GT(crossing, 0u);
  EXPECT_GE(crossing, other) << "the slice's segments first";
}

}  // namespace
}  // namespace tetrascope::testing
