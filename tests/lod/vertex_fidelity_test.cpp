// The vertex front's pictures (exact CPU integrator, PSNR against the full mesh): a larger
// budget never lowers the PSNR of a view, from outside and from inside, and the whole budget
// gives the input's picture exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "mesh_checks.h"
#include "tetrascope/lod/vertex/vertex_front.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::testing {
namespace {

storage::TetMesh field_box() {
  return kuhn_box(14, 0.3, [](double x, double y, double z) { return std::sin(5 * x) * std::cos(3 * y) + 0.8 * z * z; });
}

renderer::RenderSettings settings_for(const char* camera) {
  renderer::RenderSettings s;
  s.width = 96;
  s.height = 72;
  storage::Bounds box;
  box.max = {1, 1, 1};
  s.camera = view::parse_camera(camera, box);
  s.camera.aspect = double(s.width) / s.height;
  s.tf.attribute = std::string(1, 'f');  // not = "f": GCC 12 warns (-Wrestrict) on that assignment inlined
  s.tf.range = {{-1, 1.8}};
  s.tf.opacity = {{-1, 0}, {0.2, 0}, {1.8, 0.8}};
  return s;
}

TEST(VertexFidelity, ALargerBudgetNeverLowersThePsnr) {
  const storage::TetMesh input = field_box();
  const lod::VertexHierarchy h = lod::build_vertex_hierarchy(input, {.base_tets = 300});
  lod::VertexFront front(h);
  for (const char* camera : {"azimuth=35,elevation=25,distance=1.6", "eye=0.2,0.25,0.3,target=0.9,0.8,0.7,fov=60"}) {
    const renderer::RenderSettings s = settings_for(camera);
    const renderer::Image full = renderer::reference_render(renderer::SceneMesh::from(input, "f"), s);
    lod::FrontCriteria criteria = lod::front_criteria(h, s.tf);
    criteria.camera = s.camera;
    double last = -1;
    for (uint64_t budget : {600, 1500, 3000, 6000, 9000, 12000, 16464}) {
      front.update(criteria, budget);
      const double db = renderer::psnr(full, renderer::reference_render(renderer::SceneMesh::from(front.mesh(), "f"), s));
      EXPECT_GE(db, last) << camera << ": " << budget << " tets";
      last = db;
    }
    EXPECT_GE(last, 99.0) << camera << ": the whole budget draws the input";
  }
}

}  // namespace
}  // namespace tetrascope::testing
