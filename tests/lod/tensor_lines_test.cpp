// Lines through a symmetric tensor field (the axes of §7.4.2's stream tubes): they follow the
// major eigenvector with its sign kept continuous, stop where the linear anisotropy falls
// under the threshold, and a tensor has no critical points to seed from.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "mesh_checks.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/lod/field/streamlines.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::testing {
namespace {

using storage::SymmetricTensor;

// λ1 e1 e1^T + λ2 e2 e2^T + λ3 e3 e3^T for orthonormal e1, e2 (in the xy plane) and e3 = z.
SymmetricTensor from_frame(double l1, double l2, double l3, double e1x, double e1y) {
  const double e2x = -e1y, e2y = e1x;
  return {l1 * e1x * e1x + l2 * e2x * e2x, l1 * e1y * e1y + l2 * e2y * e2y, l3, l1 * e1x * e1y + l2 * e2x * e2y, 0, 0};
}

// The box [-1, 1]^2 x [0, 0.25] with the tensor `field(x, y)` at its vertices.
template <class Field>
storage::TetMesh tensor_slab(int n, Field field) {
  storage::TetMesh m = kuhn_box(n, 0, [](float, float, float) { return 0.f; });
  m.attributes.clear();
  storage::Attribute tensor{{"D", 6, storage::AttributeKind::kTensor, true}, {}};
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    m.x[v] = 2 * m.x[v] - 1;
    m.y[v] = 2 * m.y[v] - 1;
    m.z[v] = 0.25f * m.z[v];
    float six[6];
    storage::store_tensor(field(m.x[v], m.y[v]), six);
    tensor.values.insert(tensor.values.end(), six, six + 6);
  }
  m.attributes.push_back(tensor);
  return m;
}

// Major eigenvectors tangent to circles about the z axis: the lines are circles.
TEST(TensorLines, FollowTheMajorEigenvectorRoundACircleWithoutTurningBack) {
  const storage::TetMesh mesh = tensor_slab(24, [](double x, double y) {
    const double r = std::hypot(x, y);
    return r < 1e-9 ? SymmetricTensor{1, 1, 1, 0, 0, 0} : from_frame(3, 1, 0.5, -y / r, x / r);
  });
  const std::vector<uint32_t> opposite = pair_faces(mesh.tets).opposite;
  const lod::StreamlineTracer tracer(mesh, opposite, "D");
  lod::StreamlineOptions options;
  options.max_length = std::numbers::pi * 0.5;  // half a circle of radius 0.5 each way
  const std::vector<Vec3> seeds = {{0.5, 0, 0.125}};
  const lod::Streamlines lines = tracer.trace(std::span<const Vec3>(seeds), options);
  ASSERT_EQ(lines.line_count(), 1u);
  ASSERT_GT(lines.point_count(), 20u);
  const double diagonal = std::sqrt(4.0 + 4.0 + 0.0625);
  double deviation = 0, worst = 0, turned = 0, previous_angle = std::atan2(lines.y[0], lines.x[0]);
  std::vector<double> steps;
  for (size_t i = 0; i < lines.point_count(); ++i) {
    const double off = std::fabs(std::hypot(lines.x[i], lines.y[i]) - 0.5);
    deviation += off;
    worst = std::max(worst, off);
    EXPECT_NEAR(lines.z[i], 0.125, 1e-4);
    const double angle = std::atan2(lines.y[i], lines.x[i]);
    double step = angle - previous_angle;
    step -= 2 * std::numbers::pi * std::round(step / (2 * std::numbers::pi));
    if (i > 0) steps.push_back(step);
    turned += step;
    previous_angle = angle;
    if (i > 0) {
      const double along = lines.vx[i] * lines.vx[i - 1] + lines.vy[i] * lines.vy[i - 1] + lines.vz[i] * lines.vz[i - 1];
      EXPECT_GT(along, 0) << "point " << i << ": the written directions run one way";
    }
  }
  for (size_t i = 0; i < steps.size(); ++i)  // one way round: a sign flip of the eigenvector would turn the line back
    EXPECT_GT(steps[i] * turned, 0) << "step " << i;
  EXPECT_LT(deviation / double(lines.point_count()), 0.005 * diagonal) << "mean distance from the exact circle";
  EXPECT_LT(worst, 0.01 * diagonal);
  EXPECT_NEAR(std::fabs(turned), 2 * std::numbers::pi, 0.05) << "both directions together go once round";
  EXPECT_NEAR(lines.values[0][0], 2.0 / 4.5, 0.02) << "the line's magnitude is cl";
  EXPECT_THROW(tracer.critical_points(), std::invalid_argument);
}

// Linear (cl = 0.4) for x < 0, turning isotropic (cl = 0) by x = 0.5: a line along x stops
// where cl falls under the threshold given as the zero speed.
TEST(TensorLines, StopWhereTheLinearAnisotropyFallsUnderTheThreshold) {
  const storage::TetMesh mesh = tensor_slab(16, [](double x, double) {
    const double spread = std::clamp(1 - 2 * x, 0.0, 1.0);  // 1 for x <= 0, 0 for x >= 0.5
    return from_frame(1 + 2 * spread, 1, 1, 1, 0);
  });
  const std::vector<uint32_t> opposite = pair_faces(mesh.tets).opposite;
  const lod::StreamlineTracer tracer(mesh, opposite, "D");
  lod::StreamlineOptions options;
  options.zero_speed = 0.2;  // cl = 2s / (3 + 2s) = 0.2 at s = 3/8, x = 0.3125
  const std::vector<Vec3> seeds = {{-0.5, 0.1, 0.125}};
  const lod::Streamlines lines = tracer.trace(std::span<const Vec3>(seeds), options);
  ASSERT_EQ(lines.line_count(), 1u);
  EXPECT_EQ(lines.stops[size_t(lod::StopReason::zero_velocity)], 1u);
  EXPECT_EQ(lines.stops[size_t(lod::StopReason::boundary)], 1u) << "the other direction runs to x = -1";
  double reached = -1;
  for (size_t i = 0; i < lines.point_count(); ++i) reached = std::max(reached, double(lines.x[i]));
  EXPECT_GE(reached, 0.3125 - 1e-3);
  EXPECT_LE(reached, 0.3125 + 0.13) << "within a step (at most two cells) of where cl = 0.2";
}

}  // namespace
}  // namespace tetrascope::testing
