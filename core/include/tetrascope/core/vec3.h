// The small 3-vector arithmetic every library needs (geometry, cameras, quadrics). Doubles:
// positions are stored as float, geometry is computed in double.
#pragma once

#include <array>
#include <cmath>

namespace tetrascope {

using Vec3 = std::array<double, 3>;

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Vec3 operator*(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline Vec3 operator*(double s, const Vec3& a) { return a * s; }
inline double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double length(const Vec3& a) { return std::sqrt(dot(a, a)); }
// The unit vector along a; a zero vector gives fallback (+z unless said otherwise).
inline Vec3 normalise(const Vec3& a, const Vec3& fallback = {0, 0, 1}) {
  const double l = length(a);
  return l > 0 ? Vec3{a[0] / l, a[1] / l, a[2] / l} : fallback;
}

}  // namespace tetrascope
