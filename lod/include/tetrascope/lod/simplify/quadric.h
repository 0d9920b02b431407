// Quadric error metrics in R^(3+A): position and normalised attributes (dissertation §3.1.4,
// after Garland and Zhou 2005). Q(x) = x^T A x + 2 b^T x + c, A symmetric positive
// semi-definite, stored packed; quadrics of a set are added component-wise.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace tetrascope::lod {

constexpr int kMaxQuadricDimension = 3 + 16;

// Quadrics of one dimension d, `count` of them in one flat array.
class QuadricSet {
 public:
  QuadricSet(int dimension, size_t count);
  int dimension() const { return d_; }
  size_t stride() const { return stride_; }
  double* at(size_t i) { return &data_[i * stride_]; }
  const double* at(size_t i) const { return &data_[i * stride_]; }
  void resize(size_t count) { data_.resize(count * stride_, 0.0); }

 private:
  int d_;
  size_t stride_;
  std::vector<double> data_;
};

// Operations on one packed quadric q[stride] of dimension d: A (d(d+1)/2, row-major upper
// triangle), then b (d), then c.
namespace quadric {
size_t stride(int d);
void clear(double* q, int d);
void add(double* q, const double* other, int d, double weight = 1.0);
double evaluate(const double* q, const double* x, int d);
// Fundamental quadric of the affine subspace through `points[0]` spanned by the edge vectors
// to the other points (k+1 points, k <= 3), anchored at their centroid: A = I - sum e_i e_i^T
// over the Gram-Schmidt basis. Returns false (q untouched) when the points are degenerate.
// `measure`, when given, receives the simplex's k-volume in R^d (weight 0: measure only).
bool subspace(double* q, const double* const* points, int point_count, int d, double weight, double* measure = nullptr);
// A quadric that measures distance in the position block only: A = N (3x3), b = -N p, c = p^T N p.
void position_only(double* q, const double N[9], const double p[3], int d, double weight);
// Minimises q: solves A x = -b by Cholesky; false when A is too ill-conditioned.
bool minimise(const double* q, int d, double* x);
}  // namespace quadric

}  // namespace tetrascope::lod
