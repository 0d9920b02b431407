// Quadric error metrics (lod/quadric.h): a fundamental quadric measures squared distance to its
// subspace, in space and in R^(3+A); its minimum is the point it was anchored at.
#include "tetrascope/lod/simplify/quadric.h"

#include <gtest/gtest.h>

namespace tetrascope::testing {
namespace {

TEST(Quadric, AQuadricOfAPlaneIsTheSquaredDistanceToIt) {
  const int d = 3;
  const double a[3] = {0, 0, 2}, b[3] = {1, 0, 2}, c[3] = {0, 1, 2};  // the plane z = 2
  const double* triangle[3] = {a, b, c};
  double q[16] = {};
  ASSERT_GE(sizeof q / sizeof q[0], lod::quadric::stride(d));
  ASSERT_TRUE(lod::quadric::subspace(q, triangle, 3, d, 1.0));
  const double on_plane[3] = {5, -3, 2}, above[3] = {0.3, 7, 2.7}, below[3] = {-4, 1, -1};
  EXPECT_NEAR(lod::quadric::evaluate(q, on_plane, d), 0, 1e-12);
  EXPECT_NEAR(lod::quadric::evaluate(q, above, d), 0.49, 1e-12);
  EXPECT_NEAR(lod::quadric::evaluate(q, below, d), 9, 1e-12);
  // weights scale it, and quadrics of a set add: two parallel planes z = 2 and z = 0
  double sum[16] = {}, other[16] = {};
  const double a0[3] = {0, 0, 0}, b0[3] = {1, 0, 0}, c0[3] = {0, 1, 0};
  const double* floor_triangle[3] = {a0, b0, c0};
  ASSERT_TRUE(lod::quadric::subspace(other, floor_triangle, 3, d, 2.0));
  lod::quadric::add(sum, q, d);
  lod::quadric::add(sum, other, d);
  EXPECT_NEAR(lod::quadric::evaluate(sum, above, d), 0.49 + 2 * 2.7 * 2.7, 1e-12);
}

TEST(Quadric, FundamentalQuadricMeasuresDistanceToTheSubspace) {
  const int d = 4;
  double p[4][4] = {{0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  for (auto& v : p) v[3] = 0.5 * v[0] + 0.2 * v[1] + 0.1 * v[2] + 0.3;
  const double* pts[4] = {p[0], p[1], p[2], p[3]};
  double q[32] = {};
  ASSERT_TRUE(lod::quadric::subspace(q, pts, 4, d, 1.0));
  for (auto& v : p) EXPECT_NEAR(lod::quadric::evaluate(q, v, d), 0, 1e-12);
  double off[4] = {0.3, 0.3, 0.3, 0.5 * 0.3 + 0.2 * 0.3 + 0.1 * 0.3 + 0.3 + 0.1};
  EXPECT_NEAR(lod::quadric::evaluate(q, off, d), 0.01 / (1 + 0.25 + 0.04 + 0.01), 1e-12);
  // adding a vertex quadric at p1 makes the minimum p1
  const double* one[1] = {p[1]};
  lod::quadric::subspace(q, one, 1, d, 1e-3);
  double x[4];
  ASSERT_TRUE(lod::quadric::minimise(q, d, x));
  for (int i = 0; i < d; ++i) EXPECT_NEAR(x[i], p[1][i], 1e-9);
  // degenerate points give no quadric
  const double* flat[3] = {p[0], p[0], p[1]};
  EXPECT_FALSE(lod::quadric::subspace(q, flat, 3, d, 1.0));
}

}  // namespace
}  // namespace tetrascope::testing
