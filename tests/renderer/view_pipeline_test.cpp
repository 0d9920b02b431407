// The view pipeline on a multiresolution store (renderer/view_frame.h): a reassembly stopped
// for input (a refinement step given up when the user moves) leaves the scene it had,
// and the next update assembles the cut it asks for, the same scene a fresh pipeline builds.
#include <gtest/gtest.h>

#include "mt_fixture.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/renderer/view_frame.h"

namespace tetrascope::testing {
namespace {

view::ViewRequest request_with_budget(uint64_t budget) {
  view::ViewRequest r;
  r.width = 64;
  r.height = 48;
  r.budget = budget;
  return r;
}

TEST(ViewPipeline, AReassemblyStoppedForInputKeepsTheSceneAndIsRedoneNextTime) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  storage::SegmentCache cache(*store, 1ull << 28);
  renderer::ViewPipeline pipeline(*store, *dag, cache);
  const uint64_t all = b.report.input_tets;
  pipeline.update(request_with_budget(1));  // the coarsest cut
  const size_t coarse_tets = pipeline.scene().tets.size();
  ASSERT_GT(coarse_tets, 0u);

  int asked = 0;
  renderer::ViewTimings t;
  pipeline.update(request_with_budget(all), &t, [&] { return ++asked > 3; });  // input after three patches
  EXPECT_TRUE(t.interrupted);
  EXPECT_EQ(asked, 4) << "the assembly should stop at the first patch after the input came";
  EXPECT_EQ(pipeline.scene().tets.size(), coarse_tets) << "a stopped reassembly replaced the scene";

  // the same request again, uninterrupted: the cut is the one the stopped update reached, so the
  // cut reports no change; the scene must be assembled all the same
  renderer::ViewTimings again;
  pipeline.update(request_with_budget(all), &again, [] { return false; });
  EXPECT_FALSE(again.interrupted);
  ASSERT_EQ(pipeline.scene().tets.size(), 4 * all) << "the scene after the redone update is not the whole store's finest cut";

  renderer::ViewPipeline fresh(*store, *dag, cache);
  fresh.update(request_with_budget(all));
  EXPECT_EQ(pipeline.scene().tets, fresh.scene().tets);
  EXPECT_EQ(pipeline.scene().xyz, fresh.scene().xyz);
  EXPECT_EQ(pipeline.scene().value, fresh.scene().value);
}

}  // namespace
}  // namespace tetrascope::testing
