// A tensor field drawn by points (§7.4.2): stream tubes of a constant linear tensor sampled on
// rings about lines along its major eigenvector (cross-section from the other two), the
// diffusion surface of a constant planar tensor sampled on its plane, colours by class and by a
// derived quantity, the GL pass drawing the points where the tubes are, and refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "mesh_checks.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/renderer/view_frame.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::testing {
namespace {

renderer::Renderer& gl() {
  static renderer::Renderer* r = renderer::Renderer::create().release();  // kept until exit, as render_test
  return *r;
}

storage::TetMesh constant_tensor_box(int n, const storage::SymmetricTensor& t) {
  storage::TetMesh m = kuhn_box(n, 0.3, [](float x, float, float) { return x; });
  storage::Attribute a{{"D", 6, storage::AttributeKind::kTensor, true}, {}};
  float six[6];
  storage::store_tensor(t, six);
  for (size_t v = 0; v < m.vertex_count(); ++v) a.values.insert(a.values.end(), six, six + 6);
  m.attributes.push_back(a);
  return m;
}

view::TensorRequest tubes_only(uint32_t cells) {
  view::TensorRequest r;
  r.tube_cells = cells;
  r.surface_cells = 0;
  return r;
}

// A cigar along x, wider along y than z (λ = 1, 0.2, 0.1): tubes along x with elliptic rings,
// their y radius twice their z radius.
TEST(TensorPoints, TubesOfALinearTensorAreEllipticRingsAboutLinesAlongItsMajorEigenvector) {
  const storage::TetMesh m = constant_tensor_box(6, {1.0, 0.2, 0.1, 0, 0, 0});
  const renderer::TensorPoints p = renderer::tensor_points(m, tubes_only(4));
  ASSERT_GT(p.tubes, 0u);
  ASSERT_EQ(p.count(), p.tube_points);
  EXPECT_EQ(p.surface_points, 0u);
  EXPECT_EQ(p.tube_points % renderer::kTubeRingPoints, 0u);
  EXPECT_TRUE(p.by_class);
  double max_dy = 0, max_dz = 0;
  for (size_t i = 0; i < p.count(); i += renderer::kTubeRingPoints) {
    // a ring: its centre the mean of its points, every point at its x
    double cy = 0, cz = 0;
    for (int j = 0; j < renderer::kTubeRingPoints; ++j) cy += p.xyz[3 * (i + j) + 1], cz += p.xyz[3 * (i + j) + 2];
    cy /= renderer::kTubeRingPoints, cz /= renderer::kTubeRingPoints;
    for (int j = 0; j < renderer::kTubeRingPoints; ++j) {
      const size_t k = i + size_t(j);
      EXPECT_NEAR(std::fabs(p.tangent[3 * k]), 1.0, 1e-6) << "the tangent is the major eigenvector";
      EXPECT_NEAR(p.normal[3 * k], 0.0, 1e-6) << "the ring's normals lie in its plane";
      EXPECT_NEAR(p.xyz[3 * k], p.xyz[3 * i], 1e-6) << "a ring lies in one plane x = const";
      EXPECT_EQ(p.value[k], 1.0f) << "linear";
      max_dy = std::max(max_dy, std::fabs(p.xyz[3 * k + 1] - cy));
      max_dz = std::max(max_dz, std::fabs(p.xyz[3 * k + 2] - cz));
    }
  }
  EXPECT_NEAR(max_dy, p.radius, 1e-3 * p.radius) << "the medium eigenvector's radius is the tube's";
  EXPECT_NEAR(max_dz, p.radius / 2, 1e-3 * p.radius) << "the minor's, by the ratio of the eigenvalues";
}

TEST(TensorPoints, TheSurfaceOfAPlanarTensorIsSampledOnItsPlane) {
  const storage::TetMesh m = constant_tensor_box(6, {1.0, 0.8, 0.05, 0, 0, 0});  // normal z
  view::TensorRequest r;
  r.tube_cells = 0;
  r.surface_cells = 1;  // one seed, at the box's centre
  const renderer::TensorPoints p = renderer::tensor_points(m, r);
  ASSERT_EQ(p.surfaces, 1u);
  ASSERT_GT(p.surface_points, 1000u);
  const double area_per_point = 1.0 / double(p.surface_points);  // the unit square
  EXPECT_NEAR(area_per_point, p.spacing * p.spacing, 0.25 * p.spacing * p.spacing) << "one point a spacing squared";
  for (size_t k = 0; k < p.count(); ++k) {
    EXPECT_NEAR(p.xyz[3 * k + 2], 0.5, 1e-4);
    EXPECT_NEAR(std::fabs(p.normal[3 * k + 2]), 1.0, 1e-5);
    EXPECT_EQ(p.tangent[3 * k] * p.tangent[3 * k] + p.tangent[3 * k + 1] * p.tangent[3 * k + 1] + p.tangent[3 * k + 2] * p.tangent[3 * k + 2], 0.0f);
    EXPECT_EQ(p.value[k], 2.0f) << "planar";
  }
}

TEST(TensorPoints, ADerivedQuantityColoursThePointsWithItsValue) {
  const storage::TetMesh m = constant_tensor_box(4, {1.0, 0.2, 0.1, 0, 0, 0});
  view::TensorRequest r = tubes_only(2);
  r.color = "cl";
  const renderer::TensorPoints p = renderer::tensor_points(m, r);
  ASSERT_GT(p.count(), 0u);
  EXPECT_FALSE(p.by_class);
  for (float v : p.value) EXPECT_NEAR(v, 0.8 / 1.3, 1e-5) << "cl = (λ1 - λ2) / Σλ";
}

TEST(TensorPoints, BadRequestsAreRefusedWithAMessage) {
  const storage::TetMesh m = constant_tensor_box(2, {1.0, 0.2, 0.1, 0, 0, 0});
  view::TensorRequest r;
  r.color = "purple";
  EXPECT_THROW(renderer::tensor_points(m, r), std::invalid_argument);
  r = {};
  r.field = "f";  // a scalar
  EXPECT_THROW(renderer::tensor_points(m, r), std::invalid_argument);
  r = {};
  r.min_linear = 1.5;
  EXPECT_THROW(renderer::tensor_points(m, r), std::invalid_argument);
  const storage::TetMesh scalars = kuhn_box(2, 0, [](float x, float, float) { return x; });
  try {
    renderer::tensor_points(scalars, {});
    ADD_FAILURE() << "a mesh without tensors";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no tensor field"), std::string::npos) << e.what();
  }
}

// Looking down z orthographically at tubes along x: every ring centre's pixel is drawn in the
// linear class's red, and a pixel farther than two radii from every tube stays background.
TEST(TensorPoints, TheGlPassDrawsThePointsWhereTheTubesAre) {
  const storage::TetMesh m = constant_tensor_box(6, {1.0, 0.2, 0.1, 0, 0, 0});
  const auto points = std::make_shared<const renderer::TensorPoints>(renderer::tensor_points(m, tubes_only(4)));
  const auto scene = renderer::SceneMesh::from(m, "f");
  gl().set_mesh(scene);
  renderer::RenderSettings s;
  s.width = s.height = 200;
  s.dvr = false;
  s.tf.attribute = "f";
  s.camera.eye = {0.5, 0.5, 3};
  s.camera.target = {0.5, 0.5, 0.5};
  s.camera.up = {0, 1, 0};
  s.camera.orthographic = true;
  s.camera.ortho_height = 1.2;
  const renderer::Image empty = gl().render(s);
  s.tensor_points = points;
  renderer::FrameTimings t;
  const renderer::Image image = gl().render(s, &t);
  EXPECT_EQ(t.tensor_points, points->count());
  const view::ViewFrame frame = view::ViewFrame::of(s.camera, s.width, s.height);
  auto pixel = [&](const renderer::Image& im, int x, int y) { return &im.rgba[4 * (size_t(y) * im.width + size_t(x))]; };
  // the tubes' (y, z) centres: rings' means
  std::vector<double> tube_y;
  size_t checked = 0;
  for (size_t i = 0; i < points->count(); i += renderer::kTubeRingPoints) {
    Vec3 c{0, 0, 0};
    for (int j = 0; j < renderer::kTubeRingPoints; ++j)
      for (int k = 0; k < 3; ++k) c[size_t(k)] += points->xyz[3 * (i + size_t(j)) + size_t(k)] / renderer::kTubeRingPoints;
    tube_y.push_back(c[1]);
    double px = 0, py = 0;
    ASSERT_TRUE(frame.project(c, &px, &py));
    const uint8_t* rgb = pixel(image, int(std::lround(px)), int(std::lround(py)));
    EXPECT_GT(rgb[0], rgb[1] + 30) << "red (linear) at the tube's centre, pixel " << px << "," << py;
    ++checked;
  }
  ASSERT_GT(checked, 50u);
  const uint8_t* background = pixel(empty, 0, 0);
  size_t far = 0;
  for (int y = 0; y < int(s.height); y += 3) {
    Vec3 p{}, direction{};
    frame.ray(100, y, &p, &direction);
    double nearest = 1e9;
    for (double ty : tube_y) nearest = std::min(nearest, std::fabs(p[1] - ty));
    if (nearest < 2.5 * points->radius) continue;
    for (int x = 20; x < 180; x += 20) {
      const uint8_t* rgb = pixel(image, x, y);
      EXPECT_TRUE(rgb[0] == background[0] && rgb[1] == background[1] && rgb[2] == background[2]) << "background between the tubes at " << x << "," << y;
      ++far;
    }
  }
  EXPECT_GT(far, 40u) << "rows between the tubes were checked";
}

// The pipeline traces once per request and draws the points; a change of splat size alone
// draws the same set.
TEST(TensorPoints, ThePipelineTracesOnceAndKeepsTheSetForTheSplatSize) {
  renderer::ViewPipeline pipeline(constant_tensor_box(4, {1.0, 0.2, 0.1, 0, 0, 0}));
  renderer::ViewRequest request;
  request.dvr = false;
  request.tensors = true;
  request.tensor = tubes_only(3);
  request.width = request.height = 64;
  const renderer::RenderSettings a = pipeline.update(request);
  ASSERT_TRUE(a.tensor_points);
  request.tensor.point_size = 3;
  const renderer::RenderSettings b = pipeline.update(request);
  EXPECT_EQ(a.tensor_points, b.tensor_points);
  EXPECT_EQ(b.tensor_point_size, 3);
  request.tensor.color = "fa";
  const renderer::RenderSettings c = pipeline.update(request);
  EXPECT_NE(c.tensor_points, a.tensor_points);
  EXPECT_FALSE(c.tensor_points->by_class);
  request.tensors = false;
  EXPECT_FALSE(pipeline.update(request).tensor_points);
}

}  // namespace
}  // namespace tetrascope::testing
