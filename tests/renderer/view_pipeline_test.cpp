// The view pipeline on a multiresolution store (renderer/view_frame.h): a reassembly stopped
// for input (a refinement step given up when the user moves) leaves the scene it had,
// and the next update assembles the cut it asks for, the same scene a fresh pipeline builds.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "mt_fixture.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/renderer/view_frame.h"
#include "tetrascope/storage/mesh_stream.h"
#include "test_paths.h"

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

// One component of a vector (tf.set's "component"): the scene's values are that component of
// the vertices' vectors, its colour range is the component's over the whole dataset (the X
// range of the mesh's own values, not the magnitude's), and a scalar has no component.
TEST(ViewPipeline, AVectorComponentIsDrawnOverItsOwnRange) {
  const Built& b = built("sample");
  auto store = storage::Store::open(b.store);
  auto dag = lod::open_dag(*store);
  storage::SegmentCache cache(*store, 1ull << 28);
  const storage::TetMesh mesh = storage::load_mesh(sample_mesh());
  const storage::Attribute* velocity = mesh.find_attribute("Velocity");
  ASSERT_NE(velocity, nullptr);
  ASSERT_EQ(velocity->info.components, 3u);
  double lo = INFINITY, hi = -INFINITY, longest = 0;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const float* x = &velocity->values[3 * v];
    lo = std::min<double>(lo, x[0]);
    hi = std::max<double>(hi, x[0]);
    longest = std::max(longest, std::sqrt(double(x[0]) * x[0] + double(x[1]) * x[1] + double(x[2]) * x[2]));
  }
  ASSERT_LT(lo, 0) << "the fixture's X component should take both signs";

  view::ViewRequest r = request_with_budget(b.report.input_tets);
  r.tf.attribute = "Velocity";
  renderer::ViewPipeline magnitude(*store, *dag, cache);
  const renderer::RenderSettings m = magnitude.update(r);
  ASSERT_TRUE(m.tf.range);
  EXPECT_EQ((*m.tf.range)[0], 0);
  EXPECT_NEAR((*m.tf.range)[1], longest, 1e-6 * longest);

  r.tf.component = 0;
  renderer::ViewPipeline x(*store, *dag, cache);
  const renderer::RenderSettings s = x.update(r);
  ASSERT_TRUE(s.tf.range);
  EXPECT_EQ((*s.tf.range)[0], lo);  // the data's X range, exactly as the floats hold it
  EXPECT_EQ((*s.tf.range)[1], hi);
  EXPECT_NE(*s.tf.range, *m.tf.range);
  EXPECT_EQ(x.scene().component, 0);
  // the whole mesh's cut: its values are the X components, and span the X range
  const auto [least, most] = std::minmax_element(x.scene().value.begin(), x.scene().value.end());
  EXPECT_EQ(*least, lo);
  EXPECT_EQ(*most, hi);

  r.tf.attribute = "Temp";
  EXPECT_THROW(x.update(r), std::invalid_argument) << "a scalar has no X component";
}

}  // namespace
}  // namespace tetrascope::testing
