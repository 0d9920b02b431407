// The dissertation's artificial tensor fields (§7.4.4) on a Kuhn box of the unit cube, the
// same formulas as bench/tensor_fields.py writes as VTK (see there): the spiral (helicoids
// about the z axis through the centre, radial major eigenvector), the sphere case (linear
// along z inside radius 0.2, planar with a radial normal outside) and the sinusoidal case (the
// major eigenvector along y = y0 + A sin(K x), linear and planar slabs alternating along z).
#pragma once

#include <cmath>
#include <functional>
#include <numbers>

#include "mesh_checks.h"
#include "tetrascope/core/vec3.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::testing {

constexpr double kSpiralC = 0.25, kSpiralCore = 0.02, kSphereR = 0.2, kSineA = 0.1, kSineK = 4 * std::numbers::pi;

// l1 e1 e1^T + l2 e2 e2^T + l3 e3 e3^T
inline storage::SymmetricTensor frame_tensor(const Vec3& e1, const Vec3& e2, const Vec3& e3, double l1, double l2, double l3) {
  auto c = [&](int i, int j) { return l1 * e1[size_t(i)] * e1[size_t(j)] + l2 * e2[size_t(i)] * e2[size_t(j)] + l3 * e3[size_t(i)] * e3[size_t(j)]; };
  return {c(0, 0), c(1, 1), c(2, 2), c(0, 1), c(1, 2), c(0, 2)};
}

inline storage::SymmetricTensor spiral_tensor(const Vec3& p) {
  const double x = p[0] - 0.5, y = p[1] - 0.5, r2 = x * x + y * y;
  if (r2 < kSpiralCore * kSpiralCore) return {1, 1, 1, 0, 0, 0};
  const Vec3 n = normalise(Vec3{kSpiralC * y / r2, -kSpiralC * x / r2, 1.0});
  const Vec3 e1 = normalise(Vec3{x, y, 0});
  return frame_tensor(e1, cross(n, e1), n, 1.0, 0.6, 0.05);
}

inline storage::SymmetricTensor sphere_tensor(const Vec3& p) {
  const Vec3 c{p[0] - 0.5, p[1] - 0.5, p[2] - 0.5};
  if (length(c) < kSphereR) return {0.1, 0.1, 1.0, 0, 0, 0};
  const Vec3 n = normalise(c, {1, 0, 0});
  return {1 - 0.95 * n[0] * n[0], 1 - 0.95 * n[1] * n[1], 1 - 0.95 * n[2] * n[2], -0.95 * n[0] * n[1], -0.95 * n[1] * n[2], -0.95 * n[0] * n[2]};
}

inline storage::SymmetricTensor sinusoidal_tensor(const Vec3& p) {
  const Vec3 e1 = normalise(Vec3{1, kSineA * kSineK * std::cos(kSineK * p[0]), 0});
  const Vec3 e3{0, 0, 1};
  return frame_tensor(e1, cross(e3, e1), e3, 1.0, 0.5 - 0.4 * std::sin(4 * std::numbers::pi * p[2]), 0.1);
}

// A Kuhn box of n^3 cubes with the tensor attribute "D" (and kuhn_box's scalar "f").
inline storage::TetMesh artificial_tensor_box(int n, const std::function<storage::SymmetricTensor(const Vec3&)>& tensor) {
  storage::TetMesh m = kuhn_box(n, 0.0, [](float x, float, float) { return x; });
  storage::Attribute d{{"D", 6, storage::AttributeKind::kTensor, true}, {}};
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float six[6];
    storage::store_tensor(tensor({m.x[v], m.y[v], m.z[v]}), six);
    d.values.insert(d.values.end(), six, six + 6);
  }
  m.attributes.push_back(d);
  return m;
}

}  // namespace tetrascope::testing
