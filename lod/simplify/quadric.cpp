// Quadric error metrics, dissertation §3.1.4 (Garland and Zhou, "Quadric-based simplification
// in any dimension", 2005).
#include "tetrascope/lod/simplify/quadric.h"

#include <cmath>
#include <cstring>

namespace tetrascope::lod {

QuadricSet::QuadricSet(int dimension, size_t count) : d_(dimension), stride_(quadric::stride(dimension)), data_(count * stride_, 0.0) {}

namespace quadric {

size_t stride(int d) { return static_cast<size_t>(d * (d + 1) / 2 + d + 1); }

namespace {
inline size_t index(int i, int j, int d) {  // i <= j, row-major upper triangle
  return static_cast<size_t>(i * d - i * (i - 1) / 2 + (j - i));
}
}  // namespace

void clear(double* q, int d) { std::memset(q, 0, stride(d) * sizeof(double)); }

void add(double* q, const double* other, int d, double weight) {
  const size_t n = stride(d);
  for (size_t i = 0; i < n; ++i) q[i] += weight * other[i];
}

double evaluate(const double* q, const double* x, int d) {
  const double* b = q + d * (d + 1) / 2;
  double value = q[stride(d) - 1];
  for (int i = 0; i < d; ++i) {
    value += 2 * b[i] * x[i];
    value += q[index(i, i, d)] * x[i] * x[i];
    for (int j = i + 1; j < d; ++j) value += 2 * q[index(i, j, d)] * x[i] * x[j];
  }
  return value;
}

bool subspace(double* q, const double* const* points, int point_count, int d, double weight, double* measure) {
  double basis[3][kMaxQuadricDimension];
  int k = 0;
  double scale = 0, product = 1;
  for (int e = 1; e < point_count; ++e) {
    double* u = basis[k];
    for (int i = 0; i < d; ++i) u[i] = points[e][i] - points[0][i];
    double original = 0;
    for (int i = 0; i < d; ++i) original += u[i] * u[i];
    scale = std::max(scale, original);
    for (int j = 0; j < k; ++j) {
      double dot = 0;
      for (int i = 0; i < d; ++i) dot += u[i] * basis[j][i];
      for (int i = 0; i < d; ++i) u[i] -= dot * basis[j][i];
    }
    double length2 = 0;
    for (int i = 0; i < d; ++i) length2 += u[i] * u[i];
    if (length2 <= 1e-20 * std::max(scale, 1e-300)) return false;  // degenerate
    product *= std::sqrt(length2);
    double inv = 1 / std::sqrt(length2);
    for (int i = 0; i < d; ++i) u[i] *= inv;
    ++k;
  }
  if (measure) {  // k-dimensional volume of the simplex in R^d
    double factorial = 1;
    for (int i = 2; i <= k; ++i) factorial *= i;
    *measure = product / factorial;
  }
  if (weight == 0) return true;
  double p[kMaxQuadricDimension];
  for (int i = 0; i < d; ++i) {
    p[i] = 0;
    for (int e = 0; e < point_count; ++e) p[i] += points[e][i];
    p[i] /= point_count;
  }
  // A = I - sum u u^T ; Ap ; b = -Ap ; c = p.Ap
  double A[kMaxQuadricDimension][kMaxQuadricDimension];
  for (int i = 0; i < d; ++i) {
    for (int j = i; j < d; ++j) {
      double v = i == j ? 1.0 : 0.0;
      for (int e = 0; e < k; ++e) v -= basis[e][i] * basis[e][j];
      A[i][j] = A[j][i] = v;
    }
  }
  double* b = q + d * (d + 1) / 2;
  double c = 0;
  for (int i = 0; i < d; ++i) {
    double ap = 0;
    for (int j = 0; j < d; ++j) ap += A[i][j] * p[j];
    b[i] += -weight * ap;
    c += p[i] * ap;
    for (int j = i; j < d; ++j) q[index(i, j, d)] += weight * A[i][j];
  }
  q[stride(d) - 1] += weight * c;
  return true;
}

void position_only(double* q, const double N[9], const double p[3], int d, double weight) {
  double* b = q + d * (d + 1) / 2;
  double c = 0;
  for (int i = 0; i < 3; ++i) {
    double np = N[3 * i] * p[0] + N[3 * i + 1] * p[1] + N[3 * i + 2] * p[2];
    b[i] += -weight * np;
    c += p[i] * np;
    for (int j = i; j < 3; ++j) q[index(i, j, d)] += weight * N[3 * i + j];
  }
  q[stride(d) - 1] += weight * c;
}

bool minimise(const double* q, int d, double* x) {
  // Cholesky of A, with a pivot floor relative to the largest diagonal entry
  double L[kMaxQuadricDimension][kMaxQuadricDimension];
  double largest = 0;
  for (int i = 0; i < d; ++i) largest = std::max(largest, q[index(i, i, d)]);
  if (largest <= 0) return false;
  for (int j = 0; j < d; ++j) {
    double sum = q[index(j, j, d)];
    for (int k = 0; k < j; ++k) sum -= L[j][k] * L[j][k];
    if (sum <= 1e-9 * largest) return false;  // ill-conditioned: use the candidates instead
    L[j][j] = std::sqrt(sum);
    for (int i = j + 1; i < d; ++i) {
      double s = q[index(j, i, d)];
      for (int k = 0; k < j; ++k) s -= L[i][k] * L[j][k];
      L[i][j] = s / L[j][j];
    }
  }
  const double* b = q + d * (d + 1) / 2;
  double y[kMaxQuadricDimension];
  for (int i = 0; i < d; ++i) {
    double s = -b[i];
    for (int k = 0; k < i; ++k) s -= L[i][k] * y[k];
    y[i] = s / L[i][i];
  }
  for (int i = d - 1; i >= 0; --i) {
    double s = y[i];
    for (int k = i + 1; k < d; ++k) s -= L[k][i] * x[k];
    x[i] = s / L[i][i];
  }
  for (int i = 0; i < d; ++i) {
    if (!std::isfinite(x[i])) return false;
  }
  return true;
}

}  // namespace quadric
}  // namespace tetrascope::lod
